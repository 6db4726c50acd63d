"""Computing a sweep: chunks of samples on an executor, resumable, stoppable.

Each chunk's rows are written to ``chunks/chunk_NNNNN.parquet`` as soon as it finishes,
and logged in ``computed.log``; a rerun of the same sweep into the same folder computes
only the chunks that are missing. SIGINT and SIGTERM stop the sweep between chunk
writes, so a chunk file and its log line are always written together.
"""

from __future__ import annotations

import hashlib
import signal
import sys
import threading
import time
from collections.abc import Iterator, Sequence
from concurrent import futures
from contextlib import ExitStack, contextmanager
from dataclasses import asdict, dataclass, field
from itertools import pairwise
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from twolink.foundation.executors import (
    SWEEP_PRELOAD,
    SweepExecutor,
    check_options,
    in_pool_worker,
    open_executor,
)
from twolink.foundation.interrupts import interrupts_held
from twolink.foundation.io import (
    ForeignOutput,
    append_line,
    atomic_write_json,
    atomic_write_text,
    owned_output,
    refuse_links,
)
from twolink.foundation.planted import read_bounded, read_json, shown
from twolink.simulation.experiment import BACKENDS
from twolink.simulation.outcome import classify
from twolink.sweep.chunks import (  # run_chunk, ChunkResult: re-exported from their old home
    ChunkResult,
    _error_text,
    run_chunk,
    run_chunk_part,
    run_chunks,
)
from twolink.sweep.plan import FORMAT_VERSION, SweepPlan
from twolink.sweep.results import (
    read_table,
    results_frame,
    summarize,
    write_summary,
    write_table,
)

__all__ = [
    "ChunkResult",
    "SweepInterrupted",
    "SweepOutcome",
    "SweepOutputError",
    "SweepTaskError",
    "run_chunk",
    "run_chunks",
    "run_sweep",
    "run_sweeps",
]

# ----------------------------------------------------------------------------- chunk files


# A chunk file read back is at most this large (a chunk of 10^4 rows is ~2 MB).
MAX_CHUNK_BYTES = 1 << 30


def _chunk_path(out: Path, chunk: int) -> Path:
    return out / "chunks" / f"chunk_{chunk:05d}.parquet"


def _chunk_frame(plan: SweepPlan, rows: Any) -> pd.DataFrame:
    return results_frame(rows, plan.columns, plan.meta)


def _seal_path(path: Path) -> Path:
    return path.with_suffix(".json")


def _seal(plan: SweepPlan, path: Path) -> None:
    """Write the chunk's seal: the sweep it belongs to and the SHA-256 of its bytes."""
    sha = hashlib.sha256(path.read_bytes()).hexdigest()
    atomic_write_json(_seal_path(path), {"digest": plan.digest, "sha256": sha})


def _seal_digest(path: Path) -> str | None:
    """The sweep digest a chunk's seal names, None where it has no readable seal."""
    try:
        return read_json(_seal_path(path), 1 << 16).get("digest")
    except (OSError, ValueError, AttributeError):
        return None


def _valid_chunk(plan: SweepPlan, out: Path, chunk: int) -> pd.DataFrame | None:
    """The chunk's rows if its file is whole (its bytes match its seal's checksum), of this
    sweep, and holds exactly the rows the plan asks for; else None (it is computed again)."""
    path = _chunk_path(out, chunk)
    if not path.is_file():
        return None
    try:
        seal = read_json(_seal_path(path), 1 << 16)
        data = read_bounded(path, MAX_CHUNK_BYTES)
        if seal != {"digest": plan.digest, "sha256": hashlib.sha256(data).hexdigest()}:
            return None  # edited, cut short, of another sweep, or never sealed
        df = read_table(path)
    except (OSError, ValueError):  # pyarrow's errors for a damaged file are ValueErrors
        return None
    expected = [(i, c) for i in plan.chunk_samples(chunk) for c in plan.controller_names]
    if (
        tuple(df.columns) != plan.columns
        or list(zip(df["sample"], df["controller"], strict=True)) != expected
    ):
        return None  # e.g. the last chunk of a run with fewer samples
    return df


