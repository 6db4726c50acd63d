"""``python -m twolink``: the same command line as ``twolink``."""

from twolink.cli import main

main(prog_name="twolink")
