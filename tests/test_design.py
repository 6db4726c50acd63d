"""The FCM design procedure and the FCM-CTC controller on the paper's scenarios."""

from pathlib import Path

import numpy as np
import pytest

from twolink.controllers.fuzzy import Rule, fired_rule_labels, load_rule_base
from twolink.controllers.fuzzy_ctc import FuzzyComputedTorque
from twolink.simulation.config import RULEBASE_DIR, ConfigError, load_scenario
from twolink.simulation.experiment import build_controller, run_scenario
from twolink.studies.designs.design import (
    DEFAULT_DESIGN,
    design,
    design_or_load,
    load_design_config,
    save_design,
)
from twolink.studies.designs.design_checks import mirror_rule

PAPER = Path(__file__).resolve().parents[1] / "runs" / "paper"


@pytest.fixture(scope="module")
def config():
    return load_design_config(DEFAULT_DESIGN)


@pytest.fixture(scope="module")
def result(config):
    return design(config)


def test_design_is_deterministic_for_a_seed(config, result):
    again = design(config)
    assert again.rules == result.rules
    np.testing.assert_array_equal(again.clustering.centers, result.clustering.centers)
    np.testing.assert_array_equal(again.linguistic, result.linguistic)
    assert again.digest == result.digest


def test_kept_rules_are_the_rules_the_evidence_names(result):
    rules = result.engine.rules
    # per cluster: the rule with the largest weighted, membership-weighted firing strength
    w = np.abs(result.points).sum(axis=1)[:, None] * result.clustering.memberships**2.0
    firing = result.engine.firing(result.points[:, 0], result.points[:, 1])
    scores = (w.T @ firing) / w.sum(axis=0)[:, None]
    np.testing.assert_allclose(scores, result.scores, rtol=1e-12)
    clustered = {rules[i] for i in np.argmax(scores, axis=1)}
    assert set(result.clustered_rules) == clustered
    # the rule base: those rules and their mirrors (symmetry = "enforce")
    assert set(result.rules) == clustered | {mirror_rule(r) for r in clustered}
    # every clustered rule fired on the trajectory and is the best rule at its cluster
    counts = result.firing_counts
    assert all(counts.get(r, 0) > 0 for r in clustered)
    assert len(clustered) <= result.clustering.n_clusters


def test_written_rule_base_and_evidence_round_trip(tmp_path, config, result):
    save_design(result, tmp_path)
    saved = load_rule_base(tmp_path / "rule_base.toml")
    assert set(saved.rules) == set(result.rules)
    ev = saved.metadata["evidence"]
    assert {tuple(s.split()) for s in ev["kept_per_cluster"]} == set(result.clustered_rules)
    np.testing.assert_allclose(ev["centres_e"], result.clustering.centers[:, 0], atol=1e-6)
    loaded, designed = design_or_load(config, tmp_path)
    assert not designed and loaded.rules == result.rules
    np.testing.assert_array_equal(loaded.points, result.points)
    np.testing.assert_array_equal(loaded.sample_weights, result.sample_weights)
    assert loaded.splits == result.splits
    for a, b in zip(loaded.validation, result.validation, strict=True):
        assert (a.run, a.file, a.controller) == (b.run, b.file, b.controller)
        for k in a.COLUMNS:
            np.testing.assert_allclose(getattr(a, k), getattr(b, k), rtol=1e-5, atol=0)


def test_an_edited_designed_rule_base_is_not_reused(tmp_path, config, result):
    save_design(result, tmp_path)
    path = tmp_path / "rule_base.toml"
    rule = result.rules[0]
    other = "PB" if rule.u != "PB" else "NB"
    text = path.read_text()
    edited = text.replace(f'u = "{rule.u}"', f'u = "{other}"', 1)
    assert edited != text
    path.write_text(edited)
    loaded, designed = design_or_load(config, tmp_path)
    assert designed and loaded.rules == result.rules  # designed again, not the edit
    assert load_rule_base(path).rules == result.rules  # and written back whole


def test_a_changed_design_config_is_designed_afresh(tmp_path, config, result):
    save_design(result, tmp_path)
    changed = load_design_config(DEFAULT_DESIGN)
    changed = type(changed)(**{**changed.__dict__, "seed": 7})
    _, designed = design_or_load(changed, tmp_path)
    assert designed
    assert load_rule_base(tmp_path / "rule_base.toml").metadata["evidence"]["digest"] != (
        result.digest
    )


def test_shipped_designed_rule_base_is_current(result):
    # `twolink design --install` wrote controllers/rulebases/designed.toml
    shipped = load_rule_base(RULEBASE_DIR / "designed.toml")
    assert set(shipped.rules) == set(result.rules)
    assert shipped.metadata["evidence"]["digest"] == result.digest


def test_fired_rule_labels_name_the_dominant_rule_or_none(result):
    engine = result.engine.with_rules([Rule("PB", "PB", "PB"), Rule("Z", "Z", "Z")])
    labels = fired_rule_labels(engine, np.array([1.0, 0.0, -1.0]), np.array([1.0, 0.05, 1.0]))
    assert labels.tolist() == ["PB,PB→PB", "Z,Z→Z", "none"]


def test_bad_design_files_name_the_key(tmp_path):
    bad = tmp_path / "design.toml"
    bad.write_text("scenarios = []\n")
    with pytest.raises(ConfigError, match="scenarios"):
        load_design_config(bad)
    bad.write_text(f'scenarios = ["{PAPER / "theta1_step.toml"}"]\nfuzzifier = 1.0\n')
    with pytest.raises(ConfigError, match="fuzzifier: must be > 1"):
        load_design_config(bad)


SCENARIOS = ["theta1_step", "theta1_ramp", "theta2_step", "theta2_ramp"]


@pytest.mark.parametrize("rule_base", ["paper", "designed"])
@pytest.mark.parametrize("name", SCENARIOS)
def test_fcm_ctc_keeps_the_loop_stable_on_the_papers_scenarios(name, rule_base):
    # The property FCM-CTC must meet on the nominal arm: the run completes, the error
    # never exceeds the 1 rad move by more than 20 %, and after 10 s it is within 0.01 rad
    # of the target on both joints.
    s = load_scenario(
        PAPER / f"{name}.toml", {"controller": {"kind": "fcm_ctc", "rule_base": rule_base}}
    )
    controller = build_controller(s)
    assert isinstance(controller, FuzzyComputedTorque)
    traj = run_scenario(s, controller)
    assert traj.ok, traj.message
    assert np.abs(traj.e).max() <= 1.2
    assert np.abs(traj.e[-1]).max() < 0.01
