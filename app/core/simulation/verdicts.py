"""What a simulated run did, in words and numbers: stays up, leans on the lifted foot, slips,
falls; and for a motion that travels, how far it went and where its feet landed.

The rules (numpy only; `judge` takes the run's arrays, so each rule is testable alone):

- **falls**: the step loop's fall test (`engine`), with when and why, and the first link other
  than a foot that came down on the floor and when (`floor_link`: it may touch after the
  torso has tilted past the fall test);
- **leans on the lifted foot**: a foot the plan has in the air (`Trajectory.contacts` false)
  carries more than `LEAN_LOAD_FRACTION` of the robot's weight (vertical floor force) for
  more than `LEAN_MIN_S` in a row. This is the paper's failure at the 4.3 cm shift without
  compensation: the robot tips towards its free leg and stands on it, which the floor of a
  simulation allows and a real robot at the paper's height does not survive;
- **slips**: a foot the plan has on the floor slides more than `SLIP_M` horizontally from
  where it touched down (`result.slip_m`);
- **stays up** otherwise.
The worst applies (falls, then leans, then slips); the one-line text adds the others.

A motion *travels* when its plan lands a foot more than `TRAVEL_MIN_M` (horizontally) from where
that foot lifted (a CoM shift over planted feet does not travel). It then also gets: the distance planned (the plan's root, start to end) and covered (the
simulated root body's displacement from MuJoCo, projected on the planned direction); each
footstep's placement error (the simulated sole centre against the plan's, horizontally, at the
middle of the planned stance that follows a swing); the swing-foot scuffs (any touch of a foot
planned in the air, carrying more than `TOUCH_LOAD_FRACTION` of the weight). Everything is
counted up to the fall, not after.
"""

from __future__ import annotations

import dataclasses
from typing import Literal

import numpy as np

LEAN_LOAD_FRACTION = 0.05
"""A foot planned in the air that carries more than this fraction of the weight leans."""
LEAN_MIN_S = 0.1
"""…for longer than this [s], in a row, to count as leaning (shorter touches are scuffs)."""
TOUCH_LOAD_FRACTION = 0.02
"""A sole carrying more than this fraction of the weight touches the floor (scuffs)."""
SLIP_M = 0.01
"""A stance sole sliding more than this [m] from where it touched down slips."""
TRAVEL_MIN_M = 0.02
"""A plan that lands a foot further than this [m] from where it lifted travels."""
SIDES = ("left", "right")
Kind = Literal["stays up", "leans on the lifted foot", "slips", "falls"]


@dataclasses.dataclass(frozen=True)
class Episode:
    """A stretch of samples during which a foot planned in the air touched the floor."""

    side: str
    start_s: float
    duration_s: float
    """Number of samples × the sample step [s]."""
    peak_load_frac: float
    """Largest vertical floor force on that sole over the weight [1]."""


@dataclasses.dataclass(frozen=True)
class Footstep:
    """One planned landing: where the plan puts the sole, where the simulation had it."""

    side: str
    planned_touchdown_s: float
    planned_xy_m: tuple[float, float]
    simulated_xy_m: tuple[float, float]
    """The simulated sole centre at the middle of the planned stance [m]."""

    @property
    def error_m(self) -> float:
        dx = self.simulated_xy_m[0] - self.planned_xy_m[0]
        dy = self.simulated_xy_m[1] - self.planned_xy_m[1]
        return float(np.hypot(dx, dy))


@dataclasses.dataclass(frozen=True)
class Travel:
    distance_planned_m: float
    """Horizontal distance from the plan's first root position to its last [m]."""
    distance_covered_m: float
    """The simulated root's displacement along the planned direction [m], to the last
    simulated sample (the fall's, after a fall)."""
    footsteps: tuple[Footstep, ...]

    @property
    def fraction(self) -> float:
        return self.distance_covered_m / self.distance_planned_m if self.distance_planned_m else 0.0


