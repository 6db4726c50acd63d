"""``python -m twolink``: the same command line as ``twolink``."""

from twolink.interface.entry import run

run()