# ----------------------------------------------------------------------------- running


class SweepInterrupted(Exception):
    """The sweep stopped on SIGINT/SIGTERM; finished chunks are kept.

    Attributes
    ----------
    signum : int
        The signal that stopped it.
    done, total : int
        Chunks on disk and chunks in the sweep (in the sweeps, of :func:`run_sweeps`).
    out : Path
        The (first) sweep's folder.
    """

    def __init__(self, signum: int, done: int, total: int, out: Path, *more: Path):
        self.signum, self.done, self.total, self.out = signum, done, total, out
        kept = ", ".join(str(folder / "chunks") for folder in (out, *more))
        super().__init__(
            f"interrupted by {signal.Signals(signum).name}: {done}/{total} chunks are kept in "
            f"{kept}; run the same command again to compute only the missing ones"
        )


class SweepOutputError(RuntimeError):
    """The output folder holds a different sweep's chunks."""


class SweepTaskError(RuntimeError):
    """A chunk task failed outside the per-sample error handling (a bug or a lost worker)."""


@dataclass(frozen=True)
class SweepOutcome:
    """What a finished :func:`run_sweep` did.

    Attributes
    ----------
    out : Path
        The output folder.
    table : Path
        ``results.parquet``.
    results : pandas.DataFrame
        The results table (see :mod:`twolink.sweep.results`).
    summary : dict
        :func:`summarize`'s output.
    computed, reused : tuple of int
        Chunks computed by this call, and chunks found on disk.
    wall_s : float
        Seconds from start to finished table (plots not included).
    busy_s : float
        Seconds the workers spent inside the computed chunks, summed over chunks.
    workers : int
        Size of the executor (0 when nothing was computed).
    """

    out: Path
    table: Path
    results: pd.DataFrame
    summary: dict[str, Any]
    computed: tuple[int, ...]
    reused: tuple[int, ...]
    wall_s: float
    busy_s: float
    workers: int


def _prepare_out(plan: SweepPlan, out: Path, fresh: bool, replace_other: bool = False) -> None:
    manifest_path = out / "manifest.json"
    chunk_dir = out / "chunks"
    for path in (manifest_path, chunk_dir, out / "computed.log"):
        refuse_links(path)  # nothing read, deleted or written through a planted link
    chunks = sorted(chunk_dir.glob("chunk_*.parquet")) if chunk_dir.is_dir() else []
    digest = old_format = None
    if manifest_path.is_file():
        try:
            saved = read_json(manifest_path)
            digest, old_format = saved.get("digest"), saved.get("format")
        except (OSError, ValueError, AttributeError):
            digest = None  # a damaged manifest: each chunk's seal says whose it is
    if digest is None:
        sealed = {_seal_digest(path) for path in chunks} - {None}
        digest = next(iter(sealed - {plan.digest}), plan.digest if sealed else None)
    foreign = digest is not None and digest != plan.digest
    if foreign and not (fresh or replace_other):
        older = (
            f", written in results format {old_format} (this version writes {FORMAT_VERSION}: "
            "other columns)"
            if old_format is not None and old_format != FORMAT_VERSION
            else ""
        )
        raise SweepOutputError(
            f"{out} holds results of a different sweep (its digest "
            f"{shown(digest, 12)} != {plan.digest[:12]} of {plan.file}{older}); "
            "use another --out, or --fresh to discard them"
        )
    if foreign or fresh:
        for path in chunk_dir.glob("chunk_*") if chunk_dir.is_dir() else ():
            path.unlink()
        (out / "computed.log").unlink(missing_ok=True)
    out.mkdir(parents=True, exist_ok=True)
    if chunk_dir.exists() and not chunk_dir.is_dir():
        raise ForeignOutput(f"{chunk_dir}: is not a folder; twolink does not replace it")
    chunk_dir.mkdir(exist_ok=True)
    atomic_write_json(
        manifest_path,
        {
            "format": FORMAT_VERSION,
            "digest": plan.digest,
            "file": plan.file,
            "file_sha256": plan.file_sha256,
            "name": plan.name,
            "samples": plan.samples,
            "seed": plan.seed,
            "chunk_size": plan.chunk_size,
            "controllers": list(plan.controller_names),
            "parameters": list(plan.parameter_names),
            "joints": list(plan.joints),
            "columns": list(plan.columns),
        },
    )
    atomic_write_text(out / "sweep.toml", Path(plan.file).read_text())


