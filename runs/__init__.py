"""The shipped scenarios, sweeps and studies: package data, installed as ``twolink.runs``
(pyproject.toml) and read through importlib.resources (twolink/foundation/shipped.py).
A file here is named by its path without the extension: ``twolink run paper/theta1_step``."""
