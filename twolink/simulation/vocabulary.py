"""One vocabulary for every output: controller names and metric keys with their units.

Every table, file and printout of a run's metrics uses the keys below: a run's
``metrics.json``, the reproduction's ``metrics.csv``/``metrics.json`` and report, a
sweep's Parquet table (``joint1_rise_time_s``, ...) and summaries, and ``twolink run``'s
output. A key carries its unit (``_s`` seconds, ``_pct`` percent, ``_rad`` radians,
``_Nm`` newton metres), so no header is without one. The paper's symbols (Tp, Td, Tr, Ts,
Mp, ess) label the report's columns beside the keys. ``docs/metrics.md`` has the
definitions.

Controller names: CTC and FCM-CTC (and the other kinds' labels below) in the shipped
manifest, sweep files, figures and docs; a manifest or sweep file may name its
controllers otherwise, and those names are then used throughout its outputs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

__all__ = [
    "CONTROLLER_LABELS",
    "CONTROLLER_STYLES",
    "controller_styles",
    "rgb",
    "SIGNAL_UNITS",
    "TIME_COLUMN",
    "signal_column",
    "split_by_scale",
    "METRICS",
    "STEP_KEYS",
    "TIP_METRICS",
    "Metric",
    "format_value",
    "joint_values",
    "metric",
]

# One naming of signals (docs/tracing.md, "One naming"): a recording's entity
# ``joint{j}/{leaf}`` is the column ``joint{j}_{leaf}_{unit}`` of ``read_recording`` and of
# ``Trajectory.to_dataframe``, indexed by ``time_s``; the metric keys of tables share the
# ``joint{j}_`` prefix.
TIME_COLUMN = "time_s"
SIGNAL_UNITS = {
    "angle": "rad",  # θ
    "reference": "rad",  # θd
    "rate": "rad_s",  # θ̇
    "reference_rate": "rad_s",  # θ̇d
    "error": "rad",  # e = θd − θ
    "error_rate": "rad_s",  # ė
    "torque": "Nm",  # τ
    "motor_angle": "rad",  # φ, the rotor of a flexible joint
}


def signal_column(joint: int, leaf: str) -> str:
    """The column of joint ``joint``'s signal ``leaf`` (a key of :data:`SIGNAL_UNITS`)."""
    return f"joint{joint}_{leaf}_{SIGNAL_UNITS[leaf]}"


# Scenario ``kind`` -> the controller's name in outputs.
CONTROLLER_LABELS = {
    "ctc": "CTC",
    "fuzzy_ctc": "fuzzy-CTC",
    "fcm_ctc": "FCM-CTC",
    "pd_gravity": "PD+G",
    "ctc_integral": "CTC+I",
    "fuzzy_pd": "fuzzy-PD",
    "adaptive_ctc": "ACTC",
    "sliding_mode": "SMC",
    "ctc_dob": "CTC-DOB",
    "motor_pd": "motor-PD",
    "composite": "composite",
    "flexible_fl": "flexible-FL",
    "flexible_fl_integral": "flexible-FL-I",
    "flexible_fl_kalman": "flexible-FL-KF",
}


# One colour and one dash per controller, the same in every figure (matplotlib: the hex
# colour and the linestyle) and recording (rerun: the colour; its plots have no dashes,
# so no two controllers share a colour either). The pair first: FCM-CTC green and dashed,
# drawn over CTC red and solid, so both show where they coincide; FCM-CTC-continuous teal.
# Keyed by the names the shipped manifest, the sweeps and CONTROLLER_LABELS use.
CONTROLLER_STYLES: dict[str, tuple[str, Any]] = {
    "FCM-CTC": ("#2ca02c", "--"),
    "CTC": ("#d62728", "-"),
    "FCM-CTC-continuous": ("#17becf", "-."),
    "CTC-matched": ("#ff7f0e", (0, (3, 1, 1, 1, 1, 1))),
    "PD-G": ("#1f77b4", ":"),
    "CTC-I": ("#9467bd", (0, (5, 2))),
    "CTC-paper": ("#8c564b", (0, (1, 2, 4, 2))),
    "fuzzy-PD": ("#e377c2", (0, (8, 2, 2, 2))),
    "fuzzy-CTC": ("#bcbd22", (0, (2, 1))),
    "ACTC": ("#e6550d", (0, (2, 2, 6, 2))),
    "SMC": ("#3182bd", (0, (1, 1, 3, 1))),
    "CTC-DOB": ("#31a354", (0, (6, 2, 1, 2, 1, 2))),
    "motor-PD": ("#7f7f7f", (0, (6, 1, 1, 1))),
    "composite": ("#393b79", (0, (4, 1, 4, 1, 1, 1))),
    "flexible-FL": ("#843c39", (0, (1, 1))),
    "flexible-FL-I": ("#637939", (0, (7, 3))),
    "flexible-FL-KF": ("#7b4173", (0, (3, 3))),
}
# The same controllers under their kinds' labels (CONTROLLER_LABELS) where those differ.
STYLE_ALIASES = {"PD+G": "PD-G", "CTC+I": "CTC-I"}
# For names the table does not know: colours no entry above uses, dashes in turn.
SPARE_COLOURS = ("#e7ba52", "#5254a3", "#ad494a", "#8ca252", "#a55194", "#6b6ecf", "#d6616b")
SPARE_DASHES = ("-", "--", "-.", ":")


