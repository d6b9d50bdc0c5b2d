"""The papers' numbers, in one place: every table and figure the studio reproduces or compares.

Spring compensation (Wang et al., Biomimetics 2023; papers/spring-compensation-wbc.txt):
Table 2 (standing servo data), Table 3 (calibrated k), φ of eq 23. Symmetric gait (Chen et al.,
Micromachines 2023; papers/symmetric-gait-dircon.txt): Table 4 (torque, energy) and the solve
times of section 5.3. Code that uses a number imports it from here; tests compare against it.
"""

from __future__ import annotations

import dataclasses

# --- spring compensation paper -----------------------------------------------------------

TABLE2_TEXT = """\
1 -0.00026 -0.23438 -0.00197 -118.74
2 0.6226 0.15625 -0.36474 -1.28
3 -37.9075 -36.6406 0.01779 -71.21
4 68.7407 71.6406 -1.86625 1.55
5 -30.8239 -28.9844 0.00371 -495.82
6 -0.6245 -1.40625 0.01724 45.36
7 0.00017 0.23438 0.00198 -118.29
8 -0.60888 -0.46874 -0.39568 0.35
9 -37.9126 -37.1875 -0.004 181.28
10 68.7484 71.4062 1.88342 -1.41
11 -30.8266 -29.375 0.02008 -722.91
12 0.60647 1.0156 -0.01592 25.70
"""
"""Table 2 as printed: servo, q_des [°], q [°], τ [N·m], k [°/(N·m)] (robot standing)."""

TABLE3_K_DEG_PER_NM: dict[int, float] = {2: -4.0, 3: -650.0, 8: 20.0, 9: -1200.0}
"""Table 3: k of servos 2, 3, 8, 9 after trial-and-error calibration [°/(N·m)]."""

PHI_DEG = 8.0
"""Clearance compensation angle φ of eq 23, found by trial (section 5.4) [°]."""

TYPICAL_COMPLIANCE_DEG_PER_NM = 1.4
"""Mean |k| of the Table 2 servos whose torque is large enough to identify k (servos 2, 4 and
10: 1.28, 1.55, 1.41 °/(N·m); app.core.servo.calibration checks this from the table)."""


# --- symmetric gait paper ----------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Table4:
    """Table 4: the symmetric planner against the previous (non-symmetric) one."""

    max_abs_tau_Nm: tuple[float, float] = (9.8, 11.5)
    """Largest joint input [N·m]: (symmetric, previous)."""
    sr: tuple[float, float] = (0.772, 1.299)
    """Specific resistance E/(M·g·d) from measured energy: (symmetric, previous)."""
    solve_s: tuple[float, float] = (65.0, 300.0)
    """Range of solve times with SNOPT on an i7-9750H [s] (mean 138 s)."""

    def ratio(self, field: str) -> float:
        """Symmetric / previous for one of the paired figures."""
        symmetric, previous = getattr(self, field)
        return symmetric / previous


TABLE4 = Table4()
