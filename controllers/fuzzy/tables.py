"""The project's standard engines: the heuristic 7x7 fuzzy PD and the paper's Table 1,
both on normalised universes with the seven evenly spaced triangular labels."""

from __future__ import annotations

from twolink.controllers.fuzzy.engine import AndMethod, DefuzzMethod, MamdaniEngine
from twolink.controllers.fuzzy.membership import LABELS_7, triangular_partition
from twolink.controllers.fuzzy.rulebase import RULEBASE_DIR, RuleBase, load_rule_base

__all__ = ["default_fuzzy_pd", "paper_fuzzy_pd"]


def _standard_engine(
    rules: RuleBase,
    and_method: AndMethod,
    defuzz: DefuzzMethod,
    no_fire_output: float,
    n_points: int,
) -> MamdaniEngine:
    var = triangular_partition(LABELS_7, -1.0, 1.0, n_points)
    return MamdaniEngine(var, var, var, rules.rules, and_method, defuzz, no_fire_output)


def default_fuzzy_pd(
    *,
    and_method: AndMethod = "min",
    defuzz: DefuzzMethod = "centroid",
    no_fire_output: float = 0.0,
    n_points: int = 61,
) -> MamdaniEngine:
    """The heuristic 7x7 fuzzy PD engine (``u ~ e + de``) on normalised universes.

    e, de and u live on [-1, 1] with the 7 labels NB..PB as evenly spaced
    triangles (``triangular_partition``); the rules are read from
    ``rulebases/default_7x7.toml`` (the diagonal table of ``pd_rule_table``).

    Parameters
    ----------
    and_method, defuzz, no_fire_output
        See ``MamdaniEngine``.
    n_points : int
        Samples per universe (``n_points - 1`` a multiple of 6).

    Returns
    -------
    MamdaniEngine
    """
    rules = load_rule_base(RULEBASE_DIR / "default_7x7.toml")
    return _standard_engine(rules, and_method, defuzz, no_fire_output, n_points)


def paper_fuzzy_pd(
    *,
    and_method: AndMethod = "min",
    defuzz: DefuzzMethod = "centroid",
    no_fire_output: float = 0.0,
    n_points: int = 61,
) -> MamdaniEngine:
    """The same engine as ``default_fuzzy_pd`` with the paper's Table 1 (5 rules).

    The rules come from ``rulebases/paper_table1.toml``, which stores the
    paper's labels verbatim with ``mirror_inputs = true``: in this project's
    convention they read (NB,NS->NB), (PS,NB->NS), (PS,PS->PM), (PB,PB->PB),
    (NS,PB->NM). Most of the (e, de) plane fires no rule; there the engine
    returns ``no_fire_output``.
    """
    rules = load_rule_base(RULEBASE_DIR / "paper_table1.toml")
    return _standard_engine(rules, and_method, defuzz, no_fire_output, n_points)