def controller_styles(names) -> dict[str, tuple[str, Any]]:
    """``(colour, dash)`` of each controller in ``names`` (:data:`CONTROLLER_STYLES`): a
    name the table does not know takes the next spare colour no other name here uses."""
    out = {}
    spare = iter(SPARE_COLOURS)
    for k, name in enumerate(names):
        known = CONTROLLER_STYLES.get(STYLE_ALIASES.get(name, name))
        if known is None:
            colour = next(spare, None) or f"C{k % 10}"
            known = (colour, SPARE_DASHES[k % len(SPARE_DASHES)])
        out[name] = known
    return out


def rgb(colour: str) -> tuple[int, int, int]:
    """``"#2ca02c"`` as (44, 160, 44), for rerun."""
    h = colour.lstrip("#")
    return (int(h[0:2], 16), int(h[2:4], 16), int(h[4:6], 16))


@dataclass(frozen=True)
class Metric:
    """One metric of a joint's response.

    Attributes
    ----------
    key : str
        Its name in every table and file (unit included).
    symbol : str
        The paper's (or the literature's) symbol.
    unit : str
        Unit as printed.
    source : str
        Where the value comes from in :class:`twolink.simulation.experiment.RunMetrics`:
        ``"step.<field>"``, ``"errors.<field>"``, ``"torque.<field>"`` (per joint) or a
        per-joint field of its own (``"final_error"``, ``"oscillation"``,
        ``"settling_target"``, ``"max_twist"``).
    paper_scale : float
        Factor from the unit of the paper's tables to ``unit`` (100: the paper gives Mp as
        a fraction). Every value twolink computes is in ``unit`` already.
    """

    key: str
    symbol: str
    unit: str
    source: str
    paper_scale: float = 1.0

    @property
    def label(self) -> str:
        """``"Tr [s]"``: symbol and unit, for table headers and axes."""
        return f"{self.symbol} [{self.unit}]"