class _StopSignals:
    """SIGINT and SIGTERM recorded (the first decides the exit code), acted on where the
    sweep can stop cleanly.

    While the driver waits for its tasks (:meth:`waiting`), the handler only records: the
    driver raises KeyboardInterrupt at its next turn (within :data:`STOP_POLL_S`), so the
    signal never lands in a library's callback or ``__del__``, where Python prints
    "Exception ignored" and drops it. Elsewhere (an in-process chunk, a pool starting) it
    raises at once, as a Ctrl-C does.

    A chunk file and its log line are written with both held back
    (:func:`twolink.foundation.interrupts.interrupts_held`): a handler runs in the main thread,
    whichever thread the signal reached, so a deferred handler, not a signal mask, is
    what keeps them together.

    Not in a pool worker (a sweep run as a worker's task: the reproduction's flexible-joint
    studies): its SIGINT stays ignored and its SIGTERM ends it at once
    (:func:`twolink.foundation.executors.in_pool_worker`). Taken over, the abort's SIGTERM
    unwound the worker's sweep by a KeyboardInterrupt (seen landing in numba's compiler,
    whose callbacks print such a one as "Exception ignored" and drop it), which wrote its
    folder's record after the command had stopped and kept the worker alive until the
    abort's SIGKILL.
    """

    def __init__(self) -> None:
        self.received: list[int] = []
        self._waiting = False

    def _handler(self, signum: int, frame: Any) -> None:
        self.received.append(signum)
        if not self._waiting:
            raise KeyboardInterrupt

    @contextmanager
    def waiting(self) -> Iterator[None]:
        """A block in which the handler only records (the caller checks :meth:`check`)."""
        self._waiting = True
        try:
            yield
        finally:
            self._waiting = False

    def check(self) -> None:
        """Raise KeyboardInterrupt if a signal was received (also one a library dropped)."""
        if self.received:
            raise KeyboardInterrupt

    @contextmanager
    def installed(self) -> Iterator[None]:
        """Install the handlers for SIGINT and SIGTERM (main thread, not a pool worker)."""
        if threading.current_thread() is not threading.main_thread() or in_pool_worker():
            yield  # leave signals to the caller, or to the worker's own handlers
            return
        old = {s: signal.signal(s, self._handler) for s in (signal.SIGINT, signal.SIGTERM)}
        try:
            yield
        finally:
            for s, handler in old.items():
                signal.signal(s, handler)


STOP_POLL_S = 0.1  # s between the driver's checks for a signal while it waits for tasks


def run_sweep(
    plan: SweepPlan,
    out: str | Path,
    executor: str | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = False,
    plots: bool = True,
    fresh: bool = False,
    pool: SweepExecutor | None = None,
    replace_other: bool = False,
    backend: str = "cpu",
) -> SweepOutcome:
    """Compute the missing chunks of a sweep, then write its table, summary and plots.

    Parameters
    ----------
    plan : SweepPlan
        From :func:`load_sweep`.
    out : str or Path
        Output folder. Chunks already there (of the same sweep) are kept, not recomputed.
    executor, workers, scheduler : optional
        See :func:`twolink.foundation.executors.open_executor`; default: the sweep file's
        ``[execution]`` table, else a process pool on all cores.
    pool : SweepExecutor, optional
        An executor already running (the reproduction's pool): the chunks go to it, and
        it is left open; ``executor``, ``workers`` and ``scheduler`` are then unused.
    progress : bool
        Show a tqdm progress bar over samples (on stderr).
    plots : bool
        Write the PNG plots.
    fresh : bool
        Discard chunks already in ``out`` (also those of a different sweep).
    replace_other : bool
        Discard a different sweep's chunks (keep this sweep's): for a study's sweep
        folder inside the study's own output folder, whose sweep file changed.
    backend : str
        The batch engine: "cpu" (MuJoCo), "mjx" or "mjx-float32" (MuJoCo's accelerator
        backend, :mod:`twolink.simulation.mjx_engine`; ``pip install "twolink[mjx]"``).
        On MJX every missing chunk runs in this process as one batch (the executor's
        options are unused), and its rows are the CPU engine's to rounding (float64;
        docs/batch.md for float32).

    Returns
    -------
    SweepOutcome

    Raises
    ------
    SweepInterrupted
        On SIGINT or SIGTERM: running tasks are abandoned, finished chunks kept.
    SweepOutputError
        ``out`` holds a different sweep's chunks and ``fresh`` is false.
    ExecutorError, ValueError
        The executor cannot be started or its options are inconsistent.
    """
    return run_sweeps(
        [(plan, out)],
        executor,
        workers,
        scheduler,
        progress,
        plots,
        fresh,
        pool,
        replace_other,
        backend,
    )[0]


