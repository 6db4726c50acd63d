"""The reproduction's combined recording (twolink.tracing.comparison): a tab per
experiment with three views (angles, the pair's errors, the pair's difference), one entity
per view holding every controller's curve, light for the viewer; the tabs ordered so that
it opens where the pair differ most."""

from collections import Counter
from pathlib import Path

import numpy as np
import pandas.testing as pd_testing
import pytest
from rerun.chunk import RrdReader

from twolink.simulation.sim import Trajectory
from twolink.simulation.vocabulary import CONTROLLER_STYLES, rgb
from twolink.tracing import read_recording
from twolink.tracing.comparison import (
    ExperimentRuns,
    order_experiments,
    pair_difference,
    read_comparison,
    write_comparison,
)
from twolink.tracing.runs import REFERENCE_COLOR, sample_indices

N = 3001  # 3 s at 1 kHz
SHORT = 1500  # CTC-I stops early (a run cut short)


def trajectory(n: int, joint: int, q: np.ndarray, tau: np.ndarray) -> Trajectory:
    t = np.arange(n) * 1e-3
    ref = np.zeros((n, 2))
    ref[:, joint - 1] = np.minimum(t / 1.5, 1.0)
    angles = ref.copy()
    angles[:, joint - 1] = q[:n]
    torques = np.zeros((n, 2))
    torques[:, joint - 1] = tau[:n]
    zeros = np.zeros((n, 2))
    return Trajectory(t, angles, zeros, ref, zeros, zeros, torques, np.empty((0, 2)))


def experiment(prefix: str, joint: int, names: dict[str, float]) -> ExperimentRuns:
    """Runs whose angle is the reference times ``1 + offset`` (a far baseline swings)."""
    t = np.arange(N) * 1e-3
    ref = np.minimum(t / 1.5, 1.0)
    runs = {}
    for k, (name, offset) in enumerate(names.items()):
        q = 3 * np.sin(5 * t) if name == "fuzzy-PD" else ref * (1 + offset)
        n = SHORT if name == "CTC-I" else N
        runs[name] = trajectory(n, joint, q, np.cos(t) * (k + 1))
    return ExperimentRuns(prefix, prefix.replace("/", ": "), joint, runs)


@pytest.fixture(scope="module")
def written(tmp_path_factory) -> tuple[Path, list[ExperimentRuns]]:
    experiments = [
        experiment(
            "rigid/table2",
            1,
            {
                "CTC": 0.001,
                "CTC-I": 0.01,
                "FCM-CTC": 0.0,
                "FCM-CTC-continuous": 0.002,
                "PD-G": 0.03,
                "fuzzy-PD": 0.0,
            },
        ),
        experiment("flexible/table3", 2, {"CTC": 0.001, "FCM-CTC": 0.0}),
    ]
    path = tmp_path_factory.mktemp("comparison") / "reproduction.rrd"
    write_comparison(path, experiments)
    return path, experiments


def recording_chunks(path: Path) -> list:
    return [ch for ch in RrdReader(path).store().stream() if ch.entity_path != "/__properties"]


def legend(path: Path) -> dict[str, tuple[list[str], list[tuple[int, int, int]]]]:
    """Each entity's curve names and colours, in the order the legend lists them."""
    out = {}
    for ch in recording_chunks(path):
        if ch.is_static:
            batch = ch.to_record_batch()
            names = batch.column("SeriesLines:names")[0].as_py()
            packed = batch.column("SeriesLines:colors")[0].as_py()
            colours = [((c >> 24) & 255, (c >> 16) & 255, (c >> 8) & 255) for c in packed]
            out[ch.entity_path.strip("/")] = (names, colours)
    return out