METRICS: tuple[Metric, ...] = (
    Metric("peak_time_s", "Tp", "s", "step.peak_time"),
    Metric("delay_time_s", "Td", "s", "step.delay_time"),
    Metric("rise_time_s", "Tr", "s", "step.rise_time"),
    Metric("settling_time_s", "Ts", "s", "step.settling_time"),
    Metric("settling_time_target_s", "Ts→θd", "s", "settling_target"),
    Metric("overshoot_pct", "Mp", "%", "step.overshoot", paper_scale=100.0),
    Metric("steady_state_error_rad", "ess", "rad", "step.steady_state_error"),
    Metric("final_error_rad", "e(T)", "rad", "final_error"),
    Metric("tail_error_rad", "max|e| tail", "rad", "tail_error"),
    Metric("tail_growth", "growth", "×", "tail_growth"),
    Metric("linear_growth_1_s", "σ", "1/s", "linear_growth"),  # the loop's; flexible joints
    Metric("fuzzy_active_share", "fuzzy on", "1", "fuzzy_active"),  # fuzzy laws only
    Metric("oscillation_rad", "osc", "rad", "oscillation"),
    Metric("iae_rad_s", "IAE", "rad·s", "errors.iae"),
    Metric("ise_rad2_s", "ISE", "rad²·s", "errors.ise"),
    Metric("itae_rad_s2", "ITAE", "rad·s²", "errors.itae"),
    Metric("max_error_rad", "max|e|", "rad", "errors.max_abs"),
    Metric("torque_rms_Nm", "τ rms", "N·m", "torque.rms"),
    Metric("torque_peak_Nm", "τ peak", "N·m", "torque.peak"),
    Metric("torque_variation_Nm", "Σ|Δτ|", "N·m", "torque.variation"),
    Metric("max_twist_rad", "twist", "rad", "max_twist"),  # flexible joints; NaN if rigid
)
STEP_KEYS = tuple(m.key for m in METRICS if m.source.startswith("step."))
# The tip of links that bend ([arm.links]): the arm's measures, not a joint's; ``source``
# is a field of twolink.simulation.links_sim.TipMetrics. NaN (null) for rigid links.
TIP_METRICS: tuple[Metric, ...] = (
    Metric("tip_error_m", "max|Δtip|", "m", "tip_error"),
    Metric("final_tip_error_m", "|Δtip|(T)", "m", "final_tip_error"),
    Metric("residual_vibration_m", "w res", "m", "residual_vibration"),
    Metric("vibration_settling_time_s", "Ts tip", "s", "vibration_settling_time"),
)
# The paper's claim (section 4): FCM reduces peak, delay, rise and settling time and
# overshoot, and steady-state error, compared with CTC. Which of the manifest's
# controllers play the two roles is the manifest's ``proposed`` and ``baseline``.
# In the paper's column order (Tp, Td, Ts, Tr, Mp, ess).
CLAIMED_BETTER = (
    "peak_time_s",
    "delay_time_s",
    "settling_time_s",
    "rise_time_s",
    "overshoot_pct",
    "steady_state_error_rad",
)

_BY_KEY = {m.key: m for m in METRICS + TIP_METRICS}


def metric(key: str) -> Metric:
    """The :class:`Metric` of ``key``."""
    return _BY_KEY[key]


def joint_values(run_metrics: Any, joint: int) -> dict[str, float]:
    """Every metric of joint ``joint`` (1 or 2) of a run, by key, in output units.

    Step metrics are NaN for a joint whose reference does not move (it has no step).
    """
    out = {}
    for m in METRICS:
        section, _, field = m.source.partition(".")
        if not field:
            value = getattr(run_metrics, section)[joint - 1]
        elif section == "step":
            step = run_metrics.step[joint - 1]
            value = math.nan if step is None else getattr(step, field)
        else:
            value = getattr(getattr(run_metrics, section), field)[joint - 1]
        out[m.key] = float(value)
    return out


def format_value(value: Any, digits: int = 3) -> str:
    """A number for a table or a printout: ``digits`` significant digits, "—" where the
    value is undefined (NaN or missing), never "nan"."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "—"
    if isinstance(value, float):
        return f"{value:.{digits}g}" if abs(value) >= 1e-3 or value == 0 else f"{value:.1e}"
    return str(value)


def split_by_scale(
    angles: dict[str, Any], reference: Any, pair: tuple[str, ...] | list[str]
) -> tuple[list[str], list[str], list[str], tuple[float, float]]:
    """How figures and recordings show a comparison: ``(pair_like, near, far, (lo, hi))``.
    ``angles`` maps a controller to its angle samples; the pair and every FCM variant
    are ``pair_like`` and set the scale (with the reference, padded by 10 %); a baseline
    within it is ``near``, one that leaves it (a failing baseline's swings would flatten
    every other curve) ``far``."""
    import numpy as np

    pair_like = [n for n in angles if n in pair or n.startswith("FCM")]
    values = [np.asarray(reference)] + [np.asarray(angles[n]) for n in pair_like]
    lo = min(float(np.nanmin(v)) for v in values)
    hi = max(float(np.nanmax(v)) for v in values)
    pad = 0.1 * max(hi - lo, 0.1)
    lo, hi = lo - pad, hi + pad
    near, far = [], []
    for n, q in angles.items():
        if n not in pair_like:
            inside = np.nanmin(q) >= lo and np.nanmax(q) <= hi
            (near if inside else far).append(n)
    return pair_like, near, far, (lo, hi)
