"""`biped-studio bench`: every figure stands beside a same-run baseline, with their ratio.

Timings themselves are not asserted (they depend on the machine); what is checked is the
report's shape and arithmetic, and that an entry's baseline is what it says it is.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys

import pytest

from app.bench import ENTRIES
from app.bench.report import Figure, markdown_table


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "app", "bench", *args],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )


def test_ratio_is_value_over_baseline_and_absent_without_one():
    assert Figure("x", 3.0, "ms", "", None, 1.5, "b").ratio == pytest.approx(2.0)
    assert Figure("x", 3.0, "ms", "", None, None, "").ratio is None
    assert Figure("x", 3.0, "ms", "", None, 0.0, "b").ratio is None


def test_an_upper_bound_target_reads_and_holds_as_written_by_hand():
    assert Figure.at_most("x", 3.0, "s", 10.0, 1.5, "b", "n") == Figure(
        "x", 3.0, "s", "≤ 10 s", True, 1.5, "b", "n"
    )
    assert Figure.at_most("x", 0.3, "ms", 0.25, None, "", stat="p95") == Figure(
        "x", 0.3, "ms", "p95 ≤ 0.25 ms", False, None, ""
    )
    assert Figure.at_most("x", 10.0, "s", 10.0, None, "").ok  # the bound itself meets it
    assert not Figure.at_most("x", 1.0, "s", 10.0, None, "", met=False).ok


def test_markdown_table_has_a_row_per_figure_and_names_the_machine():
    figures = [
        Figure("drag", 4.0, "ms", "p95 ≤ 5 ms", True, 2.0, "placo"),
        Figure("plan", 12.0, "s", "≤ 10 s", False, None, ""),
    ]
    where = {"cpu": "Test CPU", "cores": 3, "load_1min": 0.5, "python": "3", "date_utc": "D"}
    table = markdown_table(figures, where).splitlines()
    assert table[0].startswith("| what | target | now | baseline")
    assert table[2].split("|")[5].strip() == "2"  # 4 / 2
    assert table[3].split("|")[5].strip() == "—"
    assert "Test CPU, 3 cores" in table[-1] and "D UTC" in table[-1]


def test_the_stability_line_gives_the_workload_before_and_after():
    where = {
        "cpu": "C", "cores": 1, "load_1min": 0.0, "python": "3", "date_utc": "D",
        "reference_before_s": 0.010, "reference_after_s": 0.012, "load_1min_after": 2.0,
    }  # fmt: skip
    last = markdown_table([], where).splitlines()[-1]
    assert "10.0 ms before the run and 12.0 ms after (1.20×)" in last
    assert "2.0 at the end" in last and "not a baseline" in last


def test_no_entry_measures_against_a_machine_reference():
    from pathlib import Path

    import app.bench

    for module in Path(app.bench.__file__).parent.glob("*.py"):
        text = module.read_text()
        assert "beside_reference" not in text and '"machine reference"' not in text, module


def test_a_pipe_in_a_figures_text_stays_inside_its_cell():
    figure = Figure("IK", 3.0, "ms", "≤ 2×", True, 1.5, "placo's loop to |dq| < 1e-6")
    where = {"cpu": "C", "cores": 1, "load_1min": 0.0, "python": "3", "date_utc": "D"}
    row = markdown_table([figure], where).splitlines()[2]
    cells = re.split(r"(?<!\\)\|", row)[1:-1]  # markdown splits on unescaped pipes only
    assert len(cells) == 5
    assert cells[3].strip().endswith("to \\|dq\\| < 1e-6") and cells[4].strip() == "2"


def test_registry_holds_every_entry_in_run_order():
    assert list(ENTRIES)[:3] == ["load", "slider", "drag"]
    for name in (
        "feedforward",
        "compensation_slider",
        "plan",
        "plan_fine",
        "simulate",
        "simulate_parts",
        "simulate_click",
    ):
        assert name in ENTRIES


def test_json_reports_figures_beside_baselines():
    result = run("--json", "--only", "load,slider", "--robot", "servo_biped", "--repeats", "20")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    machine = report["machine"]
    assert machine["cores"] >= 1
    # The fixed workload runs before and after, as a stability check, not as a baseline.
    assert machine["reference_before_s"] > 0.0 and machine["reference_after_s"] > 0.0
    assert set(report) >= {"load", "slider", "figures"}
    assert "drag" not in report  # --only
    figures = report["figures"]
    assert len(figures) == 2  # load; slider (servo_biped is both robots here)
    for figure in figures:
        assert figure["baseline"] > 0.0
        assert "machine reference" not in figure["baseline_what"]
        assert figure["ratio"] == pytest.approx(figure["value"] / figure["baseline"])
    # The load's baseline is the core load alone, which the studio's load contains.
    assert report["load"]["core_load_s"] == figures[0]["baseline"]


def test_unknown_entry_is_named_with_the_known_ones():
    result = run("--only", "nonsense")
    assert result.returncode != 0
    assert "nonsense" in result.stderr and "feedforward" in result.stderr
