"""The MuJoCo plant: conventions, generated MJCF files, and the flexible-joint arm."""

from pathlib import Path

import mujoco
import numpy as np
import pytest

from twolink.arm import dynamics
from twolink.arm.params import ArmParams, Flexibility
from twolink.arm.plant import Plant, build_model, model_xml, scene_xml

MODELS = Path(__file__).resolve().parents[1] / "models"


def test_rigid_model_matches_the_contract():
    m = build_model(ArmParams())
    assert (m.nq, m.nv, m.nu) == (2, 2, 2)
    assert m.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4
    assert np.all(m.dof_damping == 0) and np.all(m.dof_armature == 0)
    assert np.all(m.dof_frictionloss == 0) and np.all(m.jnt_limited == 0)
    assert m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT
    assert [m.joint(i).name for i in range(2)] == ["theta1", "theta2"]
    assert [m.actuator(i).name for i in range(2)] == ["tau1", "tau2"]
    np.testing.assert_array_equal(m.actuator_gear[:, 0], [1, 1])


def test_rods_are_uniform():
    p = ArmParams(m1=2.0, m2=0.5, l1=1.2, l2=0.8)
    m = build_model(p)
    for body, mass, length in ((1, p.m1, p.l1), (2, p.m2, p.l2)):
        assert m.body_mass[body] == mass
        np.testing.assert_allclose(m.body_ipos[body], [length / 2, 0, 0])
        # about the hinge axis (body y): m L^2 / 12
        assert m.body_inertia[body][1] == pytest.approx(mass * length**2 / 12, rel=1e-15)


@pytest.mark.parametrize(
    ("q", "tip"),
    [((0.0, 0.0), (2.0, 0.0)), ((np.pi / 2, 0.0), (0.0, 2.0)), ((0.0, np.pi / 2), (1.0, 1.0))],
)
def test_angles_follow_the_papers_convention(q, tip):
    # theta1 from the horizontal, theta2 relative, the paper's (x, y) is MuJoCo's (x, z)
    plant = Plant.build(ArmParams())
    plant.reset(q)
    site = plant.data.site("tip").xpos
    np.testing.assert_allclose([site[0], site[2]], tip, atol=1e-12)
    assert site[1] == 0


def test_positive_torque_raises_the_link_and_gravity_pulls_down():
    plant = Plant.build(ArmParams(g=0.0))
    plant.reset()
    np.testing.assert_array_less(0, plant.forward([1.0, 0.0])[:1])
    plant = Plant.build(ArmParams())
    plant.reset()
    assert plant.forward([0.0, 0.0])[0] < 0


def test_checked_in_mjcf_files_equal_the_generated_ones():
    # `twolink models --install` regenerates them; this fails if they drift from ArmParams.
    assert (MODELS / "twolink.xml").read_text() == model_xml(ArmParams())
    assert (MODELS / "twolink_flexible.xml").read_text() == model_xml(ArmParams(), Flexibility())
    assert (MODELS / "scene.xml").read_text() == scene_xml("twolink.xml")
    scene = mujoco.MjModel.from_xml_path(str(MODELS / "scene.xml"))
    assert scene.nq == 2


def test_checked_in_mjcf_has_the_same_dynamics_as_the_spec():
    from_file = Plant(mujoco.MjModel.from_xml_path(str(MODELS / "twolink.xml")))
    from_spec = Plant.build(ArmParams())
    for plant in (from_file, from_spec):
        plant.set_state([0.3, -0.7], [1.0, 2.0])
    # the XML prints 6 significant digits of 1/12
    np.testing.assert_allclose(from_file.mass_matrix(), from_spec.mass_matrix(), rtol=1e-6)
    np.testing.assert_allclose(from_file.bias(), from_spec.bias(), rtol=1e-6)


def test_analytic_energy_equals_mujocos():
    rng = np.random.default_rng(5)
    for _ in range(50):
        p = ArmParams(*rng.uniform(0.2, 3.0, 4), g=rng.uniform(0, 20))
        q, qd = rng.uniform(-np.pi, np.pi, 2), rng.uniform(-5, 5, 2)
        plant = Plant.build(p)
        plant.set_state(q, qd)
        kinetic, potential = dynamics.energy(p, q, qd)
        np.testing.assert_allclose(plant.energy(), (kinetic, potential), rtol=1e-12, atol=1e-12)


