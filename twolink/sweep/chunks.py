"""Computing a sweep's chunks: the rows of one chunk (or a part of one) as one batch of arms,
on the CPU engine or MJX. :mod:`twolink.sweep.execution` runs these as an executor's
tasks and writes the chunk files."""

from __future__ import annotations

import copy
import math
import os
import time
from concurrent import futures
from dataclasses import dataclass
from typing import Any

from twolink.controllers.batch import batched
from twolink.simulation.config import scenario_from_dict
from twolink.simulation.experiment import (
    build_controller,
    iter_scenarios,
    measure,
    measure_runs,
)
from twolink.simulation.vocabulary import joint_values
from twolink.sweep.plan import SweepPlan, gains
from twolink.sweep.results import METRIC_COLUMNS, STATUS_ERROR

__all__ = ["ChunkResult", "run_chunk", "run_chunk_part", "run_chunks"]

# ----------------------------------------------------------------------------- computing


@dataclass(frozen=True)
class ChunkResult:
    """The rows of one chunk, as computed by a worker.

    Attributes
    ----------
    chunk : int
        Chunk index.
    rows : tuple of tuple
        One row per (sample, controller), in sample then controller order, with the
        values of :attr:`SweepPlan.columns`.
    wall_s : float
        Seconds the worker spent on it.
    pid : int
        The worker's process id.
    """

    chunk: int
    rows: tuple[tuple[Any, ...], ...]
    wall_s: float
    pid: int


def _metric_values(m: Any) -> list[float]:
    """A run's metrics in :data:`METRIC_COLUMNS` order."""
    return [v for j in (1, 2) for v in joint_values(m, j).values()]


