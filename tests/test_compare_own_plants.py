"""`twolink compare --plants-file`: the two controllers judged on the user's own plants, a
CSV of one row per plant and one column per sweep parameter, run as the sweep's
``listed`` parameters (sample i takes row i); ``twolink sweep compare.toml`` reruns the
same plants; a bad plants file is one line naming it, exit 2; and the sweeps without
listed parameters draw exactly the plants they drew before (docs/compare.md, "Your own
plants"; docs/sweeps.md, "Listed")."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from cli_inputs import invoke, one_error_line
from test_sweep import SMALL, columns_equal, write

import twolink
from twolink import sweep as sw
from twolink.simulation.config import ConfigError

REPO = Path(__file__).resolve().parents[1]
SHORT = ["--set", "duration=0.5", "--workers", "1", "--no-trace"]  # each run 0.5 s of the step
PLANTS = "m1,payload,coulomb1\n0.9,0.0,0.0\n1.0,0.1,0.5\n1.2,0.3,0.0\n1.1,0.2,1.0\n"
ROWS = [[0.9, 0.0, 0.0], [1.0, 0.1, 0.5], [1.2, 0.3, 0.0], [1.1, 0.2, 1.0]]

# SMALL (tests/test_sweep.py: 8 samples) with two listed parameters of 9 values, l1 and
# d1 (any parameter a sweep draws can be listed); m1 m2 l2 payload drawn, k a grid
L1 = [0.95, 1.0, 1.05, 1.1, 0.9, 1.0, 1.0, 1.02, 0.97]
LISTED = SMALL.replace(
    "[parameters]\n",
    "[parameters]\n"
    f'l1 = {{ dist = "listed", values = {L1} }}\n'
    'd1 = { dist = "listed", values = [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0] }\n',
)


def test_a_listed_parameter_gives_row_i_to_sample_i_and_takes_no_draw(tmp_path):
    """Sample i takes values[i] of every listed parameter (samples may be fewer than the
    values: 8 of 9 here); the parameters drawn and the noise seed are those of the same
    sweep without the listed ones, which take nothing from the generator."""
    plan = sw.load_sweep(write(tmp_path, LISTED))
    without = sw.load_sweep(write(tmp_path, SMALL, "without.toml"))
    assert plan.parameter_names == ("d1", "k", "l1", "l2", "m1", "m2", "payload")
    assert plan.samples == 8
    for i in range(plan.samples):
        values, noise = plan.draw(i)
        assert values["l1"] == L1[i] and values["d1"] == 0.5 * i
        drawn, noise_without = without.draw(i)
        assert noise == noise_without
        assert {n: values[n] for n in drawn} == drawn
    # a listed payload is a sample's payload (listed values run like drawn ones)
    data = plan.sample_data(*plan.draw(3))
    assert data["plant"]["scale"]["l1"] == 1.1 and data["plant"]["flexibility"]["d"][0] == 1.5


@pytest.mark.parametrize(
    ("edit", "says"),
    [
        (lambda t: t.replace(", 3.5, 4.0]", ", 3.5]"),
         "parameters.l1.values: has 9 values, but parameters.d1.values has 8: every listed"),
        (lambda t: t.replace("samples = 8", "samples = 10"),
         "samples: must be at most 9, the number of values of the listed parameters"),
        (lambda t: t.replace("0.95, 1.0, 1.05", "0.95, -1.0, 1.05"),
         "parameters.l1.values: must be > 0 for parameter 'l1', got -1.0"),
        (lambda t: t.replace('dist = "listed", values = [0.0', 'dist = "listed", low = 0.0, '
                             "values = [0.0"),
         "parameters.d1.low: unknown key for listed (known: ['dist', 'values'])"),
        (lambda t: t.replace("[0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0]", "[]"),
         "parameters.d1.values: must be a non-empty list of numbers"),
    ],
    ids=["unequal lengths", "samples over values", "out of domain", "unknown key", "no values"],
)  # fmt: skip
def test_a_bad_listed_parameter_is_named_with_its_file(tmp_path, edit, says):
    path = write(tmp_path, edit(LISTED))
    with pytest.raises(ConfigError) as caught:
        sw.load_sweep(path)
    assert str(caught.value).startswith(f"{path}: ") and says in str(caught.value)


# Computed on main before the listed distribution (30b4f32): sample -> (values, noise seed)
ROBUSTNESS = {
    0: ({"g": 1.0025146044218678, "l1": 0.9539573427527741, "l2": 0.908194704787239,
         "m1": 0.7099165813171174, "m2": 1.1879621435201635, "payload": 0.18255111545554437},
        1081530687),
    7: ({"g": 0.9877976696219604, "l1": 1.0554254954320161, "l2": 1.0598338492943131,
         "m1": 0.9859040874310804, "m2": 1.2045951277382603, "payload": 0.1896718393488706},
        88159254),
    199: ({"g": 0.9824996494759722, "l1": 0.9583622124916439, "l2": 0.9619703733588295,
           "m1": 0.8118640873346437, "m2": 0.9112238928502675, "payload": 0.01249542763635827},
          1112148909),
}  # fmt: skip
LAB_0_FRICTION = {
    "coulomb1": 1.7294965609839985,
    "coulomb2": 0.38590624786635574,
    "stribeck_ratio": 1.4805217271363305,
    "stribeck_velocity": 0.06544154652815826,
}
SMALL_DRAWS = {
    0: ({"k": 50.0, "l2": 1.0202807416691362, "m1": 1.15888552038783, "m2": 0.9725862144637782,
         "payload": 0.0}, 119253154),
    1: ({"k": 5000.0, "l2": 1.0504138239615441, "m1": 0.8447708977270738,
         "m2": 0.966114216703488, "payload": 0.0}, 1152946234),
    5: ({"k": 5000.0, "l2": 0.9034384722936818, "m1": 1.0666303385974936,
         "m2": 1.0176293190122747, "payload": 0.1}, 1136741108),
}  # fmt: skip


def test_a_sweep_without_listed_parameters_draws_the_plants_it_drew_before(tmp_path):
    """Every distribution but listed, grid and friction among them: bit for bit the values
    and noise seeds drawn before the listed distribution was added."""
    robustness = sw.load_sweep(REPO / "runs" / "sweeps" / "robustness.toml")
    for i, drawn in ROBUSTNESS.items():
        assert robustness.draw(i) == drawn
    lab = sw.load_sweep(REPO / "runs" / "sweeps" / "lab.toml")
    assert lab.draw(0) == ({**ROBUSTNESS[0][0], **LAB_0_FRICTION}, ROBUSTNESS[0][1])
    small = sw.load_sweep(write(tmp_path, SMALL))
    for i, drawn in SMALL_DRAWS.items():
        assert small.draw(i) == drawn


def test_compare_on_a_plants_file_runs_its_rows_and_sweep_reruns_them(tmp_path):
    """4 rows: n of the claims is 4 (on the metrics every plant has), the results' parameter
    columns are the file's values, row i sample i, for both controllers; the parameters
    the file lacks stay nominal (not drawn); `twolink sweep compare.toml` gives the same
    table; the library takes the file or a DataFrame of it alike."""
    plants = tmp_path / "my plants.csv"
    plants.write_text(PLANTS)
    out = tmp_path / "cmp"
    result = invoke("compare", "theta1_step", "FCM-CTC", "CTC", "--plants-file", plants,
                    "--out", out, *SHORT)  # fmt: skip
    assert result.exit_code == 0, result.output
    assert f"FCM-CTC against CTC on 4 plants of {plants}, theta1_step" in result.output
    claims = pd.read_csv(out / "claims.csv").set_index("metric")
    assert list(claims.loc[["delay_time_s", "settling_time_s", "rise_time_s"], "n"]) == [4] * 3
    assert "too few plants for any verdict (4)" in result.output
    assert "(more rows in the plants file)" in result.output
    results = sw.load_results(out / "sweep")
    assert results.attrs["parameters"] == ["coulomb1", "m1", "payload"]  # the file's, no more
    for name in ("FCM-CTC", "CTC"):
        mine = results[results["controller"] == name].sort_values("sample")
        assert list(mine["sample"]) == [0, 1, 2, 3]
        assert mine[["m1", "payload", "coulomb1"]].to_numpy().tolist() == ROWS
    plan = sw.load_sweep(out / "compare.toml")
    assert plan.samples == 4 and {p.dist for p in plan.parameters} == {"listed"}
    # the sweep it wrote reruns the same plants: the same table
    again = invoke("sweep", out / "compare.toml", "--out", tmp_path / "again",
                   "--executor", "inprocess", "--no-plots", "--no-progress")  # fmt: skip
    assert again.exit_code == 0, again.output
    columns_equal(sw.load_results(tmp_path / "again"), results)
    # the library: the file, or a DataFrame of it, the same plants and the same table
    frame = pd.read_csv(plants)
    for given in (plants, frame):
        api = twolink.compare("theta1_step", "FCM-CTC", "CTC", plants=given,
                              overrides={"duration": 0.5})  # fmt: skip
        assert api.plants == 4 and list(api.claims["n"]) == list(claims["n"])
        columns_equal(api.results, results, attrs=False)
    assert "plants of plants (a DataFrame)" in str(api)


CAP = 1 << 20  # the documented cap of a plants file (a sweep file's), written out


def big(path):
    with open(path, "wb") as fh:  # sparse: refused by its size, nothing read
        fh.truncate(CAP + 1)


KNOWN = "m1, m2, mass, l1, l2, g, payload, k, k1, k2, d, d1, d2, j, j1, j2"
BAD = {  # file content (or a maker) -> what the one line says after the file's name
    "unknown column": ("m1,mass1\n1,1\n", f"unknown column 'mass1'; the columns are sweep "
                       f"parameters: {KNOWN}"),
    "not a number": ("m1,payload\n1.0,0.1\n1.1,heavy\n",
                     "row 2 under the header, column 'payload': not a number: 'heavy'"),
    "out of domain": ("m1,payload\n1.0,0.1\n1.1,-0.2\n",
                      "row 2 under the header, column 'payload': must be >= 0 for "
                      "parameter 'payload', got -0.2"),
    "not finite": ("m1\nnan\n", "row 1 under the header, column 'm1': must be finite"),
    "empty cell": ("m1,m2\n1.0\n", "row 1 under the header, column 'm2': empty"),
    "empty file": ("", "empty file"),
    "a header alone": ("m1,m2\n", "no plants"),
    "too many rows": ("m1\n1\n1\n1\n1\n", "4 rows: at most 3, the most a sweep holds"),
    "over the size cap": (big, "larger than 1,048,576 bytes, the most a plants file may hold"),
    "conflicting columns": ("k,k1\n1,1\n", "column 'k1' conflicts with 'k'"),
    "a column twice": ("m1,m1\n1,1\n", "column 'm1' given twice"),
    "ragged": ("m1,m2\n1,1,1\n", "not a CSV table of plants"),
    "not UTF-8": (b"m1\n\xff\n", "not a UTF-8 text file"),
    # under the cap, but "1," is "1.0, " in the sweep file: 2.4 MB, over the sweep's cap
    "a sweep file too large": ("m1,m2,l1,l2,g,payload\n" + "1,1,1,1,1,0\n" * 80_000,
                               "its 80,000 plants make a sweep file (compare.toml) of "
                               "2,400,"),  # and its paths: the scenario's, the overrides
}  # fmt: skip


@pytest.mark.parametrize("case", sorted(BAD))
def test_a_bad_plants_file_is_one_line_naming_it_exit_2(tmp_path, monkeypatch, case):
    if case == "too many rows":  # at 4, not at 10**6 (which no file under the cap holds)
        monkeypatch.setattr(sw.plan, "MAX_SAMPLES", 3)
    content, says = BAD[case]
    path = tmp_path / "plants.csv"
    if callable(content):
        content(path)
    elif isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    out = tmp_path / "out"
    result = invoke("compare", "theta1_step", "FCM-CTC", "CTC", "--plants-file", path,
                    "--out", out, *SHORT)  # fmt: skip
    assert result.exit_code == 2, result.output
    one_error_line(result)
    assert f"error: {path}: " in result.output and says in result.output, result.output
    assert not out.exists()  # refused before anything ran or was written
    from twolink.studies.judgments.compare import compare_sweep
    from twolink.sweep.plants_csv import MAX_PLANTS_BYTES

    assert MAX_PLANTS_BYTES == CAP
    with pytest.raises(ConfigError, match=f"^{path}: "):  # the library's, the same line
        compare_sweep(REPO / "runs" / "theta1_step.toml", "FCM-CTC", "CTC", path, 0)


def test_no_such_plants_file_and_both_kinds_of_plants_are_refused(tmp_path):
    missing = tmp_path / "nope.csv"
    for args, says in (
        (["--plants-file", missing], f"error: {missing}: no such file"),
        (["--plants-file", tmp_path], f"error: {tmp_path}: is not a regular file"),
        (["--plants-file", REPO / "examples" / "plants.csv", "-n", "5"],
         "give -n/--plants or --plants-file, not both"),
    ):  # fmt: skip
        result = invoke("compare", "theta1_step", "FCM-CTC", "CTC", *args,
                        "--out", tmp_path / "out", *SHORT)  # fmt: skip
        assert result.exit_code == 2, result.output
        one_error_line(result)
        assert says in result.output, result.output
    with pytest.raises(ConfigError, match=r"plants \(a DataFrame\): row 2 under the header"):
        twolink.compare("theta1_step", "FCM-CTC", "CTC", plants=pd.DataFrame({"m1": [1, 0]}))
    with pytest.raises(ConfigError, match="plants must be a number of plants, a CSV file"):
        twolink.compare("theta1_step", "FCM-CTC", "CTC", plants=2.5)


def test_the_shipped_example_plants_file_reads(tmp_path):
    """examples/plants.csv: 12 plants, the ones docs/compare.md describes."""
    from twolink.sweep.plants_csv import read_plants

    table = read_plants(REPO / "examples" / "plants.csv")
    assert table.shape == (12, 6) and list(table.columns[:2]) == ["m1", "m2"]
    assert np.all(table.iloc[0] == [1.0, 1.0, 1.0, 1.0, 0.0, 0.0])  # the nominal arm first
    assert table["payload"].max() == 0.5 and table["coulomb1"].max() == 1.0
