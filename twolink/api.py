"""Every command as one call: the library's side of ``twolink design``, ``twolink sweep``
and ``twolink reproduce``, and the rule bases by name (all re-exported by ``twolink``).

Each function writes only where it is told (``out``), under the same rules as the
command line (docs/reliability.md): a folder it did not write is refused.

>>> import twolink
>>> rules = twolink.load_rule_base("designed")
>>> len(rules.rules), rules.rules[0]
(5, Rule(e='NM', de='PS', u='NS'))
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import pandas as pd

    from twolink.controllers.fuzzy.rulebase import RuleBase
    from twolink.studies.designs.design import DesignResult

__all__ = ["design_rule_base", "load_rule_base", "run_sweep"]


def load_rule_base(name: str | Path = "designed") -> RuleBase:
    """A rule base by name ("designed", "paper", "default") or from a rule-base TOML or a
    MATLAB ``.fis`` file; ``MamdaniEngine.with_rules`` (or
    ``twolink.controllers.fuzzy.default_fuzzy_pd().with_rules``) makes it an engine."""
    from twolink.controllers.fuzzy.fis.engine_files import read_rule_base
    from twolink.controllers.fuzzy.rulebase import missing_rule_base, resolve_rule_base

    path = resolve_rule_base(str(name))
    if not path.exists():  # a misspelt name ("desigend") is no file either
        raise FileNotFoundError(missing_rule_base(str(name), path))
    return read_rule_base(path)


def design_rule_base(
    config: str | Path | None = None, out: str | Path | None = None
) -> DesignResult:
    """The paper's FCM design (section 3.1, steps 1-6) from a design file (default
    ``runs/paper/design.toml``): ``result.rules`` is the rule base, the rest its evidence.
    With ``out``, the folder ``twolink design`` writes (``rule_base.toml``, evidence,
    ``design.md``), reused when its inputs are unchanged.

    >>> import twolink
    >>> result = twolink.design_rule_base()  # doctest: +SKIP
    >>> [f"{r.e},{r.de}->{r.u}" for r in result.rules]  # doctest: +SKIP
    ['NM,PS->NS', 'NS,PS->Z', 'Z,Z->Z', 'PS,NS->Z', 'PM,NS->PS']
    """
    from twolink.foundation.io import check_output_folder, owned_output
    from twolink.studies.designs.design import (
        DEFAULT_DESIGN,
        design,
        design_or_load,
        load_design_config,
    )

    settings = load_design_config(config or DEFAULT_DESIGN)
    if out is None:
        return design(settings)
    # the command line's rules: a folder of the user's files, a link, is refused
    check_output_folder(out)
    with owned_output(out, "design", str(Path(config or DEFAULT_DESIGN).resolve())):
        return design_or_load(settings, out)[0]


def run_sweep(
    sweep_file: str | Path,
    out: str | Path,
    *,
    samples: int | None = None,
    workers: int | None = None,
    overrides: dict[str, Any] | None = None,
    progress: bool = False,
    plots: bool = False,
    backend: str = "cpu",
) -> pd.DataFrame:
    """Run a sweep file (``twolink sweep FILE --out OUT``) on a process pool of
    ``workers`` (default: all cores; 1: in this process) and return its results table
    (one row per plant and controller; columns in docs/sweeps.md). Chunks already in
    ``out`` are reused. With a pool, a script needs Python's ``if __name__ ==
    "__main__":`` guard, as for any process pool. ``backend="mjx"`` (or "mjx-float32")
    runs it on MuJoCo's accelerator backend in this process (docs/batch.md).

    >>> import twolink
    >>> table = twolink.run_sweep("runs/sweeps/robustness.toml", "/tmp/sweep", samples=4)
    ... # doctest: +SKIP
    >>> sorted(set(table["controller"]))  # doctest: +SKIP
    ['CTC', 'CTC-I', 'FCM-CTC', 'FCM-CTC-continuous', 'PD-G']
    """
    from twolink import sweep

    more = dict(overrides or {})
    if samples is not None:
        more["samples"] = samples
    plan = sweep.load_sweep(sweep_file, more or None)
    # one worker: in this process (no pool, so a plain script needs no __main__ guard)
    executor = "inprocess" if workers == 1 else "process"
    outcome = sweep.run_sweep(
        plan,
        out,
        executor=executor,
        workers=workers,
        progress=progress,
        plots=plots,
        backend=backend,
    )
    return outcome.results
