"""The velocity filter's cut-off rule (docs/sensors.md) and the torque activity it buys:
CTC at the shipped gains behind a 17-bit encoder, exact, differenced and filtered rates."""

import pytest

from twolink.simulation.sensor import DEFAULT_CUTOFF_HZ
from twolink.studies.designs import sensing


@pytest.fixture(scope="module")
def table():
    wn = sensing.design_wn()
    return wn, sensing.velocity_table(bandwidths=(wn,)).set_index("sensor")


def test_the_rule_gives_the_shipped_cutoff(table):
    wn, t = table
    assert wn == 15.0
    assert sensing.choose_cutoff(t.reset_index(), wn) == DEFAULT_CUTOFF_HZ == 50.0
    # ... because the next lower cut-off of the grid lags past the budget, and 50 Hz not.
    assert t.loc["encoder, filtered 30 Hz", "max_error_rad"] > sensing.ERROR_BUDGET
    assert t.loc["encoder, filtered 50 Hz", "max_error_rad"] <= sensing.ERROR_BUDGET


def test_torque_activity_exact_differenced_filtered(table):
    # docs/sensors.md's figures: Σ|Δτ| of joint 1 is 27 N·m with the true state, ~11,000
    # with the differenced encoder rate and ~240 filtered at 50 Hz.
    _, t = table
    v = t["torque_variation1_Nm"]
    assert v["exact"] == pytest.approx(27.0, rel=0.01)
    assert v["encoder, differenced"] == pytest.approx(11_170, rel=0.01)
    assert v["encoder, filtered 50 Hz"] == pytest.approx(241, rel=0.01)
    filtered = [v[f"encoder, filtered {fc:g} Hz"] for fc in sensing.CUTOFFS]
    assert filtered == sorted(filtered)  # activity rises with the cut-off
    assert v["encoder, differenced"] > 40 * v["encoder, filtered 50 Hz"] > 40 * 5 * v["exact"]
    # ... and every rate ends on target within a few encoder counts.
    assert (t["final_error_rad"] < 3e-4).all() and (t["status"] == "ok").all()


def test_the_reports_sensor_line_says_the_papers_only_for_the_true_state():
    from twolink.simulation.sensor import Sensor
    from twolink.studies.reproduction.choices import sensor_choice

    ideal = sensor_choice({Sensor()})
    assert ideal.startswith("ideal (true angles and rates) in the paper's experiments, as the")
    encoder = sensor_choice({Sensor.encoder()})
    assert encoder.startswith("17-bit encoder") and "as the paper's simulation" not in encoder
    mixed = sensor_choice({Sensor(), Sensor.encoder()})
    assert "as the paper's simulation" not in mixed