def backend_problem(backend: str) -> str | None:
    """Why the sweeps cannot run on ``backend`` (not one of :data:`BACKENDS`, or MJX and
    JAX not installed), in one line; None where they can."""
    if backend not in BACKENDS:
        return f"backend must be one of {list(BACKENDS)}, got {backend!r}"
    if backend != "cpu":
        from twolink.simulation.mjx_engine import available

        if not available():
            return f'backend {backend!r} needs MJX and JAX: pip install "twolink[mjx]"'
    return None


def run_sweeps(
    sweeps: Sequence[tuple[SweepPlan, str | Path]],
    executor: str | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = False,
    plots: bool = True,
    fresh: bool = False,
    pool: SweepExecutor | None = None,
    replace_other: bool = False,
    backend: str = "cpu",
) -> list[SweepOutcome]:
    """:func:`run_sweep` of several sweeps at once, each ``(plan, out)`` into its own
    folder: their chunks share one executor and one window of tasks, so that no worker
    waits for one sweep to end before the next begins (the regime map's two regimes, the
    reproduction's two claims sweeps). Each sweep's folder, chunks, table and outcome are
    those :func:`run_sweep` gives it alone; the options apply to every sweep, the
    executor's (``executor``, ``workers``, ``scheduler``) are the first plan's file's
    where not given."""
    start = time.perf_counter()
    jobs = [_Job(plan, Path(out)) for plan, out in sweeps]
    if not jobs:
        return []
    folders = [job.out.resolve() for job in jobs]
    if len(set(folders)) < len(folders):
        raise ValueError(f"two sweeps into one folder: {[str(f) for f in folders]}")
    if problem := backend_problem(backend):
        raise ValueError(problem)
    if backend != "cpu":  # one batch in this process: the device is the parallelism
        executor, workers, scheduler, pool = "inprocess", 1, None, None
    first = jobs[0].plan
    if executor is None:
        executor = "dask" if scheduler else first.execution.executor
    workers = workers or first.execution.workers
    check_options(executor, workers, scheduler)
    # One sweep at a time per folder: a second one into it stops at once (OutputBusy).
    with ExitStack() as held:
        for job in jobs:
            held.enter_context(owned_output(job.out, "sweep", job.plan.file))
        _compute(jobs, executor, workers, scheduler, progress, fresh, pool, replace_other, backend)
        return [_finish(job, start, plots, progress) for job in jobs]


@dataclass
class _Job:
    """One sweep of :func:`run_sweeps`: its chunks on disk, those to compute, and those
    computed (in parts where workers would idle: ``parts``, ``partial``)."""

    plan: SweepPlan
    out: Path
    frames: dict[int, pd.DataFrame] = field(default_factory=dict)
    reused: tuple[int, ...] = ()
    missing: list[int] = field(default_factory=list)
    computed: list[tuple[int, float]] = field(default_factory=list)  # (chunk, worker s)
    parts: dict[int, int] = field(default_factory=dict)
    partial: dict[int, list[ChunkResult]] = field(default_factory=dict)
    workers: int = 0


