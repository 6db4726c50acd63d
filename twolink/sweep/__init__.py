"""Monte Carlo robustness sweeps: many drawn plants, every controller on each, in parallel.

One concern per module:

- :mod:`twolink.sweep.plan`: sweep files (schema, validation, the seeded draws);
- :mod:`twolink.sweep.execution`: chunks on an executor, resume, signals;
- :mod:`twolink.sweep.results`: the results table (a pandas DataFrame, stored as
  Parquet) and its summary;
- :mod:`twolink.sweep.figures`: the sweep's plots;
- :mod:`twolink.sweep.studies`: studies built on sweeps (the flexible-joint study).
- :mod:`twolink.sweep.flexmap`: the flexible-joint stiffness x bandwidth map.

The command (``twolink sweep``) is in :mod:`twolink.interface.cli`; ``docs/sweeps.md`` has the
schema and the output folder.
"""

from twolink.sweep.execution import (
    ChunkResult,
    SweepInterrupted,
    SweepOutcome,
    SweepOutputError,
    SweepTaskError,
    run_chunk,
    run_sweep,
    run_sweeps,
)
from twolink.sweep.figures import save_sweep_plots, sweep_figures
from twolink.sweep.flexmap import (
    disagreements,
    flexible_map_figure,
    flexible_map_table,
    map_cells,
    rigid_reference,
)
from twolink.sweep.plan import DISTRIBUTIONS, PARAMETERS, Parameter, SweepPlan, load_sweep
from twolink.sweep.results import (
    METRIC_COLUMNS,
    SweepMeta,
    format_summary,
    load_results,
    summarize,
    sweep_meta,
)
from twolink.sweep.studies import flexible_study_figure, flexible_study_table

__all__ = [
    "DISTRIBUTIONS",
    "METRIC_COLUMNS",
    "PARAMETERS",
    "ChunkResult",
    "Parameter",
    "SweepInterrupted",
    "SweepMeta",
    "SweepOutcome",
    "SweepOutputError",
    "SweepPlan",
    "SweepTaskError",
    "flexible_map_figure",
    "flexible_map_table",
    "flexible_study_figure",
    "flexible_study_table",
    "format_summary",
    "load_results",
    "load_sweep",
    "disagreements",
    "map_cells",
    "rigid_reference",
    "run_chunk",
    "run_sweep",
    "run_sweeps",
    "save_sweep_plots",
    "summarize",
    "sweep_figures",
    "sweep_meta",
]
