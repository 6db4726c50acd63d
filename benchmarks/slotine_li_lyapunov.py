"""The figure docs/control.md shows for Slotine-Li adaptive CTC: its Lyapunov function
V(t) = s^T M s / 2 + ã^T Γ^-1 ã / 2 along a MuJoCo run, with V(0) - ∫ s^T K_D s dt (what
the theory says V is), and the estimates on a multi-sine against a held step.

    python benchmarks/slotine_li_lyapunov.py        (writes docs/images/slotine_li_lyapunov.png)

The plant is the model's arm with 20 % more on link 2, 10 % less on link 1 and a 0.2 kg
payload; no torque limit, the exact sensor (the theory's premises). The V run uses Γ at
3 % of the default, slow enough that the projection stays idle (tests/test_field_laws.py
checks the same run).
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from twolink.arm.params import ArmParams  # noqa: E402
from twolink.arm.plant import Plant  # noqa: E402
from twolink.arm.regressor import PARAMETER_NAMES, parameters  # noqa: E402
from twolink.controllers.adaptive import (  # noqa: E402
    DEFAULT_GAMMA,
    AdaptiveComputedTorque,
    lyapunov,
)
from twolink.foundation.references import ArmReference, make_reference  # noqa: E402

MODEL = ArmParams()
PLANT, PAYLOAD = MODEL.scaled(m1=0.9, m2=1.2), 0.2
OUT = Path(__file__).resolve().parents[1] / "docs" / "images" / "slotine_li_lyapunov.png"


def run(reference, gamma, duration, dt=1e-3):
    plant = Plant.build(PLANT, None, PAYLOAD, dt)
    c = AdaptiveComputedTorque(MODEL, reference, gamma=gamma, torque_limit=math.inf)
    a = parameters(PLANT, PAYLOAD)
    t, v, d, est = [], [], [], []
    for k in range(round(duration / dt) + 1):
        q, qd = plant.q.copy(), plant.qd.copy()
        vk, dk = lyapunov(c, k * dt, q, qd, plant.mass_matrix(), a)
        t.append(k * dt)
        v.append(vk)
        d.append(dk)
        est.append(np.divide(c.a_hat, a))
        plant.step(*c(k * dt, tuple(q), tuple(qd)))
    return np.array(t), np.array(v), np.array(d), np.array(est)


def main() -> None:
    sine = ArmReference(
        make_reference("multisine", amplitude=0.1, frequency_hz=0.2, harmonics=3),
        make_reference("multisine", amplitude=-0.12, frequency_hz=0.31, harmonics=3),
    )
    step = ArmReference(make_reference("step", final=1.0), make_reference("step", final=0.5))
    t, v, d, _ = run(sine, tuple(0.03 * g for g in DEFAULT_GAMMA), 10.0)
    theory = v[0] - np.concatenate([[0.0], np.cumsum(d[:-1]) * 1e-3])
    ts, _, _, est_sine = run(sine, DEFAULT_GAMMA, 20.0)
    tt, _, _, est_step = run(step, DEFAULT_GAMMA, 20.0)

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4))
    ax1.semilogy(t, v, label="V(t), along the run")
    ax1.semilogy(t, theory, "--", label="V(0) − ∫ sᵀ K_D s dt")
    ax1.set(xlabel="t [s]", ylabel="V [J]", title="Slotine-Li: V never increases")
    ax1.legend()
    for i, name in enumerate(PARAMETER_NAMES):
        (line,) = ax2.plot(ts, est_sine[:, i], label=f"{name}, multi-sine")
        ax2.plot(tt, est_step[:, i], ":", color=line.get_color())
    ax2.axhline(1.0, color="k", lw=0.5)
    ax2.set(xlabel="t [s]", ylabel="â / a", title="estimates: multi-sine (solid), step (dotted)")
    ax2.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(OUT, dpi=110)
    drift = np.diff(v).max()
    gap = abs(v[-1] - theory[-1])
    print(f"V: {v[0]:.4g} -> {v[-1]:.3g} J; largest increment {drift:.2g} J")
    print(f"gap to V(0) - ∫ s^T K_D s dt at the end: {gap:.2g} J")
    print(f"multi-sine â/a at 20 s: {np.round(est_sine[-1], 4).tolist()}")
    print(f"step       â/a at 20 s: {np.round(est_step[-1], 4).tolist()}")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