def test_three_views_per_experiment_one_entity_each_in_two_chunks_the_first_tab_first(written):
    """The viewer spends about a frame on every few chunks it loads, and shows nothing
    until the layout and the first tab's curves are in: three views per experiment (no
    torque view, no view of the far baselines), each one entity (its legend, then its
    curves), the first experiment's first."""
    path, _ = written
    chunks = recording_chunks(path)
    per_entity = Counter(ch.entity_path.strip("/") for ch in chunks)
    views = ("angle", "error", "difference")
    prefixes = ("rigid/table2", "flexible/table3")
    assert set(per_entity) == {f"{p}/{v}" for p in prefixes for v in views}
    assert set(per_entity.values()) == {2}
    order = [ch.entity_path.strip("/") for ch in chunks]
    assert order[:6] == [f"rigid/table2/{v}" for v in views for _ in range(2)]
    assert [ch.is_static for ch in chunks[:2]] == [True, False]


def test_the_legend_names_every_controller_the_pair_first_in_its_colour(written):
    """Per view: the pair, the other FCM variants, the baselines on the pair's scale and
    the reference last (a view too short for its legend cuts the last entries); a
    controller keeps its colour in every view and tab; the far baseline is in none."""
    path, _ = written
    lines = legend(path)
    pair = ["FCM-CTC", "CTC", "FCM-CTC-continuous"]
    assert lines["rigid/table2/angle"][0] == [*pair, "CTC-I", "PD-G", "reference"]
    assert lines["rigid/table2/error"][0] == pair
    assert lines["flexible/table3/angle"][0] == ["FCM-CTC", "CTC", "reference"]
    assert lines["rigid/table2/difference"][0] == ["FCM-CTC − CTC", "FCM-CTC-continuous − CTC"]
    assert lines["flexible/table3/difference"][0] == ["FCM-CTC − CTC"]
    colour = {}
    for names, colours in lines.values():
        for name, c in zip(names, colours, strict=True):
            assert colour.setdefault(name, c) == c, name
    assert colour["reference"] == REFERENCE_COLOR
    for name in ("FCM-CTC", "CTC", "FCM-CTC-continuous", "CTC-I", "PD-G"):  # the figures'
        assert colour[name] == rgb(CONTROLLER_STYLES[name][0]), name
    # a difference takes its FCM variant's colour; the controllers' colours are their own
    assert colour["FCM-CTC-continuous − CTC"] == colour["FCM-CTC-continuous"]
    own = {n: c for n, c in colour.items() if "−" not in n}
    assert len(set(own.values())) == len(own)


def test_every_curve_reads_back_at_the_kept_samples_a_short_run_ends_in_nan(written):
    """read_comparison gives each curve its column (``P/<view>/<controller>``, the
    entities of the layout before one entity held a whole view): every 20th sample (50
    Hz of the 1 kHz loop), each run's last, and NaN past the end of a run cut short;
    read_recording reads the file the same way."""
    path, experiments = written
    frame = read_comparison(path)
    rigid, flexible = experiments
    idx = np.union1d(sample_indices(N, 20), [SHORT - 1])
    t = np.round(idx * 1e-3, 9)
    for e in experiments:
        j = e.joint - 1
        for name, tr in e.runs.items():
            keep = idx[idx < len(tr.t)]
            for leaf, values in (("angle", tr.q), ("error", tr.q_ref - tr.q)):
                column = f"{e.prefix}/{leaf}/{name}"
                if name == "fuzzy-PD" or (name in ("PD-G", "CTC-I") and leaf != "angle"):
                    assert column not in frame  # errors: the pair's; far baselines: none
                    continue
                got = frame[column].dropna()
                if e is flexible:  # the other experiment's extra sample is NaN here
                    keep = sample_indices(N, 20)
                np.testing.assert_allclose(got.index, np.round(keep * 1e-3, 9))
                np.testing.assert_array_equal(got.to_numpy(), values[keep, j])
    assert np.allclose(frame.index, t)
    short = frame["rigid/table2/angle/CTC-I"]
    assert short.loc[(SHORT - 1) * 1e-3 :].notna().sum() == 1  # its last sample, then NaN
    np.testing.assert_array_equal(
        frame["rigid/table2/angle/reference"].dropna().to_numpy(),
        rigid.runs["CTC"].q_ref[idx, 0],
    )
    for e in experiments:  # each FCM variant less the baseline, at the kept samples
        j = e.joint - 1
        for name in ("FCM-CTC", "FCM-CTC-continuous"):
            if name not in e.runs:
                continue
            got = frame[f"{e.prefix}/difference/{name} − CTC"].dropna()
            keep = idx if e is rigid else sample_indices(N, 20)  # rigid: CTC-I's end too
            diff = e.runs[name].q[:, j] - e.runs["CTC"].q[:, j]
            np.testing.assert_array_equal(got.to_numpy(), diff[keep])
    assert not any("torque" in c or "baselines" in c or "fuzzy-PD" in c for c in frame)
    # angles, errors, differences; rigid then flexible
    assert len(frame.columns) == 6 + 3 + 2 + 3 + 2 + 1
    pd_testing.assert_frame_equal(read_recording(path), frame)


