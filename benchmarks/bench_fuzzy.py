"""The Mamdani engine vs scikit-fuzzy's ControlSystemSimulation, as ratios.

Both run the default 7x7 fuzzy PD system (``controllers.fuzzy.default_fuzzy_pd`` and
its ``to_skfuzzy()`` twin) in the same process on fresh random inputs. skfuzzy runs
``compute()`` with ``cache=False``. Absolute times are noisy on shared machines, so
only the ratios are claimed; each engine figure is the best of several repeats.

(a) one (e, de) pair per call:              target >= 300x faster than skfuzzy
(b) per sample in a batch of 10,000 inputs: target >= 10,000x faster than skfuzzy's
    per-call compute(); skfuzzy's own array-input compute() is printed beside it.
(d) the lookup table (201 x 201, bilinear) per sample on 10^6 inputs: target <= 0.1 us
    and >= 1,000x faster than skfuzzy's array-input compute() of the same rule base.

Also printed: the control loop's call (both joints at once, arrays of length 2) next
to one ``mujoco.mj_step`` of the arm, when ``twolink.arm.plant`` is importable.

    python benchmarks/bench_fuzzy.py
"""

from __future__ import annotations

import math
import time

import numpy as np
from skfuzzy import control as ctrl

from twolink.controllers.fuzzy import default_fuzzy_pd

SK_CALLS = 30  # skfuzzy compute() takes tens of ms per call
REPEATS = 5
BATCH = 10_000


def best_per_call(fn, args: list[tuple], repeats: int = REPEATS) -> float:
    """Best over repeats of the mean time per call of ``fn(*a)`` for a in args [s]."""
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        for a in args:
            fn(*a)
        best = min(best, (time.perf_counter() - start) / len(args))
    return best


def skfuzzy_per_call(system, pairs: np.ndarray) -> tuple[float, np.ndarray]:
    sim = ctrl.ControlSystemSimulation(system, cache=False)
    out = np.empty(len(pairs))
    start = time.perf_counter()
    for n, (e, de) in enumerate(pairs):
        sim.input["e"] = float(e)
        sim.input["de"] = float(de)
        sim.compute()
        out[n] = sim.output["u"]
    return (time.perf_counter() - start) / len(pairs), out


def skfuzzy_array(system, pairs: np.ndarray) -> tuple[float, np.ndarray]:
    sim = ctrl.ControlSystemSimulation(system, cache=False)
    start = time.perf_counter()
    sim.input["e"] = pairs[:, 0].copy()
    sim.input["de"] = pairs[:, 1].copy()
    sim.compute()
    out = np.asarray(sim.output["u"])
    return (time.perf_counter() - start) / len(pairs), out


def mj_step_time() -> float | None:
    try:
        import mujoco

        from twolink.arm.params import ArmParams
        from twolink.arm.plant import build_model
    except ImportError:
        return None
    model = build_model(ArmParams())
    data = mujoco.MjData(model)
    data.ctrl[:] = (1.0, 0.5)
    n = 20_000
    best = np.inf
    for _ in range(REPEATS):
        mujoco.mj_resetData(model, data)
        start = time.perf_counter()
        for _ in range(n):
            mujoco.mj_step(model, data)
        best = min(best, (time.perf_counter() - start) / n)
    return best