def _compute(
    jobs: list[_Job],
    executor: str,
    workers: int | None,
    scheduler: str | None,
    progress: bool,
    fresh: bool,
    pool: SweepExecutor | None,
    replace_other: bool,
    backend: str,
) -> None:
    """Prepare each sweep's folder, find its missing chunks and compute them, every sweep's
    on one executor (``pool``, else one opened here)."""
    from tqdm import tqdm

    for job in jobs:
        plan = job.plan
        _prepare_out(plan, job.out, fresh, replace_other)
        for c in range(plan.n_chunks):
            frame = _valid_chunk(plan, job.out, c)
            if frame is not None:
                job.frames[c] = frame
        job.reused = tuple(sorted(job.frames))
        job.missing = [c for c in range(plan.n_chunks) if c not in job.frames]
    stops = _StopSignals()
    bar = tqdm(
        total=sum(job.plan.samples for job in jobs),
        initial=sum(len(j.plan.chunk_samples(c)) for j in jobs for c in j.reused),
        unit="sample",
        disable=not progress,
        desc=" + ".join(job.plan.name for job in jobs),
        file=sys.stderr,
    )
    try:
        with stops.installed():
            try:
                if any(job.missing for job in jobs):
                    ex = pool or open_executor(executor, workers, scheduler, SWEEP_PRELOAD)
                    for job in jobs:
                        job.workers = ex.workers if job.missing else 0
                    try:
                        _drive(jobs, ex, bar, stops, backend)
                    except BaseException:
                        if pool is None:  # a lent pool is its owner's to stop
                            with interrupts_held():
                                ex.abort()
                        raise
                    if pool is None:
                        ex.shutdown(wait=True)
            except KeyboardInterrupt:
                signum = stops.received[0] if stops.received else signal.SIGINT
                raise SweepInterrupted(
                    signum,
                    sum(len(job.frames) for job in jobs),
                    sum(job.plan.n_chunks for job in jobs),
                    *(job.out for job in jobs),
                ) from None
    finally:
        bar.close()


def _finish(job: _Job, start: float, plots: bool, progress: bool) -> SweepOutcome:
    """Write a computed sweep's table, summary and plots; its outcome."""
    plan, out, frames = job.plan, job.out, job.frames
    results = pd.concat([frames[c] for c in range(plan.n_chunks)], ignore_index=True)
    results.attrs = dict(frames[0].attrs)  # concat keeps attrs only where all agree
    _classify(plan, results)
    table = write_table(out / "results.parquet", results)
    (out / "results.csv").unlink(missing_ok=True)  # the table of a format-1 sweep
    summary = summarize(results)
    write_summary(out, summary)
    wall_s = time.perf_counter() - start
    if plots:
        from twolink.sweep.figures import save_sweep_plots

        if progress:
            print(f"plots: {out / 'plots'}", file=sys.stderr, flush=True)
        save_sweep_plots(out, results)
    return SweepOutcome(
        out=out,
        table=table,
        results=results,
        summary=summary,
        computed=tuple(c for c, _ in job.computed),
        reused=job.reused,
        wall_s=wall_s,
        busy_s=sum(w for _, w in job.computed),
        workers=job.workers,
    )


def _classify(plan: SweepPlan, results: pd.DataFrame) -> None:
    """Add the ``outcome`` column (after ``status``): the runs against the plan's spec."""
    tail = results[[f"joint{j}_tail_error_rad" for j in (1, 2)]]
    growth = results[[f"joint{j}_tail_growth" for j in (1, 2)]]
    overshoot = results[[f"joint{j}_overshoot_pct" for j in (1, 2)]]
    outcome = classify(
        results["status"],
        tail,
        overshoot,
        plan.step,
        plan.success,
        growth,
        plan.finished,
        results["joint1_linear_growth_1_s"],
    )
    results.insert(results.columns.get_loc("status") + 1, "outcome", outcome.astype(str))
    results.attrs["success"] = {**asdict(plan.success), "step_rad": plan.step}


