"""What the whole suite shares: rerun's analytics config and data go to a scratch folder of
this test process, never the user's home.

rerun (its CLI, run by the recording tests as ``python -m rerun rrd verify``) writes its
analytics opt-in to ``$XDG_CONFIG_HOME/rerun/analytics.json`` (else
``~/.config/rerun/analytics.json``) and its event log under ``$XDG_DATA_HOME/rerun``
(else ``~/.local/share/rerun``): the XDG folders are the knobs it honours (there is no
``RERUN_CONFIG_DIR``). A fresh config is a first run, on which rerun sends nothing.
Subprocesses inherit the variables."""

from __future__ import annotations

import os
import shutil
import tempfile

SCRATCH = tempfile.mkdtemp(prefix="twolink-tests-xdg-")
os.environ["XDG_CONFIG_HOME"] = os.path.join(SCRATCH, "config")
os.environ["XDG_DATA_HOME"] = os.path.join(SCRATCH, "data")


def pytest_unconfigure(config) -> None:
    shutil.rmtree(SCRATCH, ignore_errors=True)