@dataclasses.dataclass(frozen=True)
class Verdict:
    """What the run did (module docstring); `text` is its one line."""

    kind: Kind
    text: str
    fall_time_s: float | None
    fall_reason: str
    floor_link: str
    """After a fall, the first link other than a foot on the floor ("" if none came down)."""
    floor_link_time_s: float | None
    """When `floor_link` first touched the floor [s] (None if none did)."""
    lean: Episode | None
    """The first episode of leaning on a lifted foot (longer than LEAN_MIN_S), if any."""
    lifted_foot_load_s: float
    """Total time a foot planned in the air carried more than LEAN_LOAD_FRACTION of the
    weight [s] (all episodes, short ones too)."""
    lifted_foot_peak_load_frac: float
    """Largest load on a foot planned in the air over the weight [1]; 0 if none is lifted."""
    slip_m: float
    """Largest slide of a stance sole from its touch-down [m]."""
    slip_side: str
    slip_time_s: float | None
    """When the largest slide was reached [s] (None without a stance sample)."""
    scuffs: tuple[Episode, ...]
    """Touches of a foot planned in the air (> TOUCH_LOAD_FRACTION) that are not leaning (the
    text names them for a travelling motion; otherwise it gives the lifted foot's load time)."""
    travel: Travel | None
    """Only for a motion that travels (TRAVEL_MIN_M)."""

    def summary(self) -> dict[str, object]:
        """The verdict's keys of `simulate --json`."""
        out: dict[str, object] = {
            "verdict": self.text,
            "verdict_kind": self.kind,
            "lifted_foot_load_s": self.lifted_foot_load_s,
            "lifted_foot_peak_load_frac": self.lifted_foot_peak_load_frac,
            "lean_start_s": None if self.lean is None else self.lean.start_s,
            "lean_side": None if self.lean is None else self.lean.side,
            "scuffs": len(self.scuffs),
            "fall_link": self.floor_link or None,
            "fall_link_time_s": self.floor_link_time_s,
        }
        if self.travel is not None:
            out["distance_planned_m"] = self.travel.distance_planned_m
            out["distance_covered_m"] = self.travel.distance_covered_m
            out["footstep_errors_m"] = [step.error_m for step in self.travel.footsteps]
        return out


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, end) index pairs of the runs of True in a 1-D bool array, end exclusive."""
    padded = np.concatenate([[False], mask, [False]]).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))


def judge(
    t_s: np.ndarray,
    planned_contacts: np.ndarray,
    contact_force_N: np.ndarray,
    weight_N: float,
    slip_m: np.ndarray,
    sole_xy_m: np.ndarray,
    planned_sole_xy_m: np.ndarray,
    root_xy_m: np.ndarray,
    planned_root_xy_m: np.ndarray,
    fall_index: int = -1,
    fall_reason: str = "",
    aid: str = "",
    floor_index: int = -1,
    floor_link: str = "",
) -> Verdict:
    """The verdict of a run sampled at t_s (T,): planned contacts (T, 2) bool (left, right);
    simulated floor force on each sole (T, 2, 3) [N] and the robot's weight [N]; slide of each
    sole since its touch-down (T, 2) [m]; simulated and planned sole centres (T, 2, 2) [m];
    simulated (MuJoCo's root body) and planned root positions (T, 2) [m]; the first fallen
    sample (−1: none) and why; `aid`: what helped the run, named after its kind in the text
    ("with balance feedback": "stays up with balance feedback; …"); after a fall, the first
    link other than a foot on the floor and its sample (−1: none came down)."""
    t_s = np.asarray(t_s, dtype=float)
    n = len(t_s)
    dt = float(t_s[1] - t_s[0]) if n > 1 else 0.0
    end = n if fall_index < 0 else fall_index  # what happens after a fall is not judged
    planned = np.asarray(planned_contacts, dtype=bool)[:end]
    load = np.asarray(contact_force_N, dtype=float)[:end, :, 2] / weight_N
    lifted_load = np.where(~planned, load, 0.0)
    heavy = lifted_load > LEAN_LOAD_FRACTION
    leaning: list[Episode] = []
    scuffs: list[Episode] = []
    for i, side in enumerate(SIDES):
        for a, b in _runs(lifted_load[:, i] > TOUCH_LOAD_FRACTION):
            # a touch with a heavy stretch longer than LEAN_MIN_S leans; any other is a scuff
            heavy_runs = [(a + c, a + d) for c, d in _runs(heavy[a:b, i])]
            long = [(c, d) for c, d in heavy_runs if (d - c) * dt > LEAN_MIN_S + 1e-9]
            if long:
                c, d = long[0]
                leaning.append(
                    Episode(side, float(t_s[c]), (d - c) * dt, _peak(lifted_load, c, d, i))
                )
            else:
                scuffs.append(
                    Episode(side, float(t_s[a]), (b - a) * dt, _peak(lifted_load, a, b, i))
                )
    leaning.sort(key=lambda e: e.start_s)
    lean = leaning[0] if leaning else None
    stance_slip = np.where(planned, np.asarray(slip_m, dtype=float)[:end], 0.0)
    if stance_slip.size:
        k, side_index = np.unravel_index(int(np.argmax(stance_slip)), stance_slip.shape)
        slip, slip_side, slip_time = (
            float(stance_slip[k, side_index]),
            SIDES[side_index],
            float(t_s[k]),
        )
    else:
        slip, slip_side, slip_time = 0.0, "", None
    travel = _travel(
        t_s,
        np.asarray(planned_contacts, dtype=bool),
        sole_xy_m,
        planned_sole_xy_m,
        root_xy_m,
        planned_root_xy_m,
        end,
    )
    fall_time = float(t_s[fall_index]) if fall_index >= 0 else None
    verdict = Verdict(
        kind="stays up",
        text="",
        fall_time_s=fall_time,
        fall_reason=fall_reason,
        floor_link=floor_link if fall_index >= 0 and floor_index >= 0 else "",
        floor_link_time_s=float(t_s[floor_index])
        if fall_index >= 0 and floor_index >= 0 and floor_link
        else None,
        lean=lean,
        lifted_foot_load_s=float(np.count_nonzero(heavy.any(axis=1)) * dt),
        lifted_foot_peak_load_frac=float(lifted_load.max()) if lifted_load.size else 0.0,
        slip_m=slip,
        slip_side=slip_side,
        slip_time_s=slip_time,
        scuffs=tuple(sorted(scuffs, key=lambda e: e.start_s)),
        travel=travel,
    )
    kind = _kind(verdict)
    return dataclasses.replace(verdict, kind=kind, text=_text(verdict, kind, aid))


def _peak(load: np.ndarray, a: int, b: int, side: int) -> float:
    return float(load[a:b, side].max())


def _kind(v: Verdict) -> Kind:
    if v.fall_time_s is not None:
        return "falls"
    if v.lean is not None:
        return "leans on the lifted foot"
    if v.slip_m > SLIP_M:
        return "slips"
    return "stays up"


def _floor_text(v: Verdict) -> str:
    """ "; the link X is on the floor at 0.52 s" after a fall whose reason does not name it
    already ("" when none came down)."""
    if not v.floor_link or v.floor_link_time_s is None or f"link {v.floor_link} " in v.fall_reason:
        return ""
    return f"; {v.floor_link} on the floor at {v.floor_link_time_s:.2f} s"


def short_text(v: Verdict) -> str:
    """The verdict in a few words, for a line that puts two side by side: "stays up",
    "leans on the lifted foot", "slips 1.5 cm", "falls at 0.14 s (base)" (the first link on
    the floor, else the fall's reason)."""
    if v.kind == "falls":
        return f"falls at {v.fall_time_s:.2f} s ({v.floor_link or v.fall_reason})"
    if v.kind == "slips":
        return f"slips {100 * v.slip_m:.1f} cm"
    return v.kind


def pair_text(aided: Verdict, unaided: Verdict, aid: str) -> str:
    """A run with and without what helped it, on one line: "with balance feedback: stays up ·
    without: falls at 0.14 s (base)" (`short_text` of each)."""
    return f"{aid}: {short_text(aided)} · without: {short_text(unaided)}"


def _lean_text(v: Verdict) -> str:
    assert v.lean is not None
    return (
        f"the {v.lean.side} foot, planned in the air, carries up to "
        f"{100 * v.lifted_foot_peak_load_frac:.0f} % of the weight from {v.lean.start_s:.2f} s, "
        f"{v.lifted_foot_load_s:.2f} s in all"
    )


def _text(v: Verdict, kind: Kind, aid: str = "") -> str:
    """One line: the kind first (as the old verdict: "stays up", "falls at 3.42 s (…)"),
    then what else happened; `aid` after the kind's words."""
    if kind == "falls":
        head = f"falls at {v.fall_time_s:.2f} s ({v.fall_reason}{_floor_text(v)})"
    elif kind == "leans on the lifted foot":
        head = f"leans on the lifted foot: {_lean_text(v)}"
    elif kind == "slips":
        head = (
            f"slips: the {v.slip_side} foot slides {100 * v.slip_m:.1f} cm by {v.slip_time_s:.2f} s"
        )
    else:
        head = "stays up"
    if aid:
        words = kind if kind != "falls" else f"falls at {v.fall_time_s:.2f} s"
        head = head.replace(words, f"{words} {aid}", 1)
    extra = []
    if kind == "falls" and v.lean is not None:
        extra.append(f"before, it leaned on the lifted foot ({_lean_text(v)})")
    if kind in ("falls", "leans on the lifted foot") and v.slip_m > SLIP_M:
        extra.append(f"the {v.slip_side} foot slid {100 * v.slip_m:.1f} cm")
    if v.travel is not None:
        tr = v.travel
        part = (
            f"covers {tr.distance_covered_m:.2f} m of {tr.distance_planned_m:.2f} m planned "
            f"({100 * tr.fraction:.0f} %)"
        )
        if tr.footsteps:
            errors = [100 * step.error_m for step in tr.footsteps]
            part += (
                f", {len(errors)} footstep{'s' if len(errors) > 1 else ''} "
                f"{min(errors):.1f}–{max(errors):.1f} cm off"
                if len(errors) > 1
                else f", 1 footstep {errors[0]:.1f} cm off"
            )
        extra.append(part)
    if kind in ("stays up", "slips") and v.lifted_foot_load_s > 0.0 and v.travel is None:
        extra.append(
            f"a lifted foot carried > {100 * LEAN_LOAD_FRACTION:.0f} % of the weight for "
            f"{v.lifted_foot_load_s:.2f} s in all (up to {100 * v.lifted_foot_peak_load_frac:.0f} %)"
        )
    if v.scuffs and v.travel is not None:
        count = len(v.scuffs)
        extra.append(
            f"{count} swing-foot scuff{'s' if count > 1 else ''} (first at "
            f"{v.scuffs[0].start_s:.2f} s, {v.scuffs[0].side})"
        )
    return "; ".join([head, *extra])


def _travel(
    t_s: np.ndarray,
    planned_contacts: np.ndarray,
    sole_xy_m: np.ndarray,
    planned_sole_xy_m: np.ndarray,
    root_xy_m: np.ndarray,
    planned_root_xy_m: np.ndarray,
    end: int,
) -> Travel | None:
    """Distance and footsteps (module docstring), or None for a motion that stays in place."""
    sole = np.asarray(sole_xy_m, dtype=float)
    planned_sole = np.asarray(planned_sole_xy_m, dtype=float)
    root = np.asarray(root_xy_m, dtype=float)
    planned_root = np.asarray(planned_root_xy_m, dtype=float)
    n = len(t_s)
    footsteps = []
    moved = 0.0
    for i, side in enumerate(SIDES):
        for a, b in _runs(planned_contacts[:, i]):
            if a == 0:
                continue  # the starting stance is no footstep
            start = _runs(~planned_contacts[:a, i])[-1][0]
            lifted = planned_sole[max(start - 1, 0), i]
            moved = max(moved, float(np.linalg.norm(planned_sole[a, i] - lifted)))
            middle = (a + b - 1) // 2
            if middle >= end:
                continue  # planned after the fall
            footsteps.append(
                Footstep(
                    side,
                    float(t_s[a]),
                    (float(planned_sole[a, i, 0]), float(planned_sole[a, i, 1])),
                    (float(sole[middle, i, 0]), float(sole[middle, i, 1])),
                )
            )
    planned_shift = planned_root[n - 1] - planned_root[0]
    distance = float(np.linalg.norm(planned_shift))
    if moved <= TRAVEL_MIN_M:
        return None
    last = min(end, n) - 1 if end > 0 else 0
    covered_vector = root[last] - root[0]
    covered = float(covered_vector @ planned_shift / distance) if distance > 0 else 0.0
    footsteps.sort(key=lambda step: step.planned_touchdown_s)
    return Travel(distance, covered, tuple(footsteps))
