"""``python -m twolink``: the same command line as ``twolink``."""

from twolink.interface.cli import main

main(prog_name="twolink")