def _whole(
    results: list[ChunkResult], parts: dict[int, int], partial: dict[int, list[ChunkResult]]
) -> list[ChunkResult]:
    """The chunks these results complete: a chunk computed in parts is whole when its last
    part is in (its rows in sample order, its time the parts' sum)."""
    whole = []
    for result in results:
        got = partial.setdefault(result.chunk, [])
        got.append(result)
        if len(got) == parts[result.chunk]:
            got.sort(key=lambda r: r.rows[0][0] if r.rows else -1)
            rows = tuple(row for r in got for row in r.rows)
            whole.append(ChunkResult(result.chunk, rows, sum(r.wall_s for r in got), result.pid))
            del partial[result.chunk]
    return whole


def _drive(
    jobs: list[_Job], ex: SweepExecutor, bar: Any, stops: _StopSignals, backend: str = "cpu"
) -> None:
    """Keep a bounded window of tasks in flight; write each chunk as it finishes. A task is
    one chunk on a pool (the unit of resuming and of spreading over workers); in-process,
    as many chunks as the executor has threads, stepped at once. The sweeps' tasks queue
    one sweep after the other, in one window."""
    missing = sum(len(job.missing) for job in jobs)
    # fewer chunks than workers (of all the sweeps): each chunk in parts, a worker each
    split = ex.name != "inprocess" and backend == "cpu" and missing < ex.workers
    tasks: list[tuple[_Job, tuple[Any, ...]]] = []
    for job in jobs:
        plan = job.plan
        job.parts = dict.fromkeys(job.missing, 1)
        if backend != "cpu":  # every chunk of a sweep in one batch (run_chunks)
            group = len(job.missing)
        else:
            group = ex.workers if ex.name == "inprocess" else 1
        if not split:
            tasks += [
                (job, (run_chunks, plan, job.missing[i : i + group], group, backend))
                for i in range(0, len(job.missing), group)
            ]
            continue
        for c in job.missing:
            samples = plan.chunk_samples(c)
            cuts = np.linspace(samples.start, samples.stop, -(-ex.workers // missing) + 1)
            edges = sorted({int(round(x)) for x in cuts})
            job.parts[c] = len(edges) - 1
            tasks += [(job, (run_chunk_part, plan, c, a, b)) for a, b in pairwise(edges)]
    todo = iter(tasks)
    # Enough queued work that no worker waits on the client, little to cancel on Ctrl-C.
    window = 1 if ex.name == "inprocess" else 2 * ex.workers
    pending: dict[futures.Future, _Job] = {}

    def fill() -> None:
        while len(pending) < window:
            task = next(todo, None)
            if task is None:
                return
            job, call = task
            pending[ex.submit(*call)] = job

    fill()
    while pending:
        with stops.waiting():
            done, _ = futures.wait(
                pending, timeout=STOP_POLL_S, return_when=futures.FIRST_COMPLETED
            )
        # Also one a library dropped on its way; and before the tasks' results: a SIGTERM
        # to the whole process group ends the workers too, and their broken pool is the
        # signal's doing (exit 143, not BrokenProcessPool's traceback).
        stops.check()
        for future in done:
            job = pending.pop(future)
            try:
                results: list[ChunkResult] = future.result()
            except futures.BrokenExecutor:
                raise
            except Exception as exc:  # outside run_chunk's per-sample net: a real bug
                raise SweepTaskError(f"a chunk task failed: {_error_text(exc)}") from exc
            for result in _whole(results, job.parts, job.partial):
                _write_chunk(job, result, ex.name)
                bar.update(len(job.plan.chunk_samples(result.chunk)))
        fill()


def _write_chunk(job: _Job, result: ChunkResult, executor: str) -> None:
    """A whole chunk's file, seal and log line, written together (interrupts held)."""
    plan = job.plan
    with interrupts_held():
        frame = _chunk_frame(plan, result.rows)
        _seal(plan, write_table(_chunk_path(job.out, result.chunk), frame))
        samples = plan.chunk_samples(result.chunk)
        append_line(
            job.out / "computed.log",
            f"{result.chunk} samples={samples.start}-{samples.stop - 1} "
            f"wall_s={result.wall_s:.3f} pid={result.pid} executor={executor}",
        )
    job.frames[result.chunk] = frame
    job.computed.append((result.chunk, result.wall_s))
