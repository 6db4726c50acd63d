"""The bounded reader's caps at their edge, and twolink's mark matched exactly (issue 49).

Each cap is tested one byte over (refused, naming the file) and exactly at it (read), so
a cap a thousand times too large (16 GiB for 16 MiB: a 20 MiB owner record was read in
5.9 s and accepted) fails here. Files over a cap are sparse (their size alone refuses
them, nothing is read)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from cli_inputs import invoke

from twolink.controllers.fuzzy.fis.engine_files import MAX_FIS_BYTES, read_engine
from twolink.foundation.io import MARK_LINE, RULE_BASE_TITLE, carries_mark
from twolink.foundation.journal import MAX_JOURNAL_BYTES, read_journal
from twolink.foundation.ownership import (
    JOURNAL_NAME,
    OWNER_NAME,
    RECORD_KIND,
    RECORD_VERSION,
    journal_command,
    read_record,
)
from twolink.foundation.planted import MAX_RECORD_BYTES, PlantedFile
from twolink.simulation.config import MAX_TOML_BYTES, ConfigError, load_scenario
from twolink.sweep import execution
from twolink.sweep.plan import load_sweep

REPO = Path(__file__).resolve().parents[1]
# The documented caps, written out: the files below are sized by these, never by the
# constants under test (a cap mistyped as 16 GiB must fail here, not fill the disk).
RECORD, JOURNAL, TOML, CHUNK, SEAL, MARK = 16 << 20, 16 << 20, 1 << 20, 1 << 30, 1 << 16, 64 << 20


def padded(path: Path, head: bytes, size: int, pad: bytes = b" ") -> Path:
    """``head`` padded to exactly ``size`` bytes."""
    assert len(head) <= size
    path.write_bytes(head + pad * (size - len(head)))
    assert path.stat().st_size == size
    return path


def sparse(path: Path, size: int) -> Path:
    with open(path, "wb") as fh:
        fh.truncate(size)
    return path


def test_the_caps_are_the_documented_ones():
    assert (MAX_RECORD_BYTES, MAX_JOURNAL_BYTES) == (RECORD, JOURNAL)
    assert MAX_TOML_BYTES == MAX_FIS_BYTES == TOML
    assert execution.MAX_CHUNK_BYTES == CHUNK


def test_an_owner_record_at_the_cap_is_read_and_one_byte_over_refused(tmp_path):
    record = {"kind": RECORD_KIND, "version": RECORD_VERSION, "command": "demo",
              "source": None, "files": {}}  # fmt: skip
    padded(tmp_path / OWNER_NAME, json.dumps(record).encode(), RECORD)
    assert read_record(tmp_path) == record
    padded(tmp_path / OWNER_NAME, json.dumps(record).encode(), RECORD + 1)
    with pytest.raises(PlantedFile, match=f"{tmp_path / OWNER_NAME}: larger than"):
        read_record(tmp_path)


def test_a_journal_at_the_cap_is_read_and_one_byte_over_refused(tmp_path):
    padded(tmp_path / JOURNAL_NAME, b"command demo\n", JOURNAL)
    assert journal_command(tmp_path) == "demo" and read_journal(tmp_path) == ({}, {})
    padded(tmp_path / JOURNAL_NAME, b"command demo\n", JOURNAL + 1)
    with pytest.raises(PlantedFile, match=f"{tmp_path / JOURNAL_NAME}: larger than"):
        read_journal(tmp_path)
    assert journal_command(tmp_path) == "demo"  # its first line alone is read for that


def test_a_chunk_seal_at_its_cap_is_read_and_a_chunk_over_its_cap_never(tmp_path):
    chunk = tmp_path / "chunk_00000.parquet"
    chunk.write_bytes(b"x")
    seal = json.dumps({"digest": "d" * 64, "sha256": "0" * 64}).encode()
    padded(chunk.with_suffix(".json"), seal, SEAL)
    assert execution._seal_digest(chunk) == "d" * 64
    padded(chunk.with_suffix(".json"), seal, SEAL + 1)
    assert execution._seal_digest(chunk) is None
    # over the chunk cap: refused by its size, before a byte is read (a sparse file; the
    # cap itself, 1 GiB, is too large to read in a test)
    plan = load_sweep(REPO / "runs" / "sweeps" / "robustness.toml", {"samples": 1})
    (tmp_path / "chunks").mkdir()
    big = sparse(tmp_path / "chunks" / "chunk_00000.parquet", CHUNK + 1)
    big.with_suffix(".json").write_text(json.dumps({"digest": plan.digest, "sha256": "0" * 64}))
    calls = []
    real = execution.read_bounded
    execution.read_bounded = lambda *a: calls.append(a) or real(*a)
    try:
        assert execution._valid_chunk(plan, tmp_path, 0) is None
    finally:
        execution.read_bounded = real
    assert calls == [(big, CHUNK)]


def test_a_scenario_and_a_sweep_file_at_the_cap_are_read_and_one_byte_over_refused(tmp_path):
    text = (REPO / "runs" / "paper" / "base.toml").read_bytes() + b"\n#"
    scenario = padded(tmp_path / "s.toml", text, TOML, b"x")
    assert load_scenario(scenario).duration > 0
    padded(scenario, text, TOML + 1, b"x")
    with pytest.raises(ConfigError, match=f"{scenario}: larger than"):
        load_scenario(scenario)
    sweep = (REPO / "runs" / "sweeps" / "robustness.toml").read_text()
    sweep = sweep.replace('scenario = "', f'scenario = "{REPO / "runs" / "sweeps"}/')
    path = padded(tmp_path / "w.toml", sweep.encode() + b"\n#", TOML, b"x")
    assert load_sweep(path).samples > 0
    padded(path, sweep.encode() + b"\n#", TOML + 1, b"x")
    with pytest.raises(ConfigError, match=f"{path}: .*larger than"):
        load_sweep(path)


def test_a_fis_file_at_the_cap_is_read_and_one_byte_over_refused(tmp_path):
    from twolink.controllers.fuzzy import default_fuzzy_pd
    from twolink.controllers.fuzzy.fis import write_fis

    source = tmp_path / "a.fis"
    write_fis(source, default_fuzzy_pd())
    text = source.read_bytes() + b"\n%"
    fis = padded(tmp_path / "b.fis", text, TOML, b"x")
    read_engine(fis)
    padded(fis, text, TOML + 1, b"x")
    with pytest.raises(Exception, match=f"{fis}: larger than"):
        read_engine(fis)


def test_a_marked_file_at_the_marks_cap_is_twolinks_and_one_byte_over_is_not(tmp_path):
    path = padded(tmp_path / "r.toml", MARK_LINE + b"\n#", MARK, b"x")
    assert carries_mark(path)
    sparse(tmp_path / "big.toml", MARK + 1)
    assert not carries_mark(tmp_path / "big.toml")


@pytest.mark.parametrize(
    "first",
    [
        MARK_LINE + b"'s user by hand; keep",
        MARK_LINE + b" ",
        MARK_LINE + b"x",
        b" " + MARK_LINE,
    ],
    ids=["longer", "trailing-space", "one-more-letter", "leading-space"],
)
def test_a_first_line_that_only_begins_with_the_mark_is_not_twolinks(tmp_path, first):
    """`# written by twolink's user by hand; keep`: a prefix match would take the file for
    twolink's and `design --out` would overwrite it."""
    for name, data in (
        ("notes.toml", first + b"\nmine = 1\n"),
        ("rules.toml", RULE_BASE_TITLE + b"\n" + first + b"\nmine = 1\n"),
    ):
        path = tmp_path / name
        path.write_bytes(data)
        assert not carries_mark(path)
        result = invoke("design", "--out", path)
        assert result.exit_code == 2 and "did not write" in result.output, result.output
        assert path.read_bytes() == data
    exact = tmp_path / "exact.toml"
    exact.write_bytes(MARK_LINE + b"\r\nmine = 1\n")
    assert carries_mark(exact)  # the mark itself, with either line ending
