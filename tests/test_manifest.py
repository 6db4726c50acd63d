"""The reproduction manifest: controller names are the manifest's own, end to end."""

import math
from pathlib import Path

import pytest

from twolink.simulation.config import ConfigError
from twolink.simulation.vocabulary import METRICS
from twolink.studies.reproduction import report
from twolink.studies.reproduction.manifest import DEFAULT_MANIFEST, load_manifest

PAPER = DEFAULT_MANIFEST.parent


def shipped_text() -> str:
    """The shipped manifest without its explicit claim roles (so the defaults apply) and
    without its second controller of kind "ctc" (CTC-paper), which would make the default
    baseline ambiguous."""
    text = DEFAULT_MANIFEST.read_text()
    start = text.index("[controllers.CTC-paper]")
    text = text[:start] + text[text.index("\n\n", start) + 2 :]
    lines = text.splitlines(keepends=True)
    return "".join(x for x in lines if not x.startswith(("proposed =", "baseline =")))


def paper_paths(text: str) -> str:
    """A copy of the shipped manifest, elsewhere: its files still the shipped ones."""
    for key in (
        "scenario",
        "design",
        "flexible_study",
        "claims_study",
        "lab_study",
        "gain_study",
        "calibration",
    ):
        text = text.replace(f'{key} = "', f'{key} = "{PAPER}/')
    return text


def renamed_manifest(tmp_path: Path, extra: str = "", **names: str) -> Path:
    """The shipped manifest, with absolute paths and its controllers renamed."""
    # without its claims sweep, which runs the controllers by their shipped names
    text = "".join(x for x in shipped_text().splitlines(True) if not x.startswith("claims_"))
    text = paper_paths(text)
    for old, new in names.items():
        text = text.replace(f"controllers.{old}]", f"controllers.{new}]")
        text = text.replace(f"paper.{old} =", f"paper.{new} =")
    path = tmp_path / "reproduce.toml"
    path.write_text(extra + text)
    return path


def fake_rows(manifest):
    """One row per run, with values that make the proposed controller win on Mp."""
    rows = []
    for variant in manifest.variants:
        for exp in manifest.experiments:
            for k, name in enumerate(manifest.controllers):
                rows.append(
                    {
                        "variant": variant.name,
                        "experiment": exp.key,
                        "controller": name,
                        "joint": exp.joint,
                        "reference": "step",
                        "status": "ok",
                        "outcome": "met spec",
                        **{m.key: 1.0 + k for m in METRICS},
                        "overshoot_pct": 10.0 if name == manifest.proposed else 30.0,
                        "other_reference": "held",
                        "other_max_error_rad": 0.5,
                        "other_final_error_rad": 0.25,
                    }
                )
    return rows


def test_the_shipped_manifest_compares_fcm_against_ctc(tmp_path):
    m = load_manifest()
    assert (m.proposed, m.baseline) == ("FCM-CTC", "CTC")
    # the same by default, from the controllers' kinds
    implicit = load_manifest(renamed_manifest(tmp_path))
    assert (implicit.proposed, implicit.baseline) == ("FCM-CTC", "CTC")


def test_the_report_uses_the_manifests_own_controller_names(tmp_path):
    path = renamed_manifest(tmp_path, CTC="pd_model", **{"FCM-CTC": "fuzzy"})
    m = load_manifest(path)
    # the roles follow the controllers' kinds
    assert (m.proposed, m.baseline) == ("fuzzy", "pd_model")
    text = report.render(fake_rows(m), m, {"uncertainty": "masses x1.2"}, {})
    assert "| pd_model | " in text and "| fuzzy | " in text
    n = len(m.experiments)
    lower = f"fuzzy's overshoot is lower than pd_model's (by more than 1 percentage point) in {n}"
    assert lower in text and f"higher in 0, of {n} experiments" in text
    assert "| CTC |" not in text and "| FCM-CTC |" not in text
    # the paper's values are found under the new names
    assert "/ 5.89 |" in text


