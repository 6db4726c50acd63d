"""Rerun recordings of finished runs: time series, phase plane and the arm moving in 3D.

This package is the only place that imports ``rerun``; everything else imports it lazily,
so runs work without rerun installed. Nothing is logged while a run is computed: a
finished :class:`~twolink.simulation.sim.Trajectory` is sent in columns (``send_columns``) along one
duration timeline, ``"time"`` (seconds). One concern per module:

- :mod:`twolink.tracing.runs`: one run's entities (the list is in its docstring);
- :mod:`twolink.tracing.overview`: the "all runs" overview of several runs;
- :mod:`twolink.tracing.layout`: the blueprint a recording carries;
- :mod:`twolink.tracing.files`: writing ``.rrd`` files atomically, reading them back.

See ``docs/tracing.md``.
"""

from twolink.tracing.files import read_recording, recording_id, write_recording
from twolink.tracing.layout import blueprint, time_panel
from twolink.tracing.overview import GROUP_FAMILIES, OVERVIEW, overview_colors
from twolink.tracing.runs import (
    REFERENCE_COLOR,
    TIMELINE,
    arm_points,
    entity_prefix,
    log_run,
    sample_indices,
)

__all__ = [
    "GROUP_FAMILIES",
    "OVERVIEW",
    "REFERENCE_COLOR",
    "TIMELINE",
    "arm_points",
    "blueprint",
    "entity_prefix",
    "log_run",
    "overview_colors",
    "read_recording",
    "recording_id",
    "sample_indices",
    "time_panel",
    "write_recording",
]
