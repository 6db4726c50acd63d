"""The Kalman filter's model checked against the physics, not against itself (issue 48):
its spring mode (the rotor against the link across the spring) has the frequency and
damping of the two-mass system its parameters describe. A sign flipped in the rotor's
damping leaves every "met spec" cell and the gain test green (that test builds its
reference from the same model) and makes this mode unstable."""

from __future__ import annotations

import math

import numpy as np
import pytest

from twolink.arm.params import ArmParams, Flexibility
from twolink.controllers.flexible_observed import SpringKalmanFilter


@pytest.mark.parametrize(
    "joints", [Flexibility.realistic(), Flexibility((500.0,) * 2, (2.0,) * 2, (0.05,) * 2)]
)
def test_the_filters_spring_mode_is_the_two_mass_systems(joints):
    dt = 1e-3
    f = SpringKalmanFilter(ArmParams(), joints, dt, 2 * np.pi / 2**17)
    for i in (0, 1):
        k, d, j, mu = joints.k[i], joints.d[i], joints.j[i], f.mu[i]
        # δ = θ − q: δ̈ = −(1/j + μ)(k δ + d δ̇): ω² = k (1/j + μ), 2 ζ ω = d (1/j + μ)
        inv = 1.0 / j + mu
        omega, zeta = math.sqrt(k * inv), d * inv / (2.0 * math.sqrt(k * inv))
        want = np.roots([1.0, d * inv, k * inv])
        s = np.log(np.linalg.eigvals(f.phi[i]).astype(complex)) / dt  # the model's poles
        moving = s[np.abs(s) > 1e-6 * omega]  # the rigid mode and the integrators at 0
        assert sorted(moving, key=lambda z: z.imag) == pytest.approx(
            sorted(want, key=lambda z: z.imag), rel=1e-6
        )
        assert zeta > 0 and all(z.real < 0 for z in moving)
