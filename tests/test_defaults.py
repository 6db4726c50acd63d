"""Every controller's defaults are the shipped design (docs/control.md, "Defaults"), so
two built with their defaults compare fairly."""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import numpy as np
import pytest

import twolink
import twolink.controllers
from twolink import (
    ArmParams,
    ArmReference,
    ComputedTorque,
    Flexibility,
    FuzzyComputedTorque,
    Quintic,
    Step,
)
from twolink.controllers.fuzzy import default_fuzzy_pd
from twolink.simulation.config import load_scenario
from twolink.simulation.experiment import build_controller


def design():
    """The shipped design: runs/paper/base.toml's [controller], as the scenario reads it."""
    return load_scenario("paper/base").controller


def controller_classes() -> list[type]:
    for info in pkgutil.walk_packages(twolink.controllers.__path__, "twolink.controllers."):
        importlib.import_module(info.name)
    found, todo = set(), [ComputedTorque]
    while todo:
        cls = todo.pop()
        found.add(cls)
        todo.extend(cls.__subclasses__())
    return sorted((c for c in found if not c.__name__.startswith("_")), key=lambda c: c.__name__)


ARM = ArmParams()
MOVE = ArmReference(Quintic(0.0, 1.0, 2.0), Step(0.0, 0.0))


def test_the_defaults_are_base_tomls_controller():
    c = design()
    assert (c.kp, c.kd, c.torque_limit) == ((225.0, 225.0), (30.0, 30.0), (60.0, 15.0))
    from twolink.controllers import baselines, ctc

    assert (ctc.DEFAULT_KP, ctc.DEFAULT_KD) == (c.kp[0], c.kd[0])
    assert ctc.DEFAULT_TORQUE_LIMIT == c.torque_limit
    assert baselines.DEFAULT_KI == c.ki[0]


@pytest.mark.parametrize("cls", controller_classes(), ids=lambda c: c.__name__)
def test_every_controller_defaults_to_the_shipped_gains_and_limits(cls):
    params = inspect.signature(cls).parameters
    kwargs = {"engine": default_fuzzy_pd()} if "engine" in params else {}
    if "joints" in params:  # the flexible-joint laws need the joints' model, no gain
        kwargs["joints"] = Flexibility.realistic()
    c = cls(ARM, MOVE, **kwargs)
    d = design()
    assert (tuple(c.kp), tuple(c.kd), tuple(c.torque_limit)) == (d.kp, d.kd, d.torque_limit)
    from twolink.controllers.baselines import IntegralComputedTorque

    if isinstance(c, IntegralComputedTorque):  # the flexible laws derive theirs from ωn
        assert tuple(c.ki) == d.ki


def test_there_are_controllers_to_check():
    names = {c.__name__ for c in controller_classes()}
    assert {"ComputedTorque", "FuzzyComputedTorque", "IntegralComputedTorque", "PDGravity",
            "FuzzyPD", "MotorPD", "FlexibleFeedbackLinearisation"} <= names  # fmt: skip


def test_the_fcm_constructor_has_the_same_defaults():
    sig = inspect.signature(FuzzyComputedTorque.fcm).parameters
    d = design()
    assert (sig["kp"].default, sig["kd"].default) == (d.kp[0], d.kd[0])
    assert tuple(sig["torque_limit"].default) == d.torque_limit


def test_a_default_ctc_is_the_shipped_scenarios_ctc():
    """On random states the default ComputedTorque gives the shipped θ1 step's torques
    (the earlier defaults, Kp 4, Kd 2.4 and no limit, gave others)."""
    s = load_scenario("paper/theta1_step")
    shipped, ours = build_controller(s), ComputedTorque(s.arm, s.reference)
    rng = np.random.default_rng(0)
    saturated = 0
    for q, qd in rng.normal(0, 0.6, (50, 2, 2)):
        t = float(rng.uniform(0, 3))
        assert ours(t, q, qd) == shipped(t, q, qd)
        saturated += abs(ours(t, q, qd)[1]) == 15.0
    assert saturated > 0  # the limit is among what was compared


def test_a_default_fuzzy_ctc_is_the_shipped_fcm_ctc():
    s = load_scenario("paper/theta1_step", {"controller": {"kind": "fcm_ctc"}})
    shipped = build_controller(s)
    engine = default_fuzzy_pd().with_rules(twolink.load_rule_base("designed"))
    ours = FuzzyComputedTorque(s.arm, s.reference, engine=engine)
    fcm = FuzzyComputedTorque.fcm(s.arm, s.reference)
    for c in (ours, fcm):
        assert (c.ke, c.kde, c.ku) == (shipped.ke, shipped.kde, shipped.ku)
        assert (c.kp, c.kd, c.torque_limit) == (shipped.kp, shipped.kd, shipped.torque_limit)
    # a scaling given is kept, the others follow from it (as a scenario's "auto")
    half = FuzzyComputedTorque(s.arm, s.reference, engine=engine, ke=shipped.ke / 2)
    assert half.ke == shipped.ke / 2 and half.kde == pytest.approx(shipped.kde / 2)
