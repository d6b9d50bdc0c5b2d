"""The README and the pages of docs/ hold together, and the figures they copy from elsewhere are
the ones there.

- every relative link points to a file that exists, and every `#anchor` to a heading of it
  (GitHub's slugs); every picture exists, is a PNG a browser test writes, and is shown;
- every page of docs/ is linked from the README; the two commands are the scripts CI runs;
- the limits list of docs/safety.md is what `biped-studio limits` prints;
- the built-in robots' DOF and masses in docs/robots.md are their URDFs' own (read here with
  ElementTree, not with the studio's loader);
- the Speed table has the columns `bench --markdown` prints, and its "every target is met"
  agrees with its marks;
- the paper's outcomes quoted beside the simulated experiments and Table 4 are the paper's.
"""

from __future__ import annotations

import argparse
import re
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from functools import cache
from pathlib import Path

import pytest

from tests.conftest import REPO

DOCS = REPO / "docs"
LINK = re.compile(r"(!?)\[([^\]]*)\]\(([^)\s]+)\)")
"""`[text](target)` and `![alt](target)`; targets here hold no spaces or parentheses."""
PUBLISH = re.compile(r"""publish\(\s*\w+\s*,\s*["']([\w.-]+\.png)["']""")


def pages() -> list[Path]:
    return [REPO / "README.md", *sorted(DOCS.glob("*.md"))]


def _prose_lines(text: str) -> Iterator[tuple[int, str]]:
    """(line number, line) outside fenced code blocks, with inline code removed."""
    fenced = False
    for n, line in enumerate(text.splitlines(), 1):
        if line.lstrip().startswith("```"):
            fenced = not fenced
            continue
        if not fenced:
            yield n, re.sub(r"`[^`]*`", "", line)


def links(path: Path) -> Iterator[tuple[int, bool, str]]:
    """(line, is_image, target) of every link of a markdown file."""
    for n, line in _prose_lines(path.read_text(encoding="utf-8")):
        for match in LINK.finditer(line):
            yield n, match.group(1) == "!", match.group(3)


def slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, formatting and punctuation dropped, spaces to
    hyphens (letters of any script, digits, `_` and `-` kept)."""
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading.strip().lower())
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


@cache
def anchors(path: Path) -> frozenset[str]:
    """Every heading's anchor, repeated headings numbered -1, -2 as GitHub does."""
    seen: dict[str, int] = {}
    out = set()
    for _, line in _prose_lines(path.read_text(encoding="utf-8")):
        match = re.match(r"#{1,6}\s+(.*)", line)
        if match:
            base = slug(match.group(1))
            count = seen.get(base, 0)
            seen[base] = count + 1
            out.add(base if count == 0 else f"{base}-{count}")
    return frozenset(out)