def main() -> None:
    import warnings

    warnings.filterwarnings("ignore", category=DeprecationWarning)  # skfuzzy's np.maximum use
    rng = np.random.default_rng(2024)
    engine = default_fuzzy_pd()
    system = engine.to_skfuzzy()

    # (a) one pair per call, fresh inputs each call.
    sk_pairs = rng.uniform(-1.0, 1.0, (SK_CALLS, 2))
    t_sk, sk_out = skfuzzy_per_call(system, sk_pairs)
    ours = np.array([float(engine(e, de)) for e, de in sk_pairs])
    assert np.abs(ours - sk_out).max() <= 1e-9, "engines disagree"
    pairs = [tuple(p) for p in rng.uniform(-1.0, 1.0, (20_000, 2))]
    t_one = best_per_call(engine, pairs)

    # The control loop's call: both joints at once.
    joint_pairs = [(p[:2], p[2:]) for p in rng.uniform(-1.0, 1.0, (20_000, 4))]
    t_two = best_per_call(engine, joint_pairs)

    # (b) a batch of 10,000.
    batch = rng.uniform(-1.0, 1.0, (BATCH, 2))
    best = np.inf
    for _ in range(REPEATS):
        start = time.perf_counter()
        out = engine(batch[:, 0], batch[:, 1])
        best = min(best, time.perf_counter() - start)
    t_batch = best / BATCH
    t_sk_array, sk_batch = skfuzzy_array(system, batch)
    assert np.abs(out - sk_batch).max() <= 1e-9, "engines disagree"

    print("Mamdani 7x7 fuzzy PD (61-point universes, centroid), same inputs, same process")
    print(f"skfuzzy compute(), cache=False, per call:   {t_sk * 1e3:9.2f} ms")
    print(f"skfuzzy compute() on arrays, per sample:    {t_sk_array * 1e6:9.2f} us")
    print(f"engine, one (e, de) pair per call:          {t_one * 1e6:9.2f} us")
    print(f"engine, both joints (length-2 arrays):      {t_two * 1e6:9.2f} us per call")
    print(f"engine, batch of {BATCH}, per sample:      {t_batch * 1e6:9.3f} us")
    print(f"(a) per call, one pair vs skfuzzy:      {t_sk / t_one:10.0f}x  (target >= 300x)")
    print(f"(b) batch per sample vs skfuzzy call:   {t_sk / t_batch:10.0f}x  (target >= 10000x)")
    print(f"    batch per sample vs skfuzzy arrays: {t_sk_array / t_batch:10.0f}x")
    table_ratios(engine, system, t_sk_array, t_batch)
    t_step = mj_step_time()
    if t_step is not None:
        print(
            f"mj_step of the arm: {t_step * 1e6:.2f} us; engine call for both joints = "
            f"{t_two / t_step:.1f} mj_steps"
        )
        closed_loop_ratio()


def table_ratios(engine, system, t_sk_array: float, t_batch: float) -> None:
    """(d) the lookup table (``engine = "table"``, 201 x 201) per sample on 10^6 inputs:
    target <= 0.1 us per sample and >= 1000x faster than skfuzzy's array compute()."""
    from twolink.controllers.fuzzy.table import FuzzyTable, table_bound

    table = FuzzyTable(engine, 201)
    rng = np.random.default_rng(7)
    e, de = rng.uniform(-1.0, 1.0, (2, 1_000_000))
    best = np.inf
    for _ in range(REPEATS):
        start = time.perf_counter()
        table.evaluate_batch(e, de)
        best = min(best, (time.perf_counter() - start) / e.size)
    err = np.abs(table(e[:100_000], de[:100_000]) - engine(e[:100_000], de[:100_000])).max()
    b = table_bound(table)  # proven, per cell (docs/fuzzy.md); the 7x7 has no jump cells
    bound = b.overall
    print(f"table 201x201, per sample on 10^6 inputs: {best * 1e6:9.4f} us  (target <= 0.1 us)")
    print(f"(d) table vs skfuzzy arrays:            {t_sk_array / best:10.0f}x  (target >= 1000x)")
    print(f"    table vs exact batch path:          {t_batch / best:10.1f}x")
    print(
        f"    table error: max {err:.2e} on 10^5 random inputs, proven bound {bound:.2e} "
        f"(L <= {max(b.lipschitz):.3g}, {b.jump_cells} jump cells)"
    )
    assert err <= bound, "table outside its bound"


def closed_loop_ratio() -> None:
    """(c) a 10 s, 1 kHz FCM-CTC closed loop vs a bare mj_step loop of the same length."""
    from bench_ctc import DT, REPEATS, bare_loop, closed_loop  # same folder

    from twolink.arm.params import ArmParams
    from twolink.arm.plant import Plant
    from twolink.controllers.fuzzy import paper_fuzzy_pd
    from twolink.controllers.fuzzy_ctc import FuzzyComputedTorque
    from twolink.foundation.references import ArmReference, Step

    p = ArmParams()
    plant = Plant.build(p, timestep=DT)
    ref = ArmReference(Step(0.0, 1.0), Step(0.0, 0.5))
    results = {}
    for name, engine in (("7x7", default_fuzzy_pd()), ("paper 5-rule", paper_fuzzy_pd())):
        controller = FuzzyComputedTorque(
            p, ref, engine=engine, kp=4.0, kd=2.4, torque_limit=math.inf, ke=1.0, kde=1.0, ku=4.0
        )
        results[name] = min(closed_loop(plant, controller) for _ in range(REPEATS))
    bare = min(bare_loop(plant) for _ in range(REPEATS))
    print(f"bare mj_step loop, 10 s at 1 kHz: {bare * 1e3:.1f} ms")
    for name, t in results.items():
        print(f"(c) FCM-CTC ({name}) closed loop / bare: {t / bare:5.2f}x  (target <= 5x)")


if __name__ == "__main__":
    main()
