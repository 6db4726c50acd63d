"""Temporaries removed only when twolink made them, and a killed command's folder its own
(issue 49). Each case failed on main before: a planted ``tmp NAME`` journal line had the
next command remove the user's ``.mydata.old/`` (exit 0), and a killed reproduction's
folder was taken over by ``sweep`` (exit 0)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from cli_inputs import SWEEP, invoke, one_error_line

from twolink.foundation.io import JOURNAL_NAME, ForeignOutput, atomic_path, owned_output
from twolink.foundation.ownership import OWNER_NAME, check_ownership, read_journal


def owned_folder(out: Path, command: str = "demo") -> None:
    """A folder a finished twolink command wrote one file into."""
    with owned_output(out, command), atomic_path(out / "result.txt") as tmp:
        tmp.write_text("twolink's\n")


def users_folder(out: Path) -> Path:
    folder = out / ".mydata.old"
    folder.mkdir()
    (folder / "thesis.tex").write_text("years of work\n")
    return folder


def test_a_planted_tmp_line_removes_nothing_of_the_users(tmp_path):
    out = tmp_path / "out"
    owned_folder(out)
    users = users_folder(out)
    (out / JOURNAL_NAME).write_text("tmp .mydata.old\ntmp file 1 .mydata.old\n")
    with pytest.raises(ForeignOutput, match=r"\.mydata\.old/thesis\.tex"):
        check_ownership(out, "demo")
    with pytest.raises(ForeignOutput), owned_output(out, "demo"):
        pass
    assert (users / "thesis.tex").read_text() == "years of work\n"


def test_a_journal_line_naming_the_users_inode_under_a_generated_name_is_kept_apart(
    tmp_path,
):
    """Only the very entry twolink made (kind and inode) goes, and only under a name
    twolink generates: a user's folder named like a temporary, listed as a file, or with
    another inode, stays; an empty user folder (nothing to refuse) stays too."""
    out = tmp_path / "out"
    owned_folder(out)
    users = users_folder(out)
    empty = out / ".notes.abcdefgh.tmp"
    empty.mkdir()
    ino = empty.stat().st_ino
    (out / JOURNAL_NAME).write_text(
        f"tmp dir {users.stat().st_ino} .mydata.old\n"  # not a name twolink makes
        f"tmp file {ino} .notes.abcdefgh.tmp\n"  # a folder, listed as a file
    )
    with pytest.raises(ForeignOutput, match=r"\.mydata\.old/thesis\.tex"):
        check_ownership(out, "demo")
    (users / "thesis.tex").unlink()
    users.rmdir()
    with owned_output(out, "demo"):
        pass
    assert empty.is_dir()


def test_a_killed_commands_temporaries_are_listed_exactly_and_removed(tmp_path):
    out = tmp_path / "out"
    code = (
        "import os; from twolink.foundation.io import atomic_path, owned_output, scratch_folder\n"
        f"with owned_output({str(out)!r}, 'demo'):\n"
        f"    with scratch_folder({str(out / 'runs')!r}) as scratch, "
        f"atomic_path({str(out / 'big.bin')!r}) as tmp:\n"
        "        (scratch / 'a.npz').write_bytes(b'1')\n"
        "        open(tmp, 'wb').write(b'x' * 1000); os.kill(os.getpid(), 9)\n"
    )
    subprocess.run([sys.executable, "-c", code], check=False)
    _, temporaries = read_journal(out)
    kinds = sorted(kind for kind, _ in temporaries.values())
    assert kinds == ["dir", "file"]
    for name, (_, inode) in temporaries.items():
        assert (out / name).stat().st_ino == inode
    with owned_output(out, "demo"):
        pass
    assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]


def test_an_owner_records_own_temporary_is_recognised(tmp_path):
    """A command killed while writing the record leaves '..twolink-owner.json.PID.tmp':
    the next command removes it; a user's file of that name is not taken for one."""
    out = tmp_path / "out"
    owned_folder(out)
    killed = out / f".{OWNER_NAME}.4242.tmp"
    killed.write_text('{\n "kind": "twolink owner')  # cut short where it was killed
    check_ownership(out, "demo")
    with owned_output(out, "demo"):
        pass
    assert not killed.exists()
    users = out / f".{OWNER_NAME}.4243.tmp"
    users.write_text("my notes\n")
    with pytest.raises(ForeignOutput, match="4243"):
        check_ownership(out, "demo")
    assert users.read_text() == "my notes\n"


def test_a_killed_reproductions_folder_is_not_taken_over_by_sweep(tmp_path):
    out = tmp_path / "out"
    code = (
        "import os; from twolink.foundation.io import atomic_path, owned_output\n"
        f"with owned_output({str(out)!r}, 'reproduce'):\n"
        f"    with atomic_path({str(out / 'report.md')!r}) as tmp:\n"
        "        tmp.write_text('half a report')\n"
        "    os.kill(os.getpid(), 9)\n"
    )
    subprocess.run([sys.executable, "-c", code], check=False)
    sweep_file = tmp_path / "tiny.toml"
    sweep_file.write_text(SWEEP)
    before = sorted(os.listdir(out))
    result = invoke("sweep", sweep_file, "--no-plots", "--out", out)
    assert result.exit_code == 2, result.output
    one_error_line(result)
    assert "twolink reproduce" in result.output and "stopped" in result.output
    assert sorted(os.listdir(out)) == before
    # the same command may finish it
    check_ownership(out, "reproduce")
