"""The closed-loop linearisation of many runs at once (``linearise_many``) against the
single path (``linearise``), the reference, run by run: the same σ and note to the bit,
for every law with a batch form on rigid and flexible plants, every kind of answer, runs
of several gravities in one call, and a law without a batch form; and a sweep's table
computed with it equal to the table of the single path (each row measured by
``measure``)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from tests.test_stability import STEP, Kinked, map_cell, rigid
from twolink import sweep as sw
from twolink.foundation.overrides import merge
from twolink.foundation.references import Sine
from twolink.simulation import stability_batch
from twolink.simulation.config import load_scenario, scenario_from_dict
from twolink.simulation.experiment import build_controller, build_plant, iter_scenarios
from twolink.simulation.stability import linearise
from twolink.simulation.stability_batch import linearise_many
from twolink.studies.judgments.regimes import DEFAULT_STUDY
from twolink.sweep import chunks


def regimes_runs(samples: range, total: int = 150) -> list[tuple]:
    """(scenario, controller) of the regime map's samples (4 controllers each)."""
    plan = sw.load_sweep(DEFAULT_STUDY, {"samples": total})
    _, arms = chunks._chunk_arms(plan, 0, samples)
    return [(s, c) for _, s, c in arms]


def same(a, b) -> bool:
    return (a.sigma == b.sigma or (math.isnan(a.sigma) and math.isnan(b.sigma))) and (
        a.note == b.note
    )


def varied() -> list[tuple]:
    """Runs of every kind at g x 1.1 (the regime map's and the flexible map's): rigid and
    flexible plants, every batch law, the relay, kinks, no rest state, a sensor with
    dynamics, a reference that never rests, a law with no batch form."""
    runs = regimes_runs(range(0, 4))  # CTC whose first start fails; no rest state; a kink
    relay = regimes_runs(range(57, 58))  # FCM-CTC: its rest state on the relay's jump
    runs += relay
    for kind in ("CTC", "FCM-CTC", "motor-PD", "composite", "flexible-FL", "flexible-FL-I"):
        for k, wn in ((2000.0, 4.0), (1e4, 7.0)):
            s = map_cell(kind, k, wn)
            runs.append((s, build_controller(s)))
    for kind in ("ctc_integral", "pd_gravity", "fuzzy_ctc", "fuzzy_pd", "fcm_ctc"):
        extra = {"rule_base": "designed"} if kind == "fcm_ctc" else {}
        s = rigid(kind, **extra)
        runs.append((s, build_controller(s)))
    s = rigid("ctc")
    sensed = load_scenario(STEP, {"sensor": {"velocity": "filtered", "cutoff_hz": 50.0}})
    sine = replace(s, reference=replace(s.reference, joint1=Sine(0.2, 0.5)))
    kinked = Kinked(
        model=s.arm, reference=s.reference, kp=(100.0, 100.0), kd=(12.0, 12.0),
        torque_limit=(math.inf, math.inf), c=150.0,
    )  # fmt: skip
    runs += [(sensed, build_controller(sensed)), (sine, build_controller(sine)), (s, kinked)]
    return runs


def test_many_runs_give_each_its_single_answer_to_the_bit(monkeypatch):
    alone_calls = []  # runs the batch path hands to the single one

    def counted(s, plant, c, *args):
        alone_calls.append(type(c).__name__)
        return linearise(s, plant, c, *args)

    monkeypatch.setattr(stability_batch, "linearise", counted)
    items = []
    for k, (s, c) in enumerate(varied()):
        near = None  # else a point off the target: the second start where the first fails
        if k % 2:
            q = np.array(s.reference.final) + 0.05
            near = (q, q if s.plant.flexibility is not None else ())
        items.append((s, c, near))
    notes = set()
    for g in {s.plant_params.g for s, _, _ in items}:  # one model's gravity each
        group = [item for item in items if item[0].plant_params.g == g]
        for (s, c, near), got in zip(group, linearise_many(group), strict=True):
            alone = linearise(s, build_plant(s), c, near=near)
            assert same(got, alone), (s.controller.kind, got, alone)
            notes.add(alone.note.split(":")[0])
    assert alone_calls == ["Kinked"]  # only the law without a batch form went alone
    # the set covers every answer the single path gives
    assert {
        "",
        "no rest state found near the target",
        "the law jumps at its rest state (a relay)",
        "a kink at the rest state",
        "a sensor with dynamics of its own",
        "a reference that never rests",
    } <= notes


def test_runs_of_several_gravities_in_one_call_each_get_their_single_answer():
    # A model has one gravity: an arm of another g would be tilted (equal to rounding
    # only, ~2e-9 in σ here), so each g gets its own model and every answer is the bit's.
    runs = regimes_runs(range(0, 6), 30)
    items = []
    for k, (s, c) in enumerate(runs):
        g = (0.9, 1.1, -1.0)[k % 3]
        data = merge(s.to_dict(), {"plant": {"scale": {"g": g}}})
        items.append((scenario_from_dict(data, str(DEFAULT_STUDY)), c, None))
    alone = [linearise(s, build_plant(s), c) for s, c, _ in items]
    for got, ref in zip(linearise_many(items), alone, strict=True):
        assert same(got, ref), (got, ref)


def test_an_error_is_the_runs_own_as_alone():
    s = rigid("ctc")
    broken = build_controller(s)
    broken.kp = None  # raises inside the law, batch or alone
    out = linearise_many([(s, build_controller(s), None), (s, broken, None)])
    assert isinstance(out[1], Exception)
    assert same(out[0], linearise(s, build_plant(s), build_controller(s)))
    with pytest.raises(type(out[1])):
        linearise(s, build_plant(s), broken)


def old_rows(plan, chunk: int) -> list[tuple]:
    """A chunk's rows by the single path: every run measured alone by ``measure``."""
    rows, arms = chunks._chunk_arms(plan, chunk)
    for k, traj in iter_scenarios([s for _, s, _ in arms], [c for _, _, c in arms]):
        r, s, c = arms[k]
        i, name, head = rows[r]
        rows[r] = chunks._measured_row(i, name, head, s, traj, c)
    return rows


def test_a_sweeps_table_is_the_single_paths():
    plan = sw.load_sweep(DEFAULT_STUDY, {"samples": 6, "chunk_size": 6})
    new = chunks.run_chunk(plan, 0).rows
    old = old_rows(plan, 0)
    assert len(new) == len(old) == 24
    for a, b in zip(new, old, strict=True):
        assert len(a) == len(b)
        for x, y in zip(a, b, strict=True):
            assert x == y or (isinstance(x, float) and math.isnan(x) and math.isnan(y)), (a, b)
