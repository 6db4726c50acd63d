"""Rerun recordings: valid files, every sample read back, the arm where MuJoCo puts it, atomic."""

import ast
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest
import rerun as rr
from rerun.chunk import RrdReader

from twolink import tracing
from twolink.arm.params import ArmParams
from twolink.arm.plant import Plant
from twolink.simulation.config import load_scenario
from twolink.simulation.experiment import run_scenario
from twolink.simulation.sim import Trajectory

ROOT = Path(__file__).resolve().parents[1]
SCALARS = {  # entity leaf -> Trajectory attribute it holds
    "angle": "q",
    "reference": "q_ref",
    "error": "e",
    "error_rate": "de",
    "torque": "tau",
}


@pytest.fixture(scope="module")
def run():
    # 1.1 s: past t = 1.025 s, where t * 1e9 falls just short of a whole nanosecond.
    s = load_scenario(ROOT / "runs" / "theta1_step.toml", {"duration": 1.1})
    return s, run_scenario(s)


def rerun_cli(*args: str, home: Path) -> subprocess.CompletedProcess:
    # `python -m rerun` passes the CLI's exit status on (`-m rerun_cli` drops it). Its
    # analytics config goes to a scratch XDG home, not the user's.
    env = {**os.environ, "XDG_CONFIG_HOME": str(home / "config"), "XDG_DATA_HOME": str(home)}
    return subprocess.run(
        [sys.executable, "-m", "rerun", *args], capture_output=True, text=True, env=env
    )


def read_back(path: Path) -> tuple[dict[str, pa.Table], dict[str, pa.Table]]:
    """Temporal rows (sorted by time) and static rows of every entity of the recording."""
    # store() needs the footer: it fails on a file whose sink was never closed.
    chunks = list(RrdReader(path).store().stream())
    temporal: dict[str, list[pa.RecordBatch]] = {}
    static: dict[str, list[pa.RecordBatch]] = {}
    for ch in chunks:
        (static if ch.is_static else temporal).setdefault(ch.entity_path, []).append(
            ch.to_record_batch()
        )
    tables = {}
    for entity, batches in temporal.items():
        table = pa.Table.from_batches(batches)
        tables[entity] = table.sort_by("time")
    return tables, {e: pa.Table.from_batches(b) for e, b in static.items()}


def values(table: pa.Table, column: str, width: int | None = None) -> np.ndarray:
    """All values of one component, nesting dropped: flat, or (-1, width) for vectors."""
    col = table.column(column).combine_chunks()
    while pa.types.is_list(col.type) or pa.types.is_fixed_size_list(col.type):
        col = col.flatten()
    flat = col.to_numpy(zero_copy_only=False)
    return flat if width is None else flat.reshape(-1, width)


def entity(prefix: str, *parts: str) -> str:
    return "/" + "/".join((prefix, *parts))


