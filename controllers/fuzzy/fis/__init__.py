"""MATLAB Fuzzy Logic Toolbox files (``.fis``), in one home: read any file and evaluate it
(:func:`read_fis`, :class:`Fis`), write twolink's engine as one (:func:`write_fis`).

- :mod:`~twolink.controllers.fuzzy.fis.sections`: the file's text as sections (both readers);
- :mod:`~twolink.controllers.fuzzy.fis.matlab`: any Mamdani or Sugeno file, read and evaluated;
- :mod:`~twolink.controllers.fuzzy.fis.exact`: a Mamdani output defuzzified exactly or sampled;
- :mod:`~twolink.controllers.fuzzy.fis.bound`: the lookup table's proven error bound for a file;
- :mod:`~twolink.controllers.fuzzy.fis.engine_files`: twolink's own engine to and from a file.
"""

from twolink.controllers.fuzzy.fis.engine_files import (
    read_engine,
    read_rule_base,
    to_fis,
    write_fis,
    written_by_twolink,
)
from twolink.controllers.fuzzy.fis.matlab import Fis, FisTerm, parse_matlab_fis, read_fis

__all__ = [
    "Fis",
    "FisTerm",
    "parse_matlab_fis",
    "read_engine",
    "read_fis",
    "read_rule_base",
    "to_fis",
    "write_fis",
    "written_by_twolink",
]
