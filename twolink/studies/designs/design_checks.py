"""Checks of a designed rule base: odd symmetry u(-e, -de) = -u(e, de), and the held-out
validation (the designed FCM-CTC beside CTC on moves that are not design runs).
:mod:`twolink.studies.designs.design` runs them and keeps their results with the design's
evidence."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from twolink.controllers.fuzzy import MIRROR_LABELS, MamdaniEngine, Rule
from twolink.simulation.config import Scenario
from twolink.simulation.experiment import build_controller, run_scenarios

SYMMETRY_GRID = 61  # points per axis of the asymmetry check: the universes' own samples
# CTC, the 7x7 fuzzy-CTC with the designed rules, and CTC retuned to spend FCM-CTC's peak
# torque on the same move (the fair linear opponent, twolink.studies.designs.matching)
VALIDATION_CONTROLLERS = ("CTC", "FCM-CTC", "CTC-matched")


def mirror_rule(rule: Rule) -> Rule:
    """The rule's odd-symmetric image: (e, de -> u) becomes (-e, -de -> -u)."""
    return Rule(MIRROR_LABELS[rule.e], MIRROR_LABELS[rule.de], MIRROR_LABELS[rule.u])


@dataclass(frozen=True)
class SymmetryCheck:
    """Odd symmetry u(-e, -de) = -u(e, de) of a rule base.

    Attributes
    ----------
    missing : rules whose mirror (-e, -de -> -u) the rule base lacks
    max_asymmetry : max |u(e, de) + u(-e, -de)| over a grid of the normalised plane
        (the universes' 61 x 61 samples), in units of the output universe
    """

    missing: tuple[Rule, ...]
    max_asymmetry: float

    @property
    def symmetric(self) -> bool:
        return not self.missing and self.max_asymmetry <= 1e-9


def check_symmetry(engine: MamdaniEngine, rules: Sequence[Rule]) -> SymmetryCheck:
    """Check ``rules`` (on ``engine``'s variables) for odd symmetry: which rules miss their
    mirror, and the largest asymmetry of the control surface on a grid."""
    kept = set(rules)
    missing = tuple(r for r in rules if mirror_rule(r) not in kept)
    x = np.linspace(-1.0, 1.0, SYMMETRY_GRID)
    e, de = np.meshgrid(x, x, indexing="ij")
    u = np.asarray(engine.with_rules(rules)(e, de))
    return SymmetryCheck(missing, float(np.max(np.abs(u + u[::-1, ::-1]))))


def with_mirrors(engine: MamdaniEngine, rules: Sequence[Rule]) -> tuple[Rule, ...]:
    """``rules`` and each one's mirror, once each, in ``engine``'s rule-table order (a
    mirror that is not in the table goes last)."""
    order = {r: i for i, r in enumerate(engine.rules)}
    every = set(rules) | {mirror_rule(r) for r in rules}
    return tuple(sorted(every, key=lambda r: (order.get(r, len(order)), r)))


# ----------------------------------------------------------------------------- validation


@dataclass(frozen=True)
class ValidationRow:
    """One held-out run under one controller: the largest of each metric over the joints.

    Attributes
    ----------
    run, file : the scenario's name and file stem
    controller : "CTC", "FCM-CTC" or "CTC-matched"
    overshoot_pct : Mp of the joints that move, largest [%] (NaN: no joint moves)
    settling_s : Ts to the target (2 % band), largest over the joints that move [s]
        (NaN: no joint moves, or one never settles)
    iae : integral of |e| over both joints [rad s]
    ess_rad : largest |e| at the end of the run [rad]
    peak_torque_Nm : largest |tau| [N m]
    wn_scale : the controller's ωn against the shipped gains' (CTC-matched's match; 1 else)
    """

    run: str
    file: str
    controller: str
    overshoot_pct: float
    settling_s: float
    iae: float
    ess_rad: float
    peak_torque_Nm: float
    wn_scale: float = 1.0

    COLUMNS = ("overshoot_pct", "settling_s", "iae", "ess_rad", "peak_torque_Nm", "wn_scale")