def _error_text(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"


def run_chunk(plan: SweepPlan, chunk: int, backend: str = "cpu") -> ChunkResult:
    """Compute every (sample, controller) of one chunk, as one batch of arms.

    The controllers are built once per chunk, and once per swept ``wn`` (they are modelled
    on the nominal arm, which does not change; a flexible-joint controller is given each
    sample's joints, ``with_joints``). A law without a batch form is called arm by arm and
    keeps its state (integrator, estimate, observer) itself, so each arm gets its own copy
    (:func:`twolink.controllers.batch.batched`). Every (sample, controller) is one arm of
    the batch engine (:func:`twolink.simulation.experiment.iter_scenarios`). A sample that
    raises or diverges gives rows with status "error" or "diverged" and the message; it
    never stops the chunk.
    ``backend``: iter_scenarios'.
    """
    start = time.perf_counter()
    rows, arms = _chunk_arms(plan, chunk)
    _measure_arms(rows, arms, backend, plan.model_gravity())
    return ChunkResult(chunk, tuple(rows), time.perf_counter() - start, os.getpid())


def run_chunk_part(plan: SweepPlan, chunk: int, start: int, stop: int) -> list[ChunkResult]:
    """:func:`run_chunk` of the samples ``start`` to ``stop - 1`` of a chunk (a pool's
    task where there are fewer missing chunks than workers: each chunk is split so that
    every worker computes; the parts are written as the chunk's one file)."""
    begin = time.perf_counter()
    rows, arms = _chunk_arms(plan, chunk, range(start, stop))
    _measure_arms(rows, arms, "cpu", plan.model_gravity())
    return [ChunkResult(chunk, tuple(rows), time.perf_counter() - begin, os.getpid())]


def _chunk_arms(
    plan: SweepPlan, chunk: int, samples: range | None = None
) -> tuple[list[Any], list[tuple[int, Any, Any]]]:
    """A chunk's rows (an error now, or a placeholder) and the arms that will fill them
    (``samples``: a part of the chunk's samples, default all)."""
    controllers: dict[Any, Any] = {}  # (name, gains) -> the controller or its build error

    def controller_of(name: str, values: dict[str, float]) -> Any:
        key = (name, tuple(gains(values).items()))  # a swept ``wn``: one per bandwidth
        if key not in controllers:
            try:
                s = scenario_from_dict(plan.controller_data(name, values), plan.file)
                controllers[key] = build_controller(s)
            except Exception as exc:  # recorded on every row of this controller
                controllers[key] = _error_text(exc)
        return controllers[key]

    # Rows in sample then controller order: an error now, or the arm that will fill it.
    rows: list[Any] = []
    arms: list[tuple[int, Any]] = []  # (row, scenario) of every arm to simulate
    for i in plan.chunk_samples(chunk) if samples is None else samples:
        values, noise_seed = plan.draw(i)
        head = list(values.values())
        try:
            s = scenario_from_dict(plan.sample_data(values, noise_seed), plan.file)
            sample_error = ""
        except Exception as exc:
            sample_error = _error_text(exc)
        for name in plan.controller_names:
            controller = controller_of(name, values)
            error = sample_error or (controller if isinstance(controller, str) else "")
            if error:
                rows.append(_error_row(i, name, head, error))
            else:
                if getattr(controller, "needs_motor", False):  # models the sample's joints
                    controller = controller.with_joints(s.plant.flexibility)
                if not batched(controller):  # called arm by arm: its state is this arm's
                    controller = copy.deepcopy(controller)
                arms.append((len(rows), s, controller))
                rows.append((i, name, head))
    return rows, arms


def _measure_arms(
    rows: list[Any], arms: list[tuple[int, Any, Any]], backend: str, model_g: float
) -> None:
    """Simulate the arms and fill their rows, measured as each batch ends (one trajectory
    at a time is ever held), their loops linearised together at the end
    (:func:`twolink.simulation.experiment.measure_runs`: :func:`measure`'s metrics).
    ``model_g``: the sweep's model gravity, the same for every chunk and part of one."""
    scenarios, controllers = [s for _, s, _ in arms], [c for _, _, c in arms]
    runs = iter_scenarios(scenarios, controllers, backend, model_g)
    done: list[tuple[int, bool, str, str]] = []  # (row, ok, status, message) per arm run

    def measured():
        for k, traj in runs:
            r, s, controller = arms[k]
            if isinstance(traj, Exception):
                i, name, head = rows[r]
                rows[r] = _measured_row(i, name, head, s, traj)
                continue
            done.append((r, traj.ok, traj.status, traj.message))
            yield s, traj, controller

    for (r, ok, status, message), metrics in zip(done, measure_runs(measured()), strict=True):
        i, name, head = rows[r]
        if isinstance(metrics, Exception):
            if ok:
                rows[r] = _error_row(i, name, head, _error_text(metrics))
                continue
            values = _NAN_METRICS  # diverged too early to measure anything
        else:
            values = _metric_values(metrics)
        rows[r] = (i, name, *head, *values, status, message)


def run_chunks(
    plan: SweepPlan, chunks: list[int], threads: int = 1, backend: str = "cpu"
) -> list[ChunkResult]:
    """:func:`run_chunk` of several chunks, ``threads`` at a time in threads of this process
    (the in-process executor's task): MuJoCo releases the GIL while it steps, so one
    process steps several batches on several cores. Each chunk is its own batch, as on a
    pool, so its rows do not depend on the executor or the number of threads.

    On the accelerator backend (``backend`` "mjx", "mjx-float32") the arms of all the
    chunks form one batch (batches of at most ``BATCH_RECORD_BYTES`` of records): the
    device's width is the parallelism, and the loop is compiled once for them all; each
    chunk still gets its own rows, and a share of the time by its rows."""
    if backend != "cpu":
        start = time.perf_counter()
        parts = [_chunk_arms(plan, c) for c in chunks]
        rows = [r for part_rows, _ in parts for r in part_rows]
        arms, offset = [], 0
        for part_rows, part_arms in parts:
            arms += [(offset + r, s, c) for r, s, c in part_arms]
            offset += len(part_rows)
        _measure_arms(rows, arms, backend, plan.model_gravity())
        share = (time.perf_counter() - start) / max(1, len(rows))
        out, offset = [], 0
        for chunk, (part_rows, _) in zip(chunks, parts, strict=True):
            n = len(part_rows)
            out.append(ChunkResult(chunk, tuple(rows[offset : offset + n]), share * n, os.getpid()))
            offset += n
        return out
    if threads <= 1 or len(chunks) == 1:
        return [run_chunk(plan, c) for c in chunks]
    with futures.ThreadPoolExecutor(min(threads, len(chunks))) as pool:
        return list(pool.map(run_chunk, [plan] * len(chunks), chunks))


_NAN_METRICS = [math.nan] * len(METRIC_COLUMNS)


def _error_row(i: int, name: str, head: list[Any], error: str) -> tuple[Any, ...]:
    return (i, name, *head, *_NAN_METRICS, STATUS_ERROR, error)


def _measured_row(
    i: int, name: str, head: list[Any], s: Any, traj: Any, controller: Any = None
) -> tuple[Any, ...]:
    """The row of one simulated arm (``traj`` is the exception where it could not run)."""
    if isinstance(traj, Exception):
        return _error_row(i, name, head, _error_text(traj))
    try:
        metrics = _metric_values(measure(s, traj, controller))
    except Exception as exc:
        if traj.ok:
            return _error_row(i, name, head, _error_text(exc))
        metrics = _NAN_METRICS  # diverged too early to measure anything
    return (i, name, *head, *metrics, traj.status, traj.message)
