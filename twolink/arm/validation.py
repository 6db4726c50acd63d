"""Cross-validation of the analytic dynamics against MuJoCo's own, for ``twolink validate``.

Random arms and states are drawn from a seeded generator; for each, the analytic
M, H + G, inverse and forward dynamics are compared with ``mj_fullM``,
``qfrc_bias``, ``mj_inverse`` and ``qacc`` after ``mj_forward``. A free swing checks
energy conservation of the integrator. Errors are relative to the size of the
reference quantity (max-abs norm), so they mean the same for light and heavy arms.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twolink.arm import dynamics
from twolink.arm.params import ArmParams
from twolink.arm.plant import Plant

TOLERANCE = 1e-9  # relative agreement demanded of every dynamics check
ENERGY_TOLERANCE = 1e-6  # relative energy drift of a 10 s free swing at 1 ms, RK4


@dataclass(frozen=True)
class Check:
    """One validation check: its worst error over all samples and its tolerance."""

    name: str
    worst: float
    tolerance: float
    samples: int

    @property
    def passed(self) -> bool:
        return bool(self.worst <= self.tolerance)


def random_arm(rng: np.random.Generator) -> ArmParams:
    """A random but physically sensible arm: masses 0.1-10 kg, lengths 0.1-2 m, g 0-20."""
    m1, m2 = rng.uniform(0.1, 10.0, 2)
    l1, l2 = rng.uniform(0.1, 2.0, 2)
    return ArmParams(m1=m1, m2=m2, l1=l1, l2=l2, g=rng.uniform(0.0, 20.0))


def _relative(actual: np.ndarray, reference: np.ndarray) -> float:
    scale = max(float(np.max(np.abs(reference))), 1e-12)
    return float(np.max(np.abs(actual - reference))) / scale


def compare_dynamics(n: int, seed: int) -> list[Check]:
    """Worst relative errors of analytic vs MuJoCo dynamics over ``n`` random samples."""
    rng = np.random.default_rng(seed)
    worst = dict.fromkeys(
        ("M (mj_fullM)", "H + G (qfrc_bias)", "inverse (mj_inverse)", "forward (qacc)"), 0.0
    )
    for _ in range(n):
        p = random_arm(rng)
        plant = Plant.build(p)
        q = rng.uniform(-np.pi, np.pi, 2)
        qd = rng.uniform(-10.0, 10.0, 2)
        qdd = rng.uniform(-50.0, 50.0, 2)
        tau = rng.uniform(-50.0, 50.0, 2)
        plant.set_state(q, qd)
        errors = (
            _relative(plant.mass_matrix(), dynamics.mass_matrix(p, q)),
            _relative(plant.bias(), dynamics.coriolis(p, q, qd) + dynamics.gravity(p, q)),
            _relative(plant.inverse(qdd), dynamics.inverse_dynamics(p, q, qd, qdd)),
            _relative(plant.forward(tau), dynamics.forward_dynamics(p, q, qd, tau)),
        )
        for key, err in zip(worst, errors, strict=True):
            worst[key] = max(worst[key], err)
    return [Check(k, v, TOLERANCE, n) for k, v in worst.items()]


def energy_drift(p: ArmParams, q0, duration: float = 10.0, timestep: float = 1e-3) -> float:
    """Relative drift of total analytic energy over an unactuated swing in MuJoCo.

    Relative to the swing's energy scale: the range of potential energy the arm can
    span, so a swing starting near zero total energy is not divided by ~0.
    """
    plant = Plant.build(p, timestep=timestep)
    plant.reset(q0)
    e0 = sum(dynamics.energy(p, plant.q, plant.qd))
    worst = 0.0
    for _ in range(round(duration / timestep)):
        plant.step(0.0, 0.0)
        worst = max(worst, abs(sum(dynamics.energy(p, plant.q, plant.qd)) - e0))
    scale = abs(p.g) * (p.m1 * p.l1 / 2 + p.m2 * (p.l1 + p.l2 / 2))
    return worst / scale


def validate(n: int = 1000, seed: int = 0) -> list[Check]:
    """All checks of ``twolink validate``: dynamics agreement and energy conservation."""
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ValueError(f"n must be an integer >= 1 (no sample checks nothing), got {n!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    checks = compare_dynamics(n, seed)
    drift = energy_drift(ArmParams(), q0=(0.3, 0.8))
    checks.append(Check("energy drift, 10 s free swing", drift, ENERGY_TOLERANCE, 1))
    return checks


def format_table(checks: list[Check]) -> str:
    """A plain-text table of the checks, one per line."""
    lines = [f"{'check':34s} {'worst':>10s} {'tolerance':>10s} {'n':>6s}  result"]
    for c in checks:
        result = "ok" if c.passed else "FAIL"
        lines.append(f"{c.name:34s} {c.worst:10.2e} {c.tolerance:10.0e} {c.samples:6d}  {result}")
    return "\n".join(lines)
