"""Measuring many runs at once (``measure_runs``, a sweep's chunks) gives every run what
``measure`` gives it alone, and the fuzzy term's share read through the compiled kernel
is the one the engine's numpy path gives (it decides where |u| is near the threshold)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.test_stability import rigid
from twolink import sweep as sw
from twolink.simulation import experiment as ex
from twolink.simulation.experiment import (
    FUZZY_ACTS,
    build_controller,
    fuzzy_active_share,
    measure,
    measure_runs,
    run_scenario,
)
from twolink.studies.judgments.regimes import DEFAULT_STUDY
from twolink.sweep import chunks


def same_metrics(a, b) -> bool:
    def equal(x, y):
        if isinstance(x, float):
            return x == y or (math.isnan(x) and math.isnan(y))
        if isinstance(x, tuple):
            return len(x) == len(y) and all(equal(u, v) for u, v in zip(x, y, strict=True))
        if hasattr(x, "__dataclass_fields__"):
            return all(equal(getattr(x, f), getattr(y, f)) for f in x.__dataclass_fields__)
        return x == y

    return equal(a, b)


def test_many_runs_are_measured_as_each_alone():
    runs = []
    for kind in ("ctc", "ctc_integral", "fcm_ctc"):
        extra = {"rule_base": "designed"} if kind == "fcm_ctc" else {}
        s = rigid(kind, **extra)
        runs.append((s, run_scenario(s), build_controller(s)))
    s = rigid("ctc", kp=1e9, kd=1.0, torque_limit=1e12)  # diverges: measured, no growth
    runs.append((s, run_scenario(s), build_controller(s)))
    assert not runs[-1][1].ok
    for (s, traj, c), got in zip(runs, measure_runs(iter(runs)), strict=True):
        assert same_metrics(got, measure(s, traj, c))


def test_the_fuzzy_share_through_the_kernel_is_the_numpy_paths():
    pytest.importorskip("numba")  # the kernel is used where numba is loaded (a sweep worker)
    from twolink.controllers.fuzzy import kernels

    assert kernels.available()
    plan = sw.load_sweep(DEFAULT_STUDY, {"samples": 30})
    _, arms = chunks._chunk_arms(plan, 0, range(0, 8))
    fuzzy = [(s, c) for _, s, c in arms if getattr(c, "engine", None) is not None]
    assert len(fuzzy) == 16  # FCM-CTC (the exact Mamdani engine) and its continuous form
    acting = 0
    for s, c in fuzzy:
        traj = run_scenario(s, c)
        u = c.engine(c.ke * traj.e, c.kde * traj.de)  # the numpy path, as before
        expected = np.mean(np.abs(u) > FUZZY_ACTS, axis=0)
        assert fuzzy_active_share(c, traj) == (float(expected[0]), float(expected[1]))
        acting += bool(expected.any())
    assert acting  # the term acts somewhere: the shares are not all 0


class Edge:
    """An engine whose kernel says |u| is just above the threshold, where its numpy path
    (the call) says it is just below: the numpy path must decide."""

    def __call__(self, e, de):
        return np.full(np.shape(e), FUZZY_ACTS * (1 - 1e-6))

    def evaluate_compiled(self, e, de):
        return np.full(np.shape(e), FUZZY_ACTS * (1 + 1e-6))


def test_near_the_threshold_the_engines_numpy_path_decides(monkeypatch):
    pytest.importorskip("numba")
    e = np.zeros((10, 2))
    assert np.array_equal(ex._fuzzy_output(Edge(), e, e), Edge()(e, e))
    far = Edge()
    far.evaluate_compiled = lambda e, de: np.full(np.shape(e), 0.5)
    assert np.array_equal(ex._fuzzy_output(far, e, e), np.full((10, 2), 0.5))


def test_settling_time_alone_is_step_metrics_ts():
    from twolink.simulation.metrics import settling_time, step_metrics

    t = np.linspace(0.0, 4.0, 4001)
    rng = np.random.default_rng(3)
    signals = [
        1.0 - np.exp(-3 * t) * np.cos(5 * t),  # settles with overshoot
        0.9 * (1.0 - np.exp(-3 * t)),  # settles off the target (10 % short): never within 2 %
        1.0 - np.exp(-3 * t) + 0.01 * rng.standard_normal(t.size),  # noisy
        np.where(t < 3.999, 1.0, np.nan),  # not finite at the end
        0.5 + 0.5 * np.sin(3 * t),  # never settles
    ]
    for y in signals:
        for target, y0 in ((1.0, 0.0), (0.98, 0.1), (-1.0, 0.5)):
            expected = step_metrics(t, y, target, y0=y0, final_value=target).settling_time
            got = settling_time(t, y, target, y0)
            assert got == expected or (math.isnan(got) and math.isnan(expected))
            expected = step_metrics(t, y, target, y0=y0, final_value=0.9).settling_time
            got = settling_time(t, y, target, y0, final_value=0.9)
            assert got == expected or (math.isnan(got) and math.isnan(expected))


def test_errors_torques_and_maxima_are_the_plain_numpy_forms_bit_for_bit():
    # error_measures and torque_measures sum several (N, k) arrays in one reduction and
    # take maxima on transposed copies (cheaper); each must equal the plain form exactly
    from twolink.simulation import metrics as me

    def plain_errors(t, e):
        tt = t if e.ndim == 1 else t[:, None]
        a = np.abs(e)
        return [me._trapezoid(f, t) for f in (a, e * e, tt * a)] + [np.max(a, axis=0)]

    def plain_torque(tau):
        with np.errstate(over="ignore"):
            rms = np.sqrt(np.mean(tau * tau, axis=0))
        return [np.max(np.abs(tau), axis=0), rms, np.sum(np.abs(np.diff(tau, axis=0)), axis=0)]

    def bits(values):
        return [np.asarray(v, dtype=float).tobytes() for v in values]

    rng = np.random.default_rng(7)
    for trial in range(300):
        n = int(rng.choice([1, 2, 3, 17, 1000, 4001, 8193]))
        k = int(rng.integers(1, 4))
        shape = (n,) if trial % 10 == 0 else (n, k)
        x = rng.standard_normal(shape) * 10.0 ** rng.uniform(-8, 8)
        if trial % 5 == 1:
            x.flat[rng.integers(0, x.size)] = np.nan
        if trial % 5 == 2:
            x.flat[rng.integers(0, x.size)] = -np.inf
        if trial % 5 == 3:
            x[...] = -0.0
        t = np.cumsum(rng.uniform(1e-4, 1e-2, n)) - (5.0 if trial % 3 == 0 else 0.0)
        got = me.error_measures(t, x)
        assert bits([got.iae, got.ise, got.itae, got.max_abs]) == bits(plain_errors(t, x))
        got = me.torque_measures(x)
        assert bits([got.peak, got.rms, got.variation]) == bits(plain_torque(x))
        if x.ndim == 2:
            m = np.abs(x)
            assert me.column_max(m).tobytes() == np.max(m, axis=0).tobytes()
