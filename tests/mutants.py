"""Issue 55's mutation re-run: each one-line mutant of twolink/ below is applied to a fresh
copy of HEAD (its named test files as in the working tree), where the unit tests named
beside it must fail; unmutated they must pass, checked first. Prints a markdown table;
exits 1 if any mutant survives.

    .venv/bin/python tests/mutants.py [--only NAME]
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import NamedTuple

REPO = Path(__file__).resolve().parents[1]
PYTHON = REPO / ".venv" / "bin" / "python"
P, V = "tests/test_promises.py::", "tests/test_claims_verdicts.py::"


class Mutant(NamedTuple):
    name: str
    path: str
    old: str
    new: str
    tests: tuple[str, ...]


MUTANTS = [
    Mutant("journal inode check removed", "twolink/foundation/journal.py",
           "return is_kind and entry.inode() == inode", "return is_kind",
           (P + "test_a_journals_temporary_is_removed_only_if_it_is_the_very_file_twolink_made",)),
    Mutant("two-tone share 2 -> 1 where chosen", "twolink/simulation/swings.py",
           "reading[0] >= SLOWER_SHARE * best", "reading[0] >= 1.0 * best",
           (P + "test_a_slower_swing_under_twice_the_faster_one_is_not_the_reading",)),
    Mutant("two-tone SLOWER_SHARE = 1", "twolink/simulation/swings.py",
           "SLOWER_SHARE = 2.0", "SLOWER_SHARE = 1.0",
           (P + "test_a_slower_swing_under_twice_the_faster_one_is_not_the_reading",)),
    Mutant("Tp left out of the lag rule", "twolink/studies/judgments/move_times.py",
           '    "peak_time_s",\n', "",
           (V + "test_an_early_time_on_a_moving_reference_is_worse_not_better[peak_time_s]",
            V + "test_claims_judge_applies_the_distance_rule_the_tables_apply")),
    Mutant("a resend per dropped Ctrl-C", "twolink/foundation/interrupts.py",
           "if _ENDING.is_set() or _RESEND_PENDING.is_set():", "if _ENDING.is_set():",
           (P + "test_several_dropped_ctrl_cs_in_a_row_are_resent_once",)),
    Mutant("SIGTERM not held at the import", "twolink/foundation/interrupts.py",
           "_HELD = (signal.SIGINT, signal.SIGTERM)", "_HELD = (signal.SIGINT,)",
           (P + "test_ctrl_c_and_sigterm_wait_while_mujoco_imports[TERM]",)),
    Mutant("record temporary with 2 links", "twolink/foundation/journal.py",
           "os.read(fd, len(head)) if st.st_nlink == 1 else None", "os.read(fd, len(head))",
           (P + "test_an_owner_records_temporary_with_a_second_name_is_not_twolinks",)),
    Mutant("Bonferroni m counts every row", "twolink/studies/judgments/claims.py",
           "weights=np.asarray(judged, float)", "weights=None",
           (V + "test_the_bonferroni_m_counts_the_rows_whose_typical_plant_is_judged",)),
    Mutant("quorum at exactly half: >= to >", "twolink/studies/judgments/claims.py",
           '2 * c["n"] >= runs', '2 * c["n"] > runs',
           (V + "test_the_typical_plant_is_judged_at_exactly_half_the_plants_not_below",
            "tests/test_claims_words.py::test_the_typical_plant_is_of_at_least_half_the_plants")),
    Mutant("lag rule not on the baseline's side", "twolink/studies/judgments/claims.py",
           "b = np.stack([judged[k][1] for k in keys_], axis=1)",
           "b = np.stack([sides[..., read.index(k)][1] for k in keys_], axis=1)",
           (V + "test_the_distance_to_the_moves_own_is_taken_on_the_baselines_side_too",
            V + "test_a_pure_lag_is_worse_on_tr_not_equal",
            "tests/test_claims_words.py::"
            "test_a_lagging_loop_whose_rise_is_shorter_than_the_moves_is_not_better")),
    Mutant("judged plants against training budget", "twolink/studies/designs/effort.py",
           "judged, budget_judged, tolerance", "judged, budget_train, tolerance",
           ("tests/test_effort_rule.py::"
            "test_each_plant_set_is_judged_against_fcm_ctcs_effort_on_that_set",)),
    Mutant("search: judged loops vs training budget", "twolink/studies/designs/opponent_search.py",
           'found[0]["budget"], fcm_judged[:4])', 'found[0]["budget"], found[0]["budget"])',
           ("tests/test_opponent_search.py::"
            "test_the_search_checks_the_judged_plants_against_fcm_ctcs_effort_there",)),
]  # fmt: skip


def fresh_copy(where: Path, tests: tuple[str, ...]) -> list[str]:
    """HEAD's tracked files, extracted into ``where``, with the working tree's version of
    the test files in ``tests`` (a test written and not committed yet): those that differ."""
    archive = subprocess.run(["git", "-C", str(REPO), "archive", "HEAD"], capture_output=True)
    subprocess.run(["tar", "-x", "-C", str(where)], input=archive.stdout, check=True)
    newer = []
    for name in dict.fromkeys(t.split("::")[0] for t in tests):
        ours, head = REPO / name, where / name
        if not head.exists() or ours.read_bytes() != head.read_bytes():
            shutil.copyfile(ours, head)
            newer.append(name)
    return newer


# An editable install maps twolink.controllers, .runs and .models to the clone's folders:
# in a copy, this sitecustomize points them at the copy's.
HOOK = f"""import sys
for finder in sys.meta_path:
    mapping = getattr(sys.modules.get(finder.__module__), "MAPPING", None)
    if isinstance(mapping, dict):
        for name, path in list(mapping.items()):
            mapping[name] = path.replace({str(REPO)!r}, {{root!r}}, 1)
