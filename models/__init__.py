"""The shipped MJCF files (``twolink models --install`` writes them): package data,
installed as ``twolink.models`` (pyproject.toml, twolink/foundation/shipped.py)."""