def test_payload_adds_a_point_mass_at_the_tip():
    p = ArmParams()
    q = np.array([0.2, 0.3])
    plant = Plant.build(p, payload=0.5)
    plant.set_state(q, [0, 0])
    c12 = np.cos(q.sum())
    extra = 0.5 * p.g * np.array([p.l1 * np.cos(q[0]) + p.l2 * c12, p.l2 * c12])
    np.testing.assert_allclose(plant.bias(), dynamics.gravity(p, q) + extra, rtol=1e-9)
    # inertia: the rod's plus the point mass's, mp J^T J with J the tip's Jacobian
    s1, s12 = np.sin(q[0]), np.sin(q.sum())
    jac = np.array(
        [[-p.l1 * s1 - p.l2 * s12, -p.l2 * s12], [p.l1 * np.cos(q[0]) + p.l2 * c12, p.l2 * c12]]
    )
    np.testing.assert_allclose(
        plant.mass_matrix(), dynamics.mass_matrix(p, q) + 0.5 * jac.T @ jac, rtol=1e-12
    )
    with pytest.raises(ValueError, match="payload"):
        build_model(p, payload=-1.0)


def test_flexible_model_layout():
    m = build_model(ArmParams(), Flexibility(k=(300.0, 200.0), d=(0.5, 0.2), j=(0.1, 0.05)))
    assert (m.nq, m.nu) == (4, 2)
    assert [m.joint(i).name for i in range(4)] == ["theta1", "theta2", "phi1", "phi2"]
    np.testing.assert_array_equal(m.tendon_stiffness, [300.0, 200.0])
    np.testing.assert_array_equal(m.tendon_damping, [0.5, 0.2])
    assert [m.actuator(i).name for i in range(2)] == ["tau1", "tau2"]
    assert list(m.actuator_trnid[:, 0]) == [2, 3]


def test_a_static_load_deflects_each_spring_by_g_over_k():
    p = ArmParams(m1=1.2, m2=0.7)
    flex = Flexibility(k=(400.0, 150.0), d=(2.0, 1.0), j=(0.05, 0.02))
    q = np.array([0.4, 0.5])
    g = dynamics.gravity(p, q)
    plant = Plant.build(p, flex)
    # Exact: at phi = q + G/K, motor torque G, the arm is in equilibrium.
    plant.set_state(np.r_[q, q + g / np.array(flex.k)], np.zeros(4))
    np.testing.assert_allclose(plant.forward(g), 0, atol=1e-10)
    # ...and with the springs relaxed (no deflection) it is not.
    plant.set_state(np.r_[q, q], np.zeros(4))
    assert np.abs(plant.forward(g)[:2]).max() > 1.0


def test_flexible_arm_converges_to_the_rigid_one_as_k_grows():
    p = ArmParams()
    j = (0.05, 0.05)
    q0 = np.array([0.3, 0.4])

    def torque(t):
        return dynamics.gravity(p, q0) + np.array([2.0 * np.sin(5 * t), np.cos(3 * t)])

    def run(model, n=5000):
        plant = Plant(model)
        plant.reset(q0)
        for i in range(n):
            plant.step(*torque(i * plant.dt))
        return plant.q

    rigid = build_model(p, timestep=1e-4)
    rigid.dof_armature[:] = j  # the K -> inf limit of Spong's model: rotors ride along
    reference = run(rigid)
    errors = [
        np.abs(
            run(build_model(p, Flexibility(k=(k, k), d=(0.0, 0.0), j=j), timestep=1e-4)) - reference
        ).max()
        for k in (1e2, 1e3, 1e4, 1e5)
    ]
    assert all(b < a / 5 for a, b in zip(errors, errors[1:], strict=False)), errors
    assert errors[-1] < 1e-3


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"k": (0.0, 1.0)}, "k"),
        ({"d": (-1.0, 0.0)}, "d"),
        ({"j": (1.0, float("nan"))}, "j"),
        ({"k": (1.0,)}, "k"),
    ],
)
def test_bad_flexibility_names_the_field(kwargs, field):
    with pytest.raises(ValueError, match=rf"Flexibility\.{field}"):
        Flexibility(**kwargs)