"""


def hooked(root: Path) -> dict:
    """The environment that runs python in ``root`` on the copy's packages only."""
    hook = root / ".mutants_hook"
    hook.mkdir()
    (hook / "sitecustomize.py").write_text(HOOK.format(root=str(root)))
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    return {**env, "PYTHONPATH": f"{hook}{os.pathsep}{root}"}


def mutate(root: Path, m: Mutant) -> int:
    """Apply ``m`` in ``root``; the line of HEAD it changes."""
    file = root / m.path
    text = file.read_text()
    count = text.count(m.old)
    if count != 1:
        sys.exit(f"{m.name}: the old text occurs {count} times in {m.path}, not once")
    file.write_text(text.replace(m.old, m.new))
    return text[: text.index(m.old)].count("\n") + 1


def imported(root: Path, env: dict) -> str:
    """The folder ``import twolink`` and ``twolink.controllers`` load from, run in ``root``
    (their common path)."""
    code = (
        "import os, twolink, twolink.controllers as c\n"
        "print(os.path.commonpath([twolink.__file__, c.__file__]))"
    )
    out = subprocess.run([PYTHON, "-c", code], cwd=root, env=env, capture_output=True, text=True)
    return out.stdout.strip()


def run_tests(root: Path, tests: tuple[str, ...], env: dict) -> tuple[int, list[str]]:
    """pytest's exit code on ``tests`` in ``root`` and the node ids that failed."""
    cmd = [PYTHON, "-m", "pytest", "-n", "0", "-p", "no:cacheprovider", "-q", *tests]
    out = subprocess.run(cmd, cwd=root, env=env, capture_output=True, text=True)
    return out.returncode, re.findall(r"^FAILED (\S+?)(?: - |$)", out.stdout, re.M)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", metavar="NAME", help="run the one mutant of this name")
    args = parser.parse_args()
    mutants = [m for m in MUTANTS if args.only in (None, m.name)]
    if not mutants:
        parser.error(f"no mutant {args.only!r}; the names: {[m.name for m in MUTANTS]}")
    start = time.monotonic()
    every = tuple(dict.fromkeys(t for m in mutants for t in m.tests))
    with tempfile.TemporaryDirectory(prefix="twolink-mutant-") as tmp:
        root = Path(tmp)
        newer = fresh_copy(root, every)
        env = hooked(root)
        where = imported(root, env)
        if where != str(root):
            sys.exit(f"import twolink in {root} loads from {where!r}, not the copy there")
        code, failed = run_tests(root, every, env)
        if code != 0:
            sys.exit(f"HEAD itself fails (exit {code}): {failed or 'see pytest'}; no table")
    rows, survivors = [], 0
    for m in mutants:
        with tempfile.TemporaryDirectory(prefix="twolink-mutant-") as tmp:
            root = Path(tmp)
            fresh_copy(root, m.tests)
            line = mutate(root, m)
            code, failed = run_tests(root, m.tests, hooked(root))
        killed = code == 1 and bool(failed)  # 1: tests failed (2-5: an error, no verdict)
        survivors += not killed
        result = "killed" if killed else "survived" if code == 0 else f"error (exit {code})"
        by = "<br>".join(f.removeprefix("tests/") for f in failed) or "—"
        rows.append(f"| {m.name} | {m.path}:{line} | {by} | {result} |")
    print(f"`import twolink` and `twolink.controllers` in a copy load the copy's ({where}).")
    print(f"Unmutated, the {len(every)} tests below pass there.")
    if newer:
        print(f"Test files taken from the working tree (they differ from HEAD): {newer}")
    print()
    print("| mutant | file:line | killed by (test id) | result |\n|---|---|---|---|")
    print("\n".join(rows))
    print(f"\n{len(mutants) - survivors} of {len(mutants)} killed "
          f"in {time.monotonic() - start:.0f} s")  # fmt: skip
    return 1 if survivors else 0


if __name__ == "__main__":
    sys.exit(main())
