"""Fuzzy logic for the controllers: a vectorised Mamdani engine exact against
scikit-fuzzy, rule bases as data, and the project's standard engines.

- :mod:`controllers.fuzzy.membership`: labels, membership functions, variables;
- :mod:`controllers.fuzzy.rulebase`: rules and rule-base files (TOML);
- :mod:`controllers.fuzzy.engine`: the Mamdani engine (and the labels of fired rules);
- :mod:`controllers.fuzzy.tables`: ``default_fuzzy_pd`` (7x7) and ``paper_fuzzy_pd``.

Everything public is importable from ``controllers.fuzzy`` itself.
"""

from twolink.controllers.fuzzy.coverage import uncovered_fraction
from twolink.controllers.fuzzy.engine import (
    MamdaniEngine,
    fired_rule_labels,
    rule_label,
)
from twolink.controllers.fuzzy.membership import (
    LABELS_7,
    MIRROR_LABELS,
    FuzzyVariable,
    MembershipFunction,
    triangular_partition,
)
from twolink.controllers.fuzzy.rulebase import (
    RULEBASE_DIR,
    Rule,
    RuleBase,
    load_rule_base,
    pd_rule_table,
    save_rule_base,
)
from twolink.controllers.fuzzy.tables import default_fuzzy_pd, paper_fuzzy_pd

__all__ = [
    "LABELS_7",
    "MIRROR_LABELS",
    "RULEBASE_DIR",
    "FuzzyVariable",
    "MamdaniEngine",
    "MembershipFunction",
    "Rule",
    "RuleBase",
    "default_fuzzy_pd",
    "fired_rule_labels",
    "load_rule_base",
    "paper_fuzzy_pd",
    "pd_rule_table",
    "rule_label",
    "save_rule_base",
    "triangular_partition",
    "uncovered_fraction",
]