def test_each_tab_has_its_views_their_legends_bottom_right(written):
    """The layout: a tab per experiment, a view per entity, its legend bottom right (the
    viewer's default, bottom left, covers the start of every step), and nothing else the
    viewer would have to load (each view fits its y axis to its curves); the angle view's
    title names a baseline left out."""
    path, experiments = written
    reader = RrdReader(path)
    (bp,) = reader.blueprints()
    views: dict[str, dict] = {}
    tabs = []
    for ch in reader.stream(store=bp):
        batch = ch.to_record_batch()
        parts = ch.entity_path.split("/")
        if "ContainerBlueprint:display_name" in batch.schema.names:
            tabs += batch.column("ContainerBlueprint:display_name").to_pylist()[-1]
        if len(parts) < 3 or parts[1] != "view":
            continue
        for name in batch.schema.names:
            if ":" in name:
                views.setdefault(parts[2], {})[name] = batch.column(name).to_pylist()[-1]
    assert sorted(tabs) == sorted(e.title for e in experiments)  # stored in no set order
    by_origin = {v["ViewBlueprint:space_origin"][0].strip("/"): v for v in views.values()}
    assert set(by_origin) == {ch.entity_path.strip("/") for ch in recording_chunks(path)}
    for v in by_origin.values():
        assert v["PlotLegend:corner"] == [4]  # RightBottom
        assert {n.split(":")[0] for n in v} == {"ViewBlueprint", "ViewContents", "PlotLegend"}
    titles = {o: v["ViewBlueprint:display_name"][0] for o, v in by_origin.items()}
    assert titles["rigid/table2/angle"].startswith("θ₁ [rad]: FCM-CTC, CTC, FCM-CTC-continuous")
    assert titles["rigid/table2/angle"].endswith("(fuzzy-PD leaves it: not shown)")
    assert titles["flexible/table3/angle"].endswith("the baselines on their scale")
    assert titles["flexible/table3/error"] == "error θ₂d − θ₂ [rad]"
    assert titles["rigid/table2/difference"] == (
        "difference θ₁ [rad]: largest |FCM-CTC − CTC| 0.001 rad"
    )


def test_time_is_the_only_timeline_and_the_layout_leaves_the_time_panel_alone(written):
    """With one timeline the viewer opens on it; a time-panel setting would make it warn
    "Timeline 'time' not found" until the curves are in (seen in the web viewer)."""
    path, _ = written
    timelines = set()
    for ch in recording_chunks(path):
        timelines |= set(ch.timeline_names)
    assert timelines == {"time"}
    reader = RrdReader(path)
    (bp,) = reader.blueprints()
    names = {n for ch in reader.stream(store=bp) for n in ch.to_record_batch().schema.names}
    assert not any(n.startswith("TimePanelBlueprint") for n in names)


