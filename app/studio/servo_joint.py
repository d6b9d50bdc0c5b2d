"""What the Servos folder shows of the joint selected: its line (the ideal servo's compliance,
or the part's stiffness K and compliance k = 1/K beside eq 7's k in use), the part's firmware
settings (a part without a kp law: its stated stiffness in place of kp), and its planned
torque–speed points against the servo's envelope with the last sizing's verdict. No viser: the servos session hands these to its panel."""

from __future__ import annotations

import math

import numpy as np

from app.core.errors import StudioError
from app.core.papers import TYPICAL_COMPLIANCE_DEG_PER_NM
from app.core.servo.catalogue import ServoRecord
from app.core.servo.choice import IDEAL, ServoChoice, choice_parts, offered_catalogue
from app.core.servo.sizing import Sizing, check_joint, envelope
from app.core.servo.sizing_work import Work
from app.studio.servo_parts import catalogue
from app.studio.work import Coefficients

Plot = tuple[str, np.ndarray, np.ndarray, "tuple[float, float, float] | None", str]
"""(title, speed [rad/s] (N,), torque [N·m] (N,), the envelope's (stall torque [N·m],
no-load speed [rad/s], torque limit [N·m]) or None, the line under it): ServosPanel.show_plot's."""


def joint_line(
    choice: ServoChoice, selected: str, coefficients: Coefficients | None
) -> tuple[dict[str, float], str]:
    """The firmware settings in use of `selected`'s servo part ({} on the ideal servo) and its
    line (a part the catalogue refuses: the reason)."""
    joint = choice.joint(selected)
    i = choice.joint_names.index(selected)
    if joint.servo == IDEAL or coefficients is None:
        compliance = (
            float(coefficients.servo.compliance_deg_per_Nm[i]) if coefficients else math.nan
        )
        return {}, (
            f"**{selected}**: ideal servo, compliance {compliance:.3g} °/(N·m) "
            f"(Compensation panel); the paper's k: {TYPICAL_COMPLIANCE_DEG_PER_NM:g} °/(N·m)"
        )
    try:
        one = ServoChoice((selected,), (joint,), user_servos=choice.user_servos)
        parts = choice_parts(one, (selected,), catalogue())
    except StudioError as error:
        return {}, f"⚠️ {error}"
    assert parts is not None  # None only when every joint is ideal: this one is not
    part = parts.parts[0]
    settings = {
        "kp": part.firmware.kp,
        "vin_V": part.firmware.vin_V,
        "current_limit_A": part.firmware.current_limit_A or 0.0,
        "dead_band_deg": part.dead_band_deg,
    }
    stated = ""
    rated = offered_catalogue(one, catalogue())[joint.servo].rated
    if not part.kp_law and rated is not None:  # a stiffness in place of kp; the register's A
        del settings["kp"]
        settings["stiffness_Nm_per_rad"] = part.stiffness_Nm_per_rad
        settings["current_limit_A"] = joint.current_limit_A or rated.current_limit_A
        stated = " (stated: no kp law, tune its P gain to give it)"
    k_now = float(coefficients.params.k_deg_per_Nm[i])
    line = (
        f"**{selected}**: {joint.servo}, stiffness K = "
        f"{part.stiffness_Nm_per_rad:.1f} N·m/rad{stated}, compliance **k = 1/K = "
        f"{part.compliance_deg_per_Nm:.3g} °/(N·m)** (the paper's k: "
        f"{TYPICAL_COMPLIANCE_DEG_PER_NM:g}); stall {part.stall_torque_Nm:.2f} N·m"
    )
    if not np.isclose(k_now, part.compliance_deg_per_Nm, rtol=1e-6):
        line += f"  \n⚠️ eq 7's k is {k_now:.3g} (edited in the Compensation panel)"
    return settings, line


def stiffness_now(coefficients: Coefficients | None, joint: str) -> float:
    """The whole N·m/rad (≥ 1) of `joint`'s compliance in use, 1/k (the paper's k where it is
    rigid): a part without a kp law starts at the stiffness the joint had; the user types the
    one its P gain gives."""
    compliance = TYPICAL_COMPLIANCE_DEG_PER_NM
    if coefficients is not None:
        i = coefficients.servo.joint_names.index(joint)
        now = float(coefficients.servo.compliance_deg_per_Nm[i])
        compliance = now if math.isfinite(now) and now > 0.0 else compliance
    return float(max(1, round(1.0 / math.radians(compliance))))


def sizing_plot(
    last: tuple[Sizing, dict[str, Work]] | None,
    joint: str,
    servo: str,
    records: dict[str, ServoRecord],
) -> Plot:
    """`joint`'s planned points of the works the `last` sizing was made against, under
    `servo`'s envelope (a servo added after the sizing: checked on the same points now); an
    empty plot before any sizing."""
    if last is None:
        return "", np.zeros(0), np.zeros(0), None, ""
    sizing, works = last
    j = [s.joint for s in sizing.joints].index(joint)
    w = np.concatenate([work.speed_rad_s[:, j] for work in works.values()])
    tau = np.concatenate([work.torque_Nm[:, j] for work in works.values()])
    record = records.get(servo)
    env = envelope(record) if record is not None else None
    bounds = None
    note = f"{joint}: planned points of {', '.join(works)} (ideal servo: no envelope)"
    if env is not None and record is not None:
        bounds = (env.stall_torque_Nm, env.no_load_speed_rad_s, env.torque_limit_Nm)
        checked = [c for c in sizing.joints[j].checks if c.servo == servo]
        check = checked[0] if checked else check_joint(record, w, tau, 1.0, sizing.margin)
        verdict = "holds" if check.holds else "⚠️ " + "; ".join(check.violations())
        note = (
            f"{joint} on {servo} ({env.source}): peak margin {check.peak_margin:+.0%}, RMS "
            f"{check.rms_torque_Nm:.3g} N·m vs {check.continuous_torque_Nm:.3g} N·m "
            f"continuous{' (assumed)' if check.continuous_assumed else ''}: {verdict}"
        )
    return f"{joint}: torque [N·m] vs speed", w, tau, bounds, note
