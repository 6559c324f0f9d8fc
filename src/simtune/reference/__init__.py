"""Reference recordings shipped with simtune (made by `simtune.reference.make`)."""

from pathlib import Path

REFERENCE_DIR = Path(__file__).parent


def run_demo(*args, **kwargs):
    from simtune.reference.demo import run_demo as _run

    return _run(*args, **kwargs)