def validate(
    engine: MamdaniEngine, rules: Sequence[Rule], scenarios: Sequence[Scenario]
) -> tuple[ValidationRow, ...]:
    """Run each held-out scenario under CTC, under FCM-CTC with ``rules`` (same gains,
    same fuzzy scaling) and under CTC-matched (CTC with ωn scaled to spend FCM-CTC's peak
    torque on that move: :func:`twolink.studies.designs.matching.choose_scale` over
    :data:`~twolink.studies.designs.matching.SCALES`), and measure the three."""
    from twolink.studies.designs.matching import SCALES, choose_scale

    designed = engine.with_rules(rules)  # one engine object: one batch law for all
    pairs, grid = [], []
    for s in scenarios:
        ctc, fuzzy = (
            dataclasses.replace(s, controller=dataclasses.replace(s.controller, kind=kind))
            for kind in ("ctc", "fuzzy_ctc")
        )
        pairs += [ctc, fuzzy]
        grid += [_scaled(ctc, k) for k in SCALES]
    controllers = [
        dataclasses.replace(build_controller(s), engine=designed)
        if s.controller.kind == "fuzzy_ctc"
        else build_controller(s)
        for s in pairs
    ]
    controllers += [build_controller(s) for s in grid]
    trajs = _checked(pairs + grid, run_scenarios(pairs + grid, controllers))
    peaks = np.array([np.abs(t.tau).max(axis=0) for t in trajs])
    n = len(SCALES)
    matched, scales = [], []
    for i, s in enumerate(scenarios):
        fcm, ctc = peaks[2 * i + 1], peaks[2 * i]
        own = peaks[len(pairs) + i * n : len(pairs) + (i + 1) * n]
        limit = np.asarray(s.controller.torque_limit, dtype=float)
        scale, _ = choose_scale(fcm, ctc, own, limit)
        scales.append(scale)
        matched.append(_scaled(pairs[2 * i], scale))
    matched_trajs = _checked(matched, run_scenarios(matched))
    rows = []
    for i in range(len(scenarios)):
        runs = (pairs[2 * i], pairs[2 * i + 1], matched[i])
        done = (trajs[2 * i], trajs[2 * i + 1], matched_trajs[i])
        for s, name, traj, scale in zip(
            runs, VALIDATION_CONTROLLERS, done, (1.0, 1.0, scales[i]), strict=True
        ):
            rows.append(_measured(s, name, traj, scale))
    return tuple(rows)


def _scaled(s: Scenario, k: float) -> Scenario:
    """``s`` with its controller's ωn scaled by k (ζ kept: Kp k², Kd k, Ki k³)."""
    c = s.controller
    gains = {
        "kp": tuple(v * k * k for v in c.kp),
        "kd": tuple(v * k for v in c.kd),
        "ki": tuple(v * k**3 for v in c.ki),
    }
    return dataclasses.replace(s, controller=dataclasses.replace(c, **gains))


def _checked(scenarios: Sequence[Scenario], trajs: Sequence[Any]) -> list[Any]:
    for s, traj in zip(scenarios, trajs, strict=True):
        if isinstance(traj, Exception) or not traj.ok:
            raise RuntimeError(f"held-out run {s.source} ({s.controller.kind}) failed: {traj}")
    return list(trajs)


def _measured(s: Scenario, name: str, traj: Any, scale: float) -> ValidationRow:
    from twolink.simulation.metrics import error_measures, step_metrics

    mp, ts = [], []
    for j, (target, q0) in enumerate(zip(s.reference.final, s.q0, strict=True)):
        if target != q0:
            m = step_metrics(traj.t, traj.q[:, j], target, y0=q0, final_value=target)
            mp.append(m.overshoot)
            ts.append(m.settling_time)
    iae = error_measures(traj.t, traj.e).iae
    return ValidationRow(
        s.name,
        Path(s.source).stem,
        name,
        max(mp) if mp else math.nan,
        max(ts) if ts and not any(math.isnan(x) for x in ts) else math.nan,
        float(sum(iae)),
        float(np.abs(traj.e[-1]).max()),
        float(np.abs(traj.tau).max()),
        float(scale),
    )


def validation_csv(rows: Sequence[ValidationRow]) -> str:
    """The held-out table as CSV (NaN: not defined for that run)."""
    fields = [f.name for f in dataclasses.fields(ValidationRow)]
    lines = [",".join(fields)]
    for row in rows:
        values = [getattr(row, f) for f in fields]
        lines.append(",".join(f'"{v}"' if isinstance(v, str) else f"{v:.6g}" for v in values))
    return "\n".join(lines) + "\n"


def validation_rows(evidence: Mapping[str, Any]) -> tuple[ValidationRow, ...]:
    """The held-out table stored in a design's evidence (as :func:`write_design` writes it)."""
    rows = []
    for file, entry in evidence.get("validation", {}).items():
        for name in VALIDATION_CONTROLLERS:
            if name in entry:
                # evidence written before the match had no wn_scale: 1, the shipped gains
                values = [float(entry[name].get(k, 1.0)) for k in ValidationRow.COLUMNS]
                rows.append(ValidationRow(entry["name"], file, name, *values))
    return tuple(rows)