def broken_links(path: Path) -> list[str]:
    broken = []
    for n, _, target in links(path):
        if re.match(r"[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto:
            continue
        file_part, _, anchor = target.partition("#")
        where = (path.parent / file_part).resolve() if file_part else path
        if not where.exists():
            broken.append(f"{path.name}:{n}: {target} (no such file)")
        elif anchor and where.suffix == ".md" and anchor not in anchors(where):
            broken.append(f"{path.name}:{n}: {target} (no heading with that anchor)")
    return broken


def test_every_relative_link_and_anchor_resolves() -> None:
    broken = [b for page in pages() for b in broken_links(page)]
    assert not broken, "broken links:\n" + "\n".join(broken)


def test_the_link_check_sees_a_broken_link(tmp_path: Path) -> None:
    (tmp_path / "other.md").write_text("# A heading — with (punctuation)\n\n## Twice\n\n## Twice\n")
    page = tmp_path / "page.md"
    page.write_text(
        "[ok](other.md#a-heading--with-punctuation) [ok](other.md#twice-1) [ok](#here)\n"
        "[gone](missing.md) [bad anchor](other.md#nowhere) ![gone](pic.png)\n"
        "`[code](not-a-link.md)`\n```\n[fenced](not-a-link.md)\n```\n# Here\n"
    )
    assert broken_links(page) == [
        "page.md:2: missing.md (no such file)",
        "page.md:2: other.md#nowhere (no heading with that anchor)",
        "page.md:2: pic.png (no such file)",
    ]


def test_every_picture_exists_is_written_by_a_browser_test_and_is_shown() -> None:
    shown = {
        (page.parent / target).resolve()
        for page in pages()
        for _, is_image, target in links(page)
        if is_image
    }
    assert shown, "no pictures found: the link pattern is wrong"
    for picture in shown:
        assert picture.is_file(), picture
        assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", f"{picture} is not a PNG"
    written = {
        (REPO / "static" / name).resolve()
        for test in (REPO / "tests" / "browser").glob("test_*.py")
        for name in PUBLISH.findall(test.read_text(encoding="utf-8"))
    }
    assert shown <= written, f"pictures no browser test writes: {sorted(shown - written)}"
    assert written <= shown, f"pictures written but shown nowhere: {sorted(written - shown)}"
    assert set((REPO / "static").glob("*.png")) <= shown


def test_every_docs_page_is_linked_from_the_readme() -> None:
    readme = REPO / "README.md"
    linked = {(REPO / t.partition("#")[0]).resolve() for _, _, t in links(readme)}
    missing = [p.name for p in sorted(DOCS.glob("*.md")) if p.resolve() not in linked]
    assert not missing, f"docs pages the README does not link: {missing}"


def test_the_readme_is_a_front_page() -> None:
    """Short: what it is, two commands, a picture, a tour, links (the reference is in docs/)."""
    text = (REPO / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 130
    headings = [line for _, line in _prose_lines(text) if line.startswith("## ")]
    wanted = ["## Two commands", "## A tour", "## Documentation"]
    assert [h for h in headings if h in wanted] == wanted, headings


def test_the_two_commands_are_the_scripts_ci_runs() -> None:
    text = (REPO / "README.md").read_text(encoding="utf-8")
    commands = re.findall(r"```bash\n(\./scripts/\w+)\s", text)
    assert commands == ["./scripts/studio", "./scripts/test"]
    for command in commands:
        script = REPO / command
        assert script.is_file() and script.stat().st_mode & 0o111, f"{command} is not executable"
    ci = (REPO / ".ci" / "run").read_text(encoding="utf-8")
    assert re.search(r"^exec \./scripts/test$", ci, re.M), ".ci/run no longer runs ./scripts/test"
    assert "biped-studio serve" in (REPO / "scripts" / "studio").read_text(encoding="utf-8")


def _fenced_blocks(path: Path) -> list[str]:
    return re.findall(r"^```\w*\n(.*?)^```", path.read_text(encoding="utf-8"), re.M | re.S)


def test_the_limits_listed_in_safety_are_what_limits_prints(capsys) -> None:
    from app.cli import limits

    assert limits.run(argparse.Namespace(json=False)) == 0
    printed = capsys.readouterr().out
    (listed,) = [b for b in _fenced_blocks(DOCS / "safety.md") if b.startswith("URDF file size")]
    assert listed == printed


def _table(path: Path, header_start: str) -> list[list[str]]:
    """The rows (cells stripped) of the markdown table whose header starts so."""
    lines = path.read_text(encoding="utf-8").splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(header_start))
    rows = []
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        rows.append([cell.strip() for cell in re.split(r"(?<!\\)\|", line)[1:-1]])
    return rows


def _urdf_facts(urdf: Path) -> tuple[int, int, float]:
    """(actuated joints, passive loop joints, total mass [kg]) straight from the XML."""
    root = ET.parse(urdf).getroot()
    moving = [j.get("name") for j in root.iter("joint") if j.get("type") != "fixed"]
    passive = {
        name
        for loop in root.iter("loop_closure")
        for name in loop.get("passive_joints", "").split()
    }
    mass = sum(float(m.get("value", "nan")) for m in root.iter("mass"))
    return len(moving) - len(passive & set(moving)), len(passive), mass


@pytest.mark.parametrize(
    "row", _table(DOCS / "robots.md", "| name | DOF | mass |"), ids=lambda r: r[0]
)
def test_builtin_robot_table_is_what_the_urdfs_say(row: list[str]) -> None:
    name = row[0].split("`")[1]
    actuated, passive, mass_kg = _urdf_facts(REPO / "robots" / name / f"{name}.urdf")
    dof = re.fullmatch(r"(\d+)(?: \(\+(\d+) passive\))?", row[1])
    assert dof, row[1]
    assert int(dof.group(1)) == actuated and int(dof.group(2) or 0) == passive
    printed = re.fullmatch(r"([\d.]+) kg", row[2])
    assert printed, row[2]
    decimals = len(printed.group(1).partition(".")[2])
    assert float(printed.group(1)) == pytest.approx(mass_kg, abs=0.5 * 10**-decimals)


def test_the_speed_table_is_the_one_bench_prints() -> None:
    from app.bench.report import markdown_table

    where = {"cpu": "cpu", "cores": 2, "load_1min": 0.0, "python": "3", "date_utc": "now"}
    header = markdown_table([], where).splitlines()[:2]
    text = (DOCS / "speed.md").read_text(encoding="utf-8")
    assert "\n".join(header) in text
    rows = _table(DOCS / "speed.md", header[0])
    assert rows and all(len(row) == 5 for row in rows)
    assert re.search(
        r"^Machine: .+, \d+ cores, load [\d.]+ at the start(, [\d.]+ at the end)?; Python ",
        text,
        re.M,
    )
    missed = [row[0] for row in rows if "✗" in row[2]]
    if "Every target is met in this run" in text:
        assert not missed, f"the text says every target is met; these are not: {missed}"


# The paper's outcomes, typed here from the paper on purpose (spring-compensation paper, section
# 5: the 5 cm squats stay up with and without (Figs. 5, 9); at 4.3 cm "without spring
# compensation, the robot fell over" (Fig. 16); fast squats complete both ways (Figs. 19, 20);
# the deeper squat "fell down while using only the position control mode" (Fig. 22)).
PAPER_OUTCOMES = (
    ("stays up", "stays up"),
    ("falls", "stays up"),
    ("stays up", "stays up"),
    ("falls", "stays up"),
)


@pytest.mark.parametrize(
    "header",
    [
        "| experiment | paper (Roban): without / with | simulated",
        "| experiment | paper (Roban): without / with | no compensation",
    ],
)
def test_the_papers_outcomes_beside_the_simulated_experiments(header: str) -> None:
    from app.core.simulation.experiments import PAPER_EXPERIMENTS

    rows = _table(DOCS / "simulation.md", header)
    quoted = [tuple(cell.replace("*", "").strip() for cell in row[1].split("/")) for row in rows]
    assert quoted == list(PAPER_OUTCOMES)
    assert [(e.paper_without, e.paper_with) for e in PAPER_EXPERIMENTS] == list(PAPER_OUTCOMES)


def test_table4_of_the_gait_paper_is_quoted_as_printed() -> None:
    """Table 4 prints max joint input 9.8 N·m (proposed) and 11.5 N·m (previous); the specific
    resistances 0.772 and 1.299 are the paper's measured ones (app.core.papers.TABLE4)."""
    from app.core.papers import TABLE4

    rows = {row[0]: row for row in _table(DOCS / "gait.md", "| the paper's case on dircon_biped")}
    tau = rows["max joint torque [N·m]"][4]
    sr = rows["SR incl. impacts"][4]
    assert tau == f"9.8 / 11.5, {9.8 / 11.5:.2f}"
    assert TABLE4.max_abs_tau_Nm == (9.8, 11.5)
    assert sr == f"{TABLE4.sr[0]} / {TABLE4.sr[1]}, {TABLE4.ratio('sr'):.2f}"