def test_runs_of_one_experiment_share_a_time_grid(tmp_path):
    e = experiment("rigid/table2", 1, {"CTC": 0.0, "FCM-CTC": 0.0})
    slow = e.runs["CTC"]
    runs = {**e.runs, "CTC": Trajectory(slow.t * 2, *(getattr(slow, f) for f in TRAJ[1:]))}
    with pytest.raises(ValueError, match="time grid"):
        write_comparison(tmp_path / "r.rrd", [ExperimentRuns(e.prefix, e.title, 1, runs)])
    assert not (tmp_path / "r.rrd").exists()


TRAJ = ("t", "q", "qd", "q_ref", "qd_ref", "qdd_ref", "tau", "motor_q")


def tab_order(path: Path) -> tuple[list[str], str]:
    """The tab bar's titles in order, and the title of the tab the recording opens on."""
    reader = RrdReader(path)
    (bp,) = reader.blueprints()
    fields: dict[str, dict] = {}
    for ch in reader.stream(store=bp):
        batch = ch.to_record_batch()
        for name in batch.schema.names:
            if name.startswith("ContainerBlueprint:"):
                fields.setdefault(ch.entity_path.strip("/"), {})[name.split(":")[1]] = batch.column(
                    name
                ).to_pylist()[-1]
    (tabs,) = [f for f in fields.values() if "active_tab" in f]
    title = {k: f.get("display_name", [None])[0] for k, f in fields.items()}
    return [title[c] for c in tabs["contents"]], title[tabs["active_tab"][0]]


def test_it_opens_on_the_experiment_where_the_pair_differ_most_its_variant_first(tmp_path):
    """The rigid quintic moves first in the manifest, where the pair coincide; the raw
    steps, where they differ, open the recording: the largest difference first, then its
    variant's other tabs in their order, then the other variants."""
    experiments = [
        experiment("rigid/table2", 1, {"CTC": 0.0, "FCM-CTC": 0.0}),
        experiment("rigid/table3", 2, {"CTC": 1e-17, "FCM-CTC": 0.0}),
        experiment("raw/table2", 1, {"CTC": 0.05, "FCM-CTC": 0.0}),
        experiment("raw/table3", 2, {"CTC": 0.1, "FCM-CTC": 0.0}),
        experiment("raw/table4", 1, {"CTC": 0.02, "FCM-CTC": 0.0}),
        experiment("flexible/table2", 1, {"CTC": 0.01, "FCM-CTC": 0.0}),
    ]
    assert pair_difference(experiments[3]) == pytest.approx(0.1)
    assert pair_difference(experiments[0]) == 0.0
    write_comparison(tmp_path / "r.rrd", experiments)
    order, opened = tab_order(tmp_path / "r.rrd")
    assert order == [
        "raw: table3",
        "raw: table2",
        "raw: table4",
        "flexible: table2",
        "rigid: table2",
        "rigid: table3",
    ]
    assert opened == order[0]
    assert [e.title for e in order_experiments(experiments)] == order
    # and its curves are the first the viewer loads
    assert recording_chunks(tmp_path / "r.rrd")[0].entity_path.strip("/") == "raw/table3/angle"


def test_where_the_pair_never_differ_the_given_order_stays(tmp_path):
    experiments = [
        experiment("rigid/table2", 1, {"CTC": 0.0, "FCM-CTC": 0.0}),
        experiment("flexible/table2", 1, {"CTC": 0.0, "FCM-CTC": 0.0}),
        experiment("rigid/table3", 1, {"CTC": 0.0}),  # no pair: no difference view
    ]
    assert order_experiments(experiments) == [experiments[0], experiments[2], experiments[1]]
    write_comparison(tmp_path / "r.rrd", experiments)
    assert tab_order(tmp_path / "r.rrd")[1] == "rigid: table2"
    entities = {ch.entity_path.strip("/") for ch in recording_chunks(tmp_path / "r.rrd")}
    assert "rigid/table3/difference" not in entities and "rigid/table2/difference" in entities
