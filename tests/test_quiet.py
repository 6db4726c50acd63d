"""A quiet terminal (issue 46): a task's warnings and C-level stderr are recorded beside
its result, not printed; the report names them, and says nothing where nothing warned."""

import os
import warnings

import numpy as np

from twolink.studies.reproduction.quiet import quietly, warnings_section


def _noisy(x):
    with np.errstate(over="warn"):
        np.float64(1e300) * np.float64(1e300)  # numpy's overflow RuntimeWarning
    os.write(2, b"WARNING: Nan, Inf or huge value in QACC at DOF 8.\n")  # as C code writes
    warnings.warn("a second one", UserWarning, stacklevel=1)
    return x + 1


def test_a_tasks_warnings_and_c_level_stderr_are_recorded_not_printed(capfd):
    result, lines = quietly(_noisy, 1)
    assert result == 2
    assert capfd.readouterr().err == ""  # nothing reached the terminal
    assert lines[0] == "WARNING: Nan, Inf or huge value in QACC at DOF 8."
    assert any(x.startswith("RuntimeWarning: overflow encountered") for x in lines)
    assert any(x.startswith("UserWarning: a second one (test_quiet.py:") for x in lines)
    # and stderr is the terminal again afterwards
    os.write(2, b"after\n")
    assert capfd.readouterr().err == "after\n"


def test_the_section_counts_each_warning_and_names_the_runs_or_says_none():
    section = warnings_section([
        ("flexible_study/", ["W: overflow", "W: overflow", "M: unstable"], []),
        ("runs batch of 105", ["M: unstable"], ["rigid/table2/CTC"]),
        ("quiet batch", [], ["never/shown"]),
    ])  # fmt: skip
    text = "\n".join(section)
    assert "- **flexible_study/**: 3 warnings; runs stopped as diverged: none." in text
    assert "  - 2 × W: overflow" in text and "  - 1 × M: unstable" in text
    assert "runs stopped as diverged: rigid/table2/CTC." in text
    assert "quiet batch" not in text  # a task that warned nothing is not listed
    assert warnings_section([("a", [], [])]) == []  # nothing warned: no section
