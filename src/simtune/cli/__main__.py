"""``python -m simtune.cli``: the command line."""

from simtune.cli import main

main()
