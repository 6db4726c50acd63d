"""Analytic dynamics: against MuJoCo, against its own structure, and its inputs."""

import dataclasses
import math

import numpy as np
import pytest

from twolink.arm import dynamics
from twolink.arm.params import ArmParams
from twolink.arm.plant import Plant
from twolink.arm.validation import (
    ENERGY_TOLERANCE,
    TOLERANCE,
    compare_dynamics,
    energy_drift,
    random_arm,
)


def test_agrees_with_mujoco_on_1000_random_arms_and_states():
    checks = compare_dynamics(n=1000, seed=1)
    for check in checks:
        assert check.samples == 1000
        assert check.worst <= TOLERANCE, check


def test_comparison_detects_the_papers_uncorrected_coriolis_terms():
    # The paper prints H without the sin(theta2) factor; the check must catch that.
    rng = np.random.default_rng(3)
    p = random_arm(rng)
    q, qd = np.array([0.4, 0.3]), np.array([1.5, -2.0])
    plant = Plant.build(p)
    plant.set_state(q, qd)
    a = p.m2 * p.l1 * p.l2
    wrong_h = np.array([-a * qd[0] * qd[1] - a / 2 * qd[1] ** 2, a / 2 * qd[0] ** 2])
    err = np.abs(plant.bias() - (wrong_h + dynamics.gravity(p, q))).max()
    assert err > 1e-3


def test_mass_matrix_is_symmetric_positive_definite():
    rng = np.random.default_rng(0)
    for _ in range(200):
        p = random_arm(rng)
        m = dynamics.mass_matrix(p, rng.uniform(-np.pi, np.pi, 2))
        assert np.allclose(m, m.T, rtol=0, atol=0)
        assert np.all(np.linalg.eigvalsh(m) > 0)


def test_coriolis_matrix_gives_h_and_mdot_minus_2c_is_skew():
    rng = np.random.default_rng(1)
    for _ in range(100):
        p = random_arm(rng)
        q, qd = rng.uniform(-np.pi, np.pi, 2), rng.uniform(-5, 5, 2)
        c = dynamics.coriolis_matrix(p, q, qd)
        np.testing.assert_allclose(c @ qd, dynamics.coriolis(p, q, qd), rtol=1e-12, atol=1e-12)
        h = 1e-6  # central difference of M along the motion: error O(h^2)
        mdot = (dynamics.mass_matrix(p, q + h * qd) - dynamics.mass_matrix(p, q - h * qd)) / (2 * h)
        n = mdot - 2 * c
        assert np.abs(n + n.T).max() <= 1e-7 * max(1.0, np.abs(mdot).max())


def test_inverse_and_forward_dynamics_are_inverses_and_broadcast():
    rng = np.random.default_rng(2)
    p = ArmParams()
    q, qd, qdd = (rng.normal(size=(4, 3, 2)) for _ in range(3))
    tau = dynamics.inverse_dynamics(p, q, qd, qdd)
    assert tau.shape == (4, 3, 2)
    np.testing.assert_allclose(dynamics.forward_dynamics(p, q, qd, tau), qdd, atol=1e-12)
    assert dynamics.mass_matrix(p, q).shape == (4, 3, 2, 2)
    assert dynamics.gravity(p, q).shape == (4, 3, 2)
    assert dynamics.mass_matrix(p, [0.1, 0.2]).shape == (2, 2)
    k, v = dynamics.energy(p, q, qd)
    assert k.shape == v.shape == (4, 3)
    with pytest.raises(ValueError, match="trailing axis"):
        dynamics.mass_matrix(p, np.zeros(3))


def test_scalar_kernel_equals_the_vectorised_model():
    rng = np.random.default_rng(4)
    for _ in range(200):
        p = random_arm(rng)
        q, qd = rng.uniform(-np.pi, np.pi, 2), rng.uniform(-5, 5, 2)
        m11, m12, m22, b1, b2 = dynamics.terms(p, *q, *qd)
        np.testing.assert_allclose(
            [[m11, m12], [m12, m22]], dynamics.mass_matrix(p, q), rtol=1e-14, atol=1e-14
        )
        bias = dynamics.coriolis(p, q, qd) + dynamics.gravity(p, q)
        np.testing.assert_allclose([b1, b2], bias, rtol=1e-13, atol=1e-12)


def test_closed_form_values_of_the_corrected_model():
    # Straight arm pointing along +x at rest: both gravity torques at their maximum.
    p = ArmParams(m1=2.0, m2=1.0, l1=1.5, l2=0.5, g=10.0)
    np.testing.assert_allclose(
        dynamics.gravity(p, [0, 0]), [(1 + 1) * 1.5 * 10 + 0.25 * 10, 0.25 * 10]
    )
    np.testing.assert_allclose(dynamics.gravity(p, [math.pi / 2, 0]), [0, 0], atol=1e-12)
    m = dynamics.mass_matrix(p, [0, 0])
    assert m[1, 1] == pytest.approx(1.0 * 0.25 / 3)
    assert m[0, 1] == pytest.approx(0.25 / 3 + 1.5 * 0.5 / 2)
    assert m[0, 0] == pytest.approx((2 / 3 + 1) * 2.25 + 0.25 / 3 + 0.75)


def test_energy_of_a_free_swing_is_conserved_by_rk4():
    assert energy_drift(ArmParams(), q0=(0.3, 0.8)) < ENERGY_TOLERANCE
    assert energy_drift(ArmParams(m1=3, m2=0.5, l1=0.7, l2=1.2), q0=(-1.0, 2.0)) < ENERGY_TOLERANCE


def test_gravity_torque_holds_the_arm_still_in_mujoco():
    p = ArmParams(m1=1.3, m2=0.8, l1=0.9, l2=0.6)
    q0 = np.array([0.7, -0.4])
    plant = Plant.build(p)
    plant.reset(q0)
    tau = dynamics.gravity(p, q0)
    for _ in range(1000):
        plant.step(*tau)
    assert np.abs(plant.q - q0).max() < 1e-9
    # and without it, the arm falls: the check can fail
    plant.reset(q0)
    for _ in range(1000):
        plant.step(0.0, 0.0)
    assert np.abs(plant.q - q0).max() > 0.1


@pytest.mark.parametrize("field", ["m1", "m2", "l1", "l2"])
@pytest.mark.parametrize("value", [0.0, -1.0, math.nan, math.inf])
def test_bad_parameters_name_the_field_and_value(field, value):
    with pytest.raises(ValueError, match=rf"ArmParams\.{field}.*{value}"):
        ArmParams(**{field: value})


@pytest.mark.parametrize("value", [math.nan, math.inf, "9.81"])
def test_gravity_must_be_a_finite_number(value):
    with pytest.raises(ValueError, match=r"ArmParams\.g"):
        ArmParams(g=value)


def test_params_are_frozen_and_scalable():
    p = ArmParams()
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.m1 = 2.0  # type: ignore[misc]
    assert p.scaled(m2=1.5, g=0.5) == ArmParams(m2=1.5, g=9.81 * 0.5)
    assert ArmParams(g=0.0).g == 0.0