def test_recording_passes_rerun_verify_and_leaves_no_temp_file(tmp_path, run):
    s, traj = run
    out = tmp_path / "out" / "trace.rrd"
    assert tracing.write_recording(out, [("ctc", traj, s.arm, {})]) == out
    assert os.listdir(out.parent) == ["trace.rrd"]
    ok = rerun_cli("rrd", "verify", str(out), home=tmp_path)
    assert ok.returncode == 0, ok.stderr
    # The check can fail: a truncated copy (no footer) does not verify.
    cut = tmp_path / "cut.rrd"
    cut.write_bytes(out.read_bytes()[: out.stat().st_size // 2])
    assert rerun_cli("rrd", "verify", str(cut), home=tmp_path).returncode != 0


def test_the_file_is_complete_before_it_is_renamed_into_place(tmp_path, run, monkeypatch):
    s, traj = run
    real_replace, renamed = os.replace, []

    def checked_replace(src, dst):
        # store() reads the footer, which rerun writes only when the sink is closed.
        assert len(RrdReader(src).store()) > 0
        renamed.append(Path(dst).name)
        real_replace(src, dst)

    monkeypatch.setattr(os, "replace", checked_replace)
    tracing.write_recording(tmp_path / "trace.rrd", [("ctc", traj, s.arm, {})])
    assert renamed == ["trace.rrd"]


def test_every_series_holds_every_sample_on_the_time_grid(tmp_path, run):
    s, traj = run
    out = tmp_path / "trace.rrd"
    tracing.write_recording(out, [("ctc", traj, s.arm, {"name": s.name})])
    temporal, static = read_back(out)
    n = len(traj.t)
    expected_ns = np.round(traj.t * 1e9).astype(np.int64)
    for j in range(2):
        for leaf, attr in SCALARS.items():
            table = temporal[entity("ctc", f"joint{j + 1}", leaf)]
            assert table.num_rows == n
            times = table.column("time").combine_chunks().cast(pa.int64()).to_numpy()
            np.testing.assert_array_equal(times, expected_ns)
            np.testing.assert_array_equal(
                values(table, "Scalars:scalars"), getattr(traj, attr)[:, j]
            )
        state = temporal[entity("ctc", "phase", f"joint{j + 1}", "state")]
        plane = np.stack([traj.e[:, j], traj.de[:, j]], axis=1).astype(np.float32)
        np.testing.assert_array_equal(values(state, "Points2D:positions", 2), plane)
        path = static[entity("ctc", "phase", f"joint{j + 1}", "path")]
        np.testing.assert_array_equal(values(path, "LineStrips2D:strips", 2), plane)
    # A rigid arm has no rotor angles; the steady step does not move the arm's base.
    assert entity("ctc", "joint1", "motor_angle") not in temporal
    assert values(static[entity("ctc", "status")], "TextLog:text").tolist() == [f"{s.name}: ok"]
    base = values(static[entity("ctc", "arm", "base")], "Points3D:positions", 3)
    np.testing.assert_array_equal(base, [[0.0, 0.0, 0.0]])


def test_arm_points_match_mujoco_kinematics():
    arm = ArmParams(m1=1.2, m2=0.7, l1=0.9, l2=0.6)
    q = np.random.default_rng(0).uniform(-np.pi, np.pi, size=(20, 2))
    plant = Plant.build(arm)
    pts = tracing.arm_points(arm, q)
    for k in range(len(q)):
        plant.set_state(q[k], np.zeros(2))
        np.testing.assert_allclose(pts[k, 0], 0.0, atol=0.0)
        np.testing.assert_allclose(pts[k, 1], plant.data.body("link2").xpos, atol=1e-12)
        np.testing.assert_allclose(pts[k, 2], plant.data.site("tip").xpos, atol=1e-12)


def test_recorded_arm_follows_the_run(tmp_path, run):
    s, traj = run
    out = tmp_path / "trace.rrd"
    tracing.write_recording(out, [("ctc", traj, s.arm, {})])
    temporal, _ = read_back(out)
    expected = tracing.arm_points(s.arm, traj.q).astype(np.float32)
    links = temporal[entity("ctc", "arm", "links")]
    assert links.num_rows == len(traj.t)
    np.testing.assert_array_equal(
        values(links, "LineStrips3D:strips", 3).reshape(-1, 3, 3), expected
    )
    joints = temporal[entity("ctc", "arm", "joints")]
    assert joints.num_rows == len(traj.t)
    np.testing.assert_array_equal(
        values(joints, "Points3D:positions", 3).reshape(-1, 3, 3), expected
    )
    # The step moves joint 1 by 1 rad: the tip ends up high in the (x, z) plane.
    assert expected[-1, 2, 2] > 1.0 and np.all(expected[:, :, 1] == 0.0)


def test_centres_fired_rules_and_phase_scale(tmp_path, run):
    s, traj = run
    n = len(traj.t)
    centres = np.array([[-0.5, 0.0], [0.0, 0.0], [0.5, 0.25]])
    rules = np.array([[f"R{(k // 7) % 5}", f"S{(k // 11) % 3}"] for k in range(n)])
    extras = {
        "centres": centres,
        "fired_rules": rules,
        "phase_scale": (2.0, 0.5),
        "centre_labels": ["NB", "ZE", "PB"],
    }
    out = tmp_path / "trace.rrd"
    tracing.write_recording(out, [("fcm", traj, s.arm, extras)])
    temporal, static = read_back(out)
    c = static[entity("fcm", "phase", "centres")]
    np.testing.assert_array_equal(values(c, "Points2D:positions", 2), centres)
    assert values(c, "Points2D:labels").tolist() == ["NB", "ZE", "PB"]
    for j in range(2):
        state = temporal[entity("fcm", "phase", f"joint{j + 1}", "state")]
        assert values(state, "Points2D:labels").tolist() == rules[:, j].tolist()
        plane = np.stack([2.0 * traj.e[:, j], 0.5 * traj.de[:, j]], axis=1)
        np.testing.assert_array_equal(
            values(state, "Points2D:positions", 2), plane.astype(np.float32)
        )
        # the log: the rule at each change, named by joint (a readable sequence over time)
        log = temporal[entity("fcm", "phase", f"joint{j + 1}", "fired_rule")]
        block = (7, 11)[j]
        starts = np.arange(0, n, block)
        assert log.num_rows == len(starts)
        sub = "₁₂"[j]
        assert values(log, "TextLog:text").tolist() == [f"θ{sub}: {rules[k, j]}" for k in starts]
        at = log.column("time").to_numpy().astype("timedelta64[ns]").astype(np.int64) / 1e9
        np.testing.assert_allclose(at, traj.t[starts], atol=1e-9)


def test_per_joint_centres_go_under_each_joint(tmp_path, run):
    s, traj = run
    centres = np.array([[[0.0, 0.0], [1.0, 1.0]], [[0.0, 0.5], [2.0, 2.0]]])
    out = tmp_path / "trace.rrd"
    tracing.write_recording(out, [("fcm", traj, s.arm, {"centres": centres})])
    _, static = read_back(out)
    for j in range(2):
        c = static[entity("fcm", "phase", f"joint{j + 1}", "centres")]
        np.testing.assert_array_equal(values(c, "Points2D:positions", 2), centres[j])
        assert values(c, "Points2D:labels").tolist() == ["c1", "c2"]
    assert entity("fcm", "phase", "centres") not in static


def test_decimation_keeps_every_kth_sample_and_the_last(tmp_path, run):
    np.testing.assert_array_equal(tracing.sample_indices(10, 3), [0, 3, 6, 9])
    np.testing.assert_array_equal(tracing.sample_indices(11, 3), [0, 3, 6, 9, 10])
    np.testing.assert_array_equal(tracing.sample_indices(4, 1), [0, 1, 2, 3])
    for bad in (0, -1, 1.5, True):
        with pytest.raises(ValueError, match="every"):
            tracing.sample_indices(10, bad)
    s, traj = run
    out = tmp_path / "trace.rrd"
    tracing.write_recording(out, [("ctc", traj, s.arm, {})], every=7)
    temporal, _ = read_back(out)
    idx = np.r_[np.arange(0, len(traj.t), 7), len(traj.t) - 1]  # 1101 samples: 0..1099, 1100
    for name in ("joint2/torque", "phase/joint1/state", "arm/links"):
        table = temporal[entity("ctc", *name.split("/"))]
        times = table.column("time").combine_chunks().cast(pa.int64()).to_numpy()
        np.testing.assert_array_equal(times, np.round(traj.t[idx] * 1e9).astype(np.int64))
    np.testing.assert_array_equal(
        values(temporal[entity("ctc", "joint1", "angle")], "Scalars:scalars"), traj.q[idx, 0]
    )


def test_several_runs_share_a_file_and_the_layout_selects_their_entities(tmp_path, run):
    s, traj = run
    flexible = replace(traj, motor_q=traj.q + 0.01)
    diverged = replace(traj, status="diverged", message="angle beyond 100 rad at t=0.5")
    named = tracing.entity_prefix("θ1 step, CTC")
    runs = [
        (named, traj, s.arm, {}),
        ("paper/flexible", flexible, s.arm, {"name": "flexible"}),
        ("paper/diverged", diverged, s.arm, {}),
    ]
    out = tmp_path / "all.rrd"
    tracing.write_recording(out, runs)
    temporal, static = read_back(out)
    n = len(traj.t)
    for prefix in (named, "paper/flexible", "paper/diverged"):
        assert temporal[entity(prefix, "joint2", "angle")].num_rows == n
    motor = temporal[entity("paper/flexible", "joint1", "motor_angle")]
    np.testing.assert_array_equal(values(motor, "Scalars:scalars"), flexible.motor_q[:, 0])
    status = static[entity("paper/diverged", "status")]
    assert values(status, "TextLog:text").tolist() == [f"diverged: {diverged.message}"]
    assert values(status, "TextLog:level").tolist() == ["WARN"]

    # The blueprint travels in the file; every view selects entities that were logged,
    # and together the views show every time series.
    reader = RrdReader(out)
    (bp,) = reader.blueprints()
    (recording,) = reader.recordings()
    assert recording.recording_id == tracing.recording_id("twolink", runs)
    queries, origins = [], []
    for ch in reader.stream(store=bp):
        batch = ch.to_record_batch()
        if "ViewContents:query" in batch.schema.names:
            queries += batch.column("ViewContents:query").to_pylist()
        if "ViewBlueprint:space_origin" in batch.schema.names:
            origins += batch.column("ViewBlueprint:space_origin").to_pylist()
    shown = set()
    for query in queries:
        if query == ["$origin/**"]:
            continue
        selected = {ch.entity_path for ch in RrdReader(out).stream().filter(content=query)}
        assert selected, query
        shown |= selected
    scalar_entities = {e for e in temporal if e.rsplit("/", 1)[-1] in {*SCALARS, "motor_angle"}}
    assert scalar_entities <= shown
    spatial = {o for (o,) in origins if o != "/"}
    assert spatial == {
        f"{p}/{leaf}"
        for p in (named, "paper/flexible", "paper/diverged")
        for leaf in ("phase", "arm")
    }


def test_a_single_run_may_sit_at_the_root(tmp_path, run):
    s, traj = run
    out = tmp_path / "trace.rrd"
    tracing.write_recording(out, [("", traj, s.arm, {})])
    temporal, static = read_back(out)
    assert temporal["/joint1/angle"].num_rows == len(traj.t)
    assert "/arm/base" in static


def test_log_run_checks_its_inputs_before_sending_anything(run):
    s, traj = run
    rec = rr.RecordingStream("twolink-test", recording_id="check-inputs")
    memory = rec.memory_recording()
    before = memory.num_msgs()
    bad = [
        {"centres": np.zeros((2, 2)), "centre_labels": ["only one"]},
        {"fired_rules": ["R1"] * (len(traj.t) - 1)},
        {"phase_scale": (1.0, float("nan"))},
        {"every": 0},
    ]
    for kwargs in bad:
        with pytest.raises(ValueError):
            tracing.log_run(rec, traj, s.arm, "run", **kwargs)
    with pytest.raises(ValueError, match="no samples"):
        tracing.log_run(rec, replace(traj, t=traj.t[:0]), s.arm, "run")
    assert memory.num_msgs() == before
    tracing.log_run(rec, traj, s.arm, "run")
    assert memory.num_msgs() > before


def test_identical_runs_give_the_same_recording(tmp_path, run):
    s, traj = run
    a, b, c = tmp_path / "a.rrd", tmp_path / "b.rrd", tmp_path / "c.rrd"
    tracing.write_recording(a, [("ctc", traj, s.arm, {})])
    tracing.write_recording(b, [("ctc", traj, s.arm, {})])
    other = replace(traj, tau=traj.tau * 1.001)
    tracing.write_recording(c, [("ctc", other, s.arm, {})])
    ids = [RrdReader(p).recordings()[0].recording_id for p in (a, b, c)]
    assert ids[0] == ids[1] != ids[2]
    assert rerun_cli("rrd", "compare", str(a), str(b), home=tmp_path).returncode == 0
    assert rerun_cli("rrd", "compare", str(a), str(c), home=tmp_path).returncode != 0


@pytest.mark.parametrize(
    "bad_extras",
    [{"centres": np.zeros((3, 3))}, {"no_such_option": 1}, {"fired_rules": ["R1"] * 5}],
)
def test_a_failing_write_keeps_the_old_file_and_leaves_no_temp(tmp_path, run, bad_extras):
    s, traj = run
    out = tmp_path / "trace.rrd"
    out.write_bytes(b"previous recording")
    # The good run is logged into the temporary file before the bad one fails.
    runs = [("good", traj, s.arm, {}), ("bad", traj, s.arm, bad_extras)]
    with pytest.raises((ValueError, TypeError)):
        tracing.write_recording(out, runs)
    assert os.listdir(tmp_path) == ["trace.rrd"]
    assert out.read_bytes() == b"previous recording"
    fresh = tmp_path / "new" / "trace.rrd"
    with pytest.raises((ValueError, TypeError)):
        tracing.write_recording(fresh, runs)
    assert os.listdir(fresh.parent) == []


def test_disabled_rerun_raises_instead_of_writing_an_empty_file(tmp_path, run, monkeypatch):
    s, traj = run
    monkeypatch.setenv("RERUN", "off")
    with pytest.raises(RuntimeError, match="disabled"):
        tracing.write_recording(tmp_path / "trace.rrd", [("ctc", traj, s.arm, {})])
    assert os.listdir(tmp_path) == []


def test_bad_prefixes_are_refused(tmp_path, run):
    s, traj = run
    for pair in (("a", "a"), ("a", "a/b"), ("", "b")):
        with pytest.raises(ValueError, match="prefixes"):
            tracing.write_recording(tmp_path / "x.rrd", [(p, traj, s.arm, {}) for p in pair])
    with pytest.raises(ValueError, match="non-empty"):
        tracing.entity_prefix("run", "")
    assert not (tmp_path / "x.rrd").exists()


def test_only_the_tracing_package_imports_rerun():
    importers = []
    for path in sorted([*(ROOT / "twolink").rglob("*.py"), *(ROOT / "controllers").rglob("*.py")]):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            else:
                continue
            if any(n == "rerun" or n.startswith("rerun.") for n in names):
                importers.append(path.relative_to(ROOT).parent.as_posix())
    assert set(importers) == {"twolink/tracing"}


def overview_views(path: Path) -> dict[str, dict[str, list]]:
    """The blueprint's views by name: their contents and axis settings."""
    reader = RrdReader(path)
    (bp,) = reader.blueprints()
    parts: dict[str, dict[str, list]] = {}
    for ch in reader.stream(store=bp):
        if not ch.entity_path.startswith("/view/"):
            continue
        view = ch.entity_path.split("/")[2]
        batch = ch.to_record_batch()
        for name in batch.schema.names:
            if name.split(":")[0] in {"ViewBlueprint", "ViewContents", "ScalarAxis", "TimeAxis"}:
                row = batch.column(name).to_pylist()[-1]  # a batch: one value, or the query
                parts.setdefault(view, {})[name] = row if name.endswith(":query") else row[0]
    return {
        v["ViewBlueprint:display_name"]: v
        for v in parts.values()
        if "ViewBlueprint:display_name" in v
    }


def srgb(packed: int) -> tuple[int, int, int]:
    """(r, g, b) of a colour as rerun stores it (0xRRGGBBAA)."""
    return (packed >> 24) & 255, (packed >> 16) & 255, (packed >> 8) & 255


OVERVIEW_RUNS = (  # prefix, controller, name
    ("rigid/table2/CTC", "CTC", None),
    ("rigid/table2/FCM-CTC", "FCM-CTC", None),
    ("rigid/table3/CTC", "CTC", "θ1 ramp"),
    ("flexible/table2/FCM-CTC", "FCM-CTC", None),
    ("flexible/table2/CTC", "CTC", None),
)


@pytest.fixture(scope="module")
def overview(tmp_path_factory, run):
    """A recording of five runs of two controllers, three of them on one reference."""
    s, traj = run
    trajs = [replace(traj, q=traj.q * (1 - 0.05 * k)) for k in range(len(OVERVIEW_RUNS))]
    trajs[2] = replace(trajs[2], q_ref=traj.q_ref * 0.5 + 0.1)  # its own reference
    trajs[3] = replace(trajs[3], q=traj.q * [[1.0, -3.0]])  # θ2 far below the others
    runs = [
        (prefix, t, s.arm, {"name": name} if name else {})
        for (prefix, _, name), t in zip(OVERVIEW_RUNS, trajs, strict=True)
    ]
    out = tmp_path_factory.mktemp("overview") / "all.rrd"
    tracing.write_recording(out, runs, groups=[g for _, g, _ in OVERVIEW_RUNS])
    return out, runs


def test_the_overview_names_each_run_and_colours_it_by_controller(overview):
    out, runs = overview
    temporal, static = read_back(out)
    for j in (1, 2):
        style = {}
        for (prefix, controller, name), (_, traj, _, _) in zip(OVERVIEW_RUNS, runs, strict=True):
            path = entity(tracing.OVERVIEW, f"joint{j}", prefix)
            # each run its own entity, holding that run's angles, named after the run
            np.testing.assert_array_equal(
                values(temporal[path], "Scalars:scalars"), traj.q[:, j - 1]
            )
            (label,) = values(static[path], "SeriesLines:names").tolist()
            (colour,) = values(static[path], "SeriesLines:colors").tolist()
            (width,) = values(static[path], "SeriesLines:widths").tolist()
            style[prefix] = (controller, srgb(colour), width)
            # the name says the controller: the prefix ends with it, or it is added
            assert label == (prefix if name is None else f"{name} ({controller})")
        # one colour family per controller (CTC the reds, FCM-CTC the greens, as in the
        # report's figures), and within it a shade of its own per run
        ctc = [c for g, c, _ in style.values() if g == "CTC"]
        fcm = [c for g, c, _ in style.values() if g == "FCM-CTC"]
        assert all(r > g and r > b for r, g, b in ctc), ctc
        assert all(g > r and g > b for r, g, b in fcm), fcm
        assert len(set(ctc)) == 3 and len(set(fcm)) == 2
        # the references: grey, thinner than the runs, each distinct one once
        refs = sorted(
            e
            for e in static
            if e.startswith(f"/{tracing.OVERVIEW}/joint{j}/") and e.endswith("/reference")
        )
        assert refs == [
            entity(tracing.OVERVIEW, f"joint{j}", p, "reference")
            for p in ("rigid/table2/CTC", "rigid/table3/CTC")
        ]
        (label,) = values(static[refs[0]], "SeriesLines:names").tolist()
        assert label == "reference of rigid/table2/CTC +3"  # three more runs share it
        for ref in refs:
            (colour,) = values(static[ref], "SeriesLines:colors").tolist()
            (width,) = values(static[ref], "SeriesLines:widths").tolist()
            assert srgb(colour) == tracing.REFERENCE_COLOR
            assert width < min(w for *_, w in style.values())
    with pytest.raises(ValueError, match="2 groups for 5 runs"):
        tracing.write_recording(out.parent / "x.rrd", runs, groups=["CTC", "FCM-CTC"])
    empty = ("empty", replace(runs[0][1], t=runs[0][1].t[:0]), runs[0][2], {})
    with pytest.raises(ValueError, match="no samples"):  # checked before the overview
        tracing.write_recording(out.parent / "x.rrd", [runs[0], empty])
    assert not (out.parent / "x.rrd").exists()


def test_the_overview_layout_lists_every_run_and_fits_every_curve(overview):
    out, runs = overview
    views = overview_views(out)
    data = tracing.read_recording(out)
    t_end = max(float(r[1].t[-1]) for r in runs)
    for j in (1, 2):
        (name,) = [n for n in views if n.startswith(f"θ{'₁₂'[j - 1]} of every run")]
        view = views[name]
        # each run's entities by name, so every run is in the plot and nothing else is
        listed = set(view["ViewContents:query"])
        for prefix, *_ in OVERVIEW_RUNS:
            assert f"{tracing.OVERVIEW}/joint{j}/{prefix}" in listed
            assert f"{tracing.OVERVIEW}/joint{j}/{prefix}/reference" in listed
        assert len(listed) == 2 * len(OVERVIEW_RUNS)
        # the y axis spans every curve of the plot, references included
        curves = data[[c for c in data if c.startswith(f"{tracing.OVERVIEW}/joint{j}/")]]
        assert curves.shape[1] == len(OVERVIEW_RUNS) + 2
        low, high = view["ScalarAxis:range"]
        assert low < curves.min().min() and curves.max().max() < high
        assert high - low < 1.2 * (curves.max().max() - curves.min().min())  # and fits them
        # the time axis goes past the runs' end: the legend (top right) covers no curve
        assert view["TimeAxis:view_range"]["start"] == 0
        assert view["TimeAxis:view_range"]["end"] >= 1.3 * t_end * 1e9
    # the viewer opens on the overview, on the runs' timeline
    reader = RrdReader(out)
    (bp,) = reader.blueprints()
    timelines = []
    for ch in reader.stream(store=bp):
        batch = ch.to_record_batch()
        if "TimePanelBlueprint:timeline" in batch.schema.names:
            timelines += batch.column("TimePanelBlueprint:timeline").to_pylist()
    assert timelines == [[tracing.TIMELINE]]


def test_overview_colours_give_each_group_a_family_and_each_run_a_shade():
    groups = ["CTC", "FCM-CTC", "CTC", "FCM-CTC", "CTC", "PID"]
    colours = tracing.overview_colors(groups)
    # the runs of a group go from the dark end of its family to the light end, in order
    dark, light = tracing.GROUP_FAMILIES[0]
    assert colours[0] == dark and colours[4] == light
    assert all(min(a, b) <= m <= max(a, b) for a, m, b in zip(dark, colours[2], light, strict=True))
    assert colours[1] == tracing.GROUP_FAMILIES[1][0] and colours[3] == tracing.GROUP_FAMILIES[1][1]
    assert colours[5] == tracing.GROUP_FAMILIES[2][0]  # a third group, a third family
    assert len(set(colours)) == len(groups)
    # the same groups in the same order give the same colours (a pure function)
    assert tracing.overview_colors(groups) == colours


def test_the_docs_recording_reader_snippet_runs_as_written(tmp_path):
    import re

    doc = (ROOT / "docs" / "tracing.md").read_text()
    section = doc.split("## Reading one back", 1)[1]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    made = subprocess.run(
        [sys.executable, "-m", "twolink", "run", str(ROOT / "runs/paper/theta1_step.toml")],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert made.returncode == 0, made.stderr
    assert "at 200 Hz" in made.stdout and "rerun --serve-web" in made.stdout
    result = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 0, result.stderr
    traj = Trajectory.load(tmp_path / "results" / "theta1_step" / "trajectory.npz")
    idx = tracing.sample_indices(len(traj.t), 5)
    assert f"{len(idx)} samples from 0.0 to 10.0 s; final θ1 {traj.q[-1, 0]:.4f}" in result.stdout


def test_read_recording_returns_every_series_at_the_kept_samples(tmp_path, run):
    s, traj = run
    out = tmp_path / "t.rrd"
    tracing.write_recording(out, [("ctc", traj, s.arm, {})], every=3)
    df = tracing.read_recording(out)
    idx = tracing.sample_indices(len(traj.t), 3)
    np.testing.assert_allclose(df.index.to_numpy(), traj.t[idx], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(df["ctc/joint2_torque_Nm"].to_numpy(), traj.tau[idx, 1])
    np.testing.assert_array_equal(df["ctc/joint1_error_rad"].to_numpy(), traj.e[idx, 0])
    # one naming: a one-run recording's columns are the trajectory's DataFrame columns
    tracing.write_recording(tmp_path / "one.rrd", [("", traj, s.arm, {})], every=3)
    one = tracing.read_recording(tmp_path / "one.rrd")
    frame = traj.to_dataframe().iloc[idx]
    shared = [c for c in frame.columns if c in one.columns]
    assert {"joint1_angle_rad", "joint1_reference_rad", "joint2_torque_Nm"} <= set(shared)
    assert one.index.name == frame.index.name == "time_s"
    for column in shared:
        np.testing.assert_allclose(one[column].to_numpy(), frame[column].to_numpy(), atol=1e-12)


def test_every_controller_has_a_colour_and_a_dash_no_other_shares():
    """One style table (twolink.simulation.vocabulary): no two controllers share a colour
    (a recording has no dashes to tell them apart) nor a dash; every kind's label has a
    style; names the table does not know get colours nobody else in the figure has. The
    issue's case: PD-G and FCM-CTC-continuous were both blue and dashed."""
    from twolink.simulation.vocabulary import (
        CONTROLLER_LABELS,
        CONTROLLER_STYLES,
        STYLE_ALIASES,
        controller_styles,
    )

    colours = [c for c, _ in CONTROLLER_STYLES.values()]
    dashes = [repr(d) for _, d in CONTROLLER_STYLES.values()]
    assert len(set(colours)) == len(colours)
    assert len(set(dashes)) == len(dashes)
    for label in CONTROLLER_LABELS.values():
        assert STYLE_ALIASES.get(label, label) in CONTROLLER_STYLES, label
    assert set(STYLE_ALIASES.values()) <= set(CONTROLLER_STYLES)
    names = ["CTC", "new law", "FCM-CTC", "another", "PD+G"]
    styles = controller_styles(names)
    assert len({c for c, _ in styles.values()}) == len(names)
    assert styles["PD+G"] == CONTROLLER_STYLES["PD-G"]
    assert CONTROLLER_STYLES["PD-G"] != CONTROLLER_STYLES["FCM-CTC-continuous"]


def test_the_response_figure_and_the_recording_draw_each_controller_in_its_style(tmp_path):
    """The figure's lines take the table's colour and dash (FCM-CTC dashed over CTC), and
    the combined recording the same colours: one table, in one place."""
    from matplotlib.colors import to_rgb

    from twolink.figures.plots import response_figure
    from twolink.simulation.vocabulary import CONTROLLER_STYLES
    from twolink.tracing.comparison import ExperimentRuns, read_comparison, write_comparison

    t = np.arange(2001) * 1e-3
    ref = np.stack([np.minimum(t, 1.0), np.zeros_like(t)], axis=1)
    zeros = np.zeros_like(ref)
    names = ["FCM-CTC", "CTC", "FCM-CTC-continuous", "PD-G", "CTC-I"]
    trajs = {}
    for k, name in enumerate(names):
        q = ref * (1 + 0.01 * k)
        trajs[name] = Trajectory(t, q, zeros, ref, zeros, zeros, zeros, np.empty((0, 2)))
    fig = response_figure(trajs, 1, "styles")
    lines = {ln.get_label(): ln for ln in fig.axes[0].get_lines()}
    drawn = set()
    for name in names:
        colour, dash = CONTROLLER_STYLES[name]
        line = lines[name]
        assert np.allclose(to_rgb(line.get_color()), to_rgb(colour)), name
        if isinstance(dash, str):
            assert line.get_linestyle() == dash, name
        drawn.add(to_rgb(line.get_color()))
    assert len(drawn) == len(names)
    assert lines["FCM-CTC"].get_linestyle() == "--" and lines["CTC"].get_linestyle() == "-"
    import matplotlib.pyplot as plt

    plt.close(fig)
    path = tmp_path / "r.rrd"
    write_comparison(path, [ExperimentRuns("raw/table2", "raw: table2", 1, trajs)])
    assert "raw/table2/difference/FCM-CTC − CTC" in read_comparison(path)
    from rerun.chunk import RrdReader

    for ch in RrdReader(path).store().stream():
        if ch.is_static and ch.entity_path.strip("/") == "raw/table2/angle":
            batch = ch.to_record_batch()
            labels = batch.column("SeriesLines:names")[0].as_py()
            packed = batch.column("SeriesLines:colors")[0].as_py()
            for name, c in zip(labels, packed, strict=True):
                if name in CONTROLLER_STYLES:
                    want = tuple(round(255 * v) for v in to_rgb(CONTROLLER_STYLES[name][0]))
                    assert ((c >> 24) & 255, (c >> 16) & 255, (c >> 8) & 255) == want, name


@pytest.mark.parametrize(
    ("scale", "names"),
    [
        ((1.0, 1.0), ("e [rad] →", "ė [rad/s] ↓")),
        ((2.0, 0.5), ("ke·e →", "kde·ė ↓")),
    ],
)
def test_the_phase_plane_has_axes_with_names_units_and_round_ticks(tmp_path, run, scale, names):
    """The axes cross at the origin and span every path and centre; each is named with
    its unit at its positive end (the viewer's y axis points down: ė ↓); ticks at round
    values, labelled, within the axes."""
    s, traj = run
    centres = np.array([[-0.5, 0.0], [0.3, 0.25]])
    out = tmp_path / "trace.rrd"
    extras = {"centres": centres, "phase_scale": scale, "centre_labels": ["NB,Z→PB", "Z,Z→Z"]}
    tracing.write_recording(out, [("fcm", traj, s.arm, extras)])
    _, static = read_back(out)
    strips = values(static[entity("fcm", "phase", "axes")], "LineStrips2D:strips", 2)
    (x0, y0), (x1, _), (_, ya), (_, yb) = strips
    ke, kde = scale
    planes = np.concatenate([np.stack([ke * traj.e[:, j], kde * traj.de[:, j]], 1) for j in (0, 1)])
    everything = np.concatenate([planes, centres])
    assert y0 == 0 and x0 <= everything[:, 0].min() and x1 >= everything[:, 0].max()
    assert ya <= everything[:, 1].min() and yb >= everything[:, 1].max()
    labels = values(static[entity("fcm", "phase", "axes", "names")], "Points2D:labels").tolist()
    assert labels == list(names)
    scale_note = entity("fcm", "phase", "axes", "scale")
    if scale == (1.0, 1.0):
        assert scale_note not in static
    else:  # a normalised plane says how, with the units of e and ė
        (note,) = values(static[scale_note], "Points2D:labels").tolist()
        assert note == "normalised: ke = 2/rad, kde = 0.5 s/rad"
    ticks = static[entity("fcm", "phase", "axes", "ticks")]
    pos = values(ticks, "Points2D:positions", 2)
    text = values(ticks, "Points2D:labels").tolist()
    assert len(text) >= 4 and all(float(t) != 0 for t in text)
    along = np.where(pos[:, 1] == 0, pos[:, 0], pos[:, 1])
    np.testing.assert_allclose(along, [float(t) for t in text], rtol=1e-6)
    centre = static[entity("fcm", "phase", "centres")]
    assert values(centre, "Points2D:labels").tolist() == ["NB,Z→PB", "Z,Z→Z"]


def test_nice_ticks_are_round_and_cover_the_span():
    from twolink.tracing.runs import nice_ticks

    np.testing.assert_allclose(nice_ticks(-0.13, 1.07), [0, 0.2, 0.4, 0.6, 0.8, 1.0])
    np.testing.assert_allclose(nice_ticks(-3.2, 7.9), [-2, 0, 2, 4, 6])
    assert nice_ticks(1.0, 1.0).tolist() == [1.0]


def test_the_reproduction_names_each_centre_by_the_rule_the_design_kept(tmp_path):
    """The plan gives the fuzzy runs the centres and their kept rules' names (not c1-c5),
    and the run's recording labels the centres with them."""
    from types import SimpleNamespace

    from twolink.controllers.fuzzy.engine import rule_label
    from twolink.studies.reproduction.manifest import load_manifest
    from twolink.studies.reproduction.reproduce import centre_rules, plan

    engine = SimpleNamespace(rules=[SimpleNamespace(e="NB", de="Z", u="PB"),
                                    SimpleNamespace(e="Z", de="PS", u="NS")])  # fmt: skip
    result = SimpleNamespace(engine=engine, kept=np.array([1, 0, 1]))
    assert centre_rules(result) == ["Z,PS→NS", "NB,Z→PB", "Z,PS→NS"]
    assert rule_label(engine.rules[0]) == "NB,Z→PB"
    manifest = load_manifest(ROOT / "runs" / "paper" / "reproduce.toml")
    centres = [(0.1, 0.2), (0.3, 0.4), (-0.2, 0.0)]
    specs = plan(manifest, None, centres, None, centre_rules(result))
    for sp in specs:
        fuzzy = sp.overrides["controller"].get("kind") in ("fcm_ctc", "fuzzy_pd")
        assert sp.centre_labels == (tuple(centre_rules(result)) if fuzzy else ())
        assert len(sp.centres) == (3 if fuzzy else 0)


def test_the_compare_figure_and_the_sweep_figures_use_the_style_table():
    """twolink compare's overlay and the sweep figures colour a controller as every other
    figure does (they had their own: green and red for any pair, C0, C1, ...)."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import to_rgb

    from twolink.figures.plots import comparison_figure
    from twolink.simulation.vocabulary import CONTROLLER_STYLES

    t = np.linspace(0, 1, 11)
    q = np.zeros((3, 11, 2))
    fig = comparison_figure(t, q, q + 0.1, np.zeros((11, 2)), (1,), ("CTC-I", "PD-G"), "x")
    medians = {ln.get_label().split(":")[0]: ln for ln in fig.axes[0].get_lines()}
    for name in ("CTC-I", "PD-G"):
        assert np.allclose(to_rgb(medians[name].get_color()), to_rgb(CONTROLLER_STYLES[name][0]))
    assert medians["PD-G"].get_linestyle() == ":"
    plt.close(fig)


def test_the_overview_gives_a_controller_its_hue_whatever_its_order():
    """A controller of the style table keeps its hue in the overview (CTC reds, FCM-CTC
    greens, PD-G blues, ..., FCM-CTC-continuous a ramp through its teal) in whatever order
    the runs come; a group the table does not know takes a family no group here claims."""
    from twolink.simulation.vocabulary import CONTROLLER_STYLES, rgb

    groups = ["fuzzy-PD", "PD+G", "CTC", "FCM-CTC-continuous", "mystery", "CTC"]
    colours = tracing.overview_colors(groups)
    families = tracing.GROUP_FAMILIES
    assert colours[0] == families[5][0]  # fuzzy-PD: pinks, though first
    assert colours[1] == families[2][0]  # PD+G is PD-G: blues
    assert colours[2] == families[0][0] and colours[5] == families[0][1]  # CTC: reds
    teal = np.array(rgb(CONTROLLER_STYLES["FCM-CTC-continuous"][0]))
    assert colours[3] == tuple(int(v) for v in np.round(0.6 * teal))
    assert colours[4] == families[1][0]  # the first family nobody here claims
    assert len(set(colours)) == len(colours)