def test_claim_roles_can_be_named_and_are_checked_before_anything_runs(tmp_path):
    # Two computed-torque controllers: the baseline cannot be inferred from the kinds.
    extra = '[controllers.stiff]\nkind = "ctc"\nkp = 25.0\nkd = 10.0\n\n'
    text = shipped_text().replace("[variants.rigid]", extra + "[variants.rigid]")
    path = tmp_path / "two_ctc.toml"
    path.write_text(paper_paths(text))
    with pytest.raises(ConfigError, match=r"two_ctc.toml: baseline: missing"):
        load_manifest(path)
    path.write_text('baseline = "stiff"\n' + path.read_text())
    m = load_manifest(path)
    assert (m.proposed, m.baseline) == ("FCM-CTC", "stiff")
    rows = fake_rows(m)
    assert "FCM-CTC's overshoot is lower than stiff's (by" in report.render(rows, m, {}, {})
    for bad, message in (
        ('proposed = "nope"', "proposed: must name a controller of this manifest"),
        ('proposed = "CTC"\nbaseline = "CTC"', "baseline: must differ from proposed"),
    ):
        path.write_text(bad + "\n" + paper_paths(text))
        with pytest.raises(ConfigError, match=message):
            load_manifest(path)


def test_claims_count_the_proposed_controller_against_the_baseline(tmp_path):
    m = load_manifest(renamed_manifest(tmp_path, CTC="b", **{"FCM-CTC": "a"}))
    rows = fake_rows(m)
    counts = report.claims(rows, m, "rigid")
    n = len(m.experiments)
    assert counts["overshoot_pct"][:3] == (n, 0, n)  # a wins every time
    assert counts["peak_time_s"][:3] == (0, n, n)  # a's 2.0 never below b's 1.0
    assert not any(math.isnan(x) for c in counts.values() for x in c)


def test_a_claim_is_not_won_by_rounding():
    from twolink.studies.judgments.claims import count_wins

    assert count_wins([3.0e-15], [3.1e-15], 1e-3) == (0, 0, 1)  # both at rounding: a tie
    assert count_wins([0.001], [0.002], 1e-4) == (1, 0, 0)
    assert count_wins([0.001], [0.0015], 1e-3) == (0, 0, 1)  # within the tolerance
    assert count_wins([float("nan")], [1.0], 1e-3) == (0, 0, 0)  # not counted


def test_a_claims_sweep_must_run_the_claims_two_controllers(tmp_path):
    from click.testing import CliRunner

    from twolink.interface.cli import main

    sweep = tmp_path / "other.toml"
    sweep.write_text(
        (PAPER.parent / "sweeps" / "robustness.toml")
        .read_text()
        .replace("[controllers.FCM-CTC]", "[controllers.FCM]")
        .replace('"../paper/base.toml"', f'"{PAPER}/base.toml"')
    )
    text = (PAPER / "reproduce.toml").read_text()
    path = tmp_path / "m.toml"
    path.write_text(paper_paths(text).replace(f'"{PAPER}/../sweeps/robustness.toml"', f'"{sweep}"'))
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["reproduce", "--manifest", str(path), "--out", str(out)])
    assert result.exit_code == 2, result.output
    assert "m.toml: claims_study: other.toml must run ['FCM-CTC']" in result.output
    assert not out.exists()


def test_the_lab_sweep_must_run_the_claims_two_controllers(tmp_path):
    from click.testing import CliRunner

    from twolink.interface.cli import main

    sweep = tmp_path / "lab.toml"
    sweep.write_text(
        (PAPER.parent / "sweeps" / "lab.toml")
        .read_text()
        .replace("[controllers.CTC]", "[controllers.C]")
        .replace('"../paper/base.toml"', f'"{PAPER}/base.toml"')
    )
    text = paper_paths((PAPER / "reproduce.toml").read_text())
    path = tmp_path / "m.toml"
    path.write_text(text.replace(f'"{PAPER}/../sweeps/lab.toml"', f'"{sweep}"'))
    assert load_manifest(path).lab_study == sweep
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["reproduce", "--manifest", str(path), "--out", str(out)])
    assert result.exit_code == 2, result.output
    assert (
        result.output.strip()
        .splitlines()[-1]
        .endswith(
            "m.toml: lab_study: lab.toml must run ['CTC'] by name (it runs "
            "['C', 'PD-G', 'CTC-I', 'FCM-CTC', 'FCM-CTC-continuous'])"
        )
    )
    assert not out.exists()
