"""What the benchmark scripts share: the qrg2019 data path, their argument parsers, a tuned run's best
point, and result files dated in benchmarks/results/.

The scripts run as ``python benchmarks/NAME.py``, so this folder is first on ``sys.path`` and they import
this module as ``common``.
"""

from __future__ import annotations

import argparse
import datetime
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

from simtune.objective import Objective
from simtune.runs import RunConfig, resume_run, start_run
from simtune.tasks import parse_tasks
from simtune.tasks.spec import TaskSpec

#: the real qrg2019 motion-capture recordings, one folder per task, in ../shared beside the checkout
#: (the README says where the public data set comes from); ``--data`` names another copy
QRG2019_DATA = Path(__file__).resolve().parents[2] / "shared/datasets/qrg2019/mocap"
#: where the scripts that write their results keep them, each file named ``<name>-<date>.<suffix>``
RESULTS_DIR = Path(__file__).resolve().parent / "results"


def make_parser(doc: str | None, *, whole_doc: bool = False) -> argparse.ArgumentParser:
    """The script's parser, described by its docstring: the first line, or the whole of it as written."""
    text = doc or ""
    if whole_doc:
        return argparse.ArgumentParser(description=text, formatter_class=argparse.RawDescriptionHelpFormatter)
    return argparse.ArgumentParser(description=text.splitlines()[0] if text else None)


def add_data_option(
    parser: argparse.ArgumentParser, default: Path | None = QRG2019_DATA, help: str | None = None
) -> None:
    """``--data ROOT``: the recordings' root (default: the qrg2019 recordings in ../shared)."""
    parser.add_argument("--data", type=Path, default=default, help=help or f"the recordings' root (default: {default})")


def add_engines_option(parser: argparse.ArgumentParser, default: str) -> None:
    """``--engines E1,E2``: the engines to measure, joined by commas."""
    parser.add_argument("--engines", default=default, help=f"engines joined by commas (default: {default})")


def add_results_option(parser: argparse.ArgumentParser) -> None:
    """``--results DIR``: where the dated result files go (default: benchmarks/results)."""
    parser.add_argument("--results", type=Path, default=RESULTS_DIR, help="folder of the result files")


def add_search_options(parser: argparse.ArgumentParser, budget_evals: int) -> None:
    """The recovery benchmarks' search: ``--optimizer``, ``--budget-evals``, ``--workers``, ``--no-refine``."""
    parser.add_argument("--optimizer", default="cmaes")
    parser.add_argument("--budget-evals", type=int, default=budget_evals)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--no-refine", action="store_true", help="skip the least-squares refinement")


def middle_batch(data: Path | str, task: str, space: str, n: int) -> tuple[Objective, Any]:
    """MuJoCo's objective on the recordings of ``task`` under ``data``, tuning ``space``, and ``n`` random vectors
    (rows of an array) of the middle of that space (each value in the middle 40 % of its range, seed 0): stable
    simulations with differing masses and time steps, as a DE population has."""
    import numpy as np

    from simtune.engines import engine_class
    from simtune.objective import load_references
    from simtune.params import get_space
    from simtune.tasks import get_task

    spec = get_task(task)
    tuned = get_space(space, engine_class("mujoco").supported())
    objective = Objective("mujoco", [spec], load_references(data, [spec]), tuned)
    lo, hi = np.array(tuned.bounds).T
    points = lo + (0.3 + 0.4 * np.random.default_rng(0).random((n, len(lo)))) * (hi - lo)
    return objective, points


def start_or_resume(config: RunConfig, run_dir: Path) -> Any:
    """Run ``config`` in ``run_dir``; a run an earlier call left there (same ``--out``) is replayed or finished."""
    if (run_dir / "run.sqlite").exists():
        return resume_run(run_dir, show_progress=False)
    return start_run(config, run_dir, show_progress=False)


class Transcript:
    """A benchmark's output lines: printed as they come, and appended to ``out`` (``--out FILE``) at the end."""

    def __init__(self, out: Path | None):
        self.out = out
        self.lines: list[str] = []

    def say(self, line: str) -> None:
        print(line, flush=True)
        self.lines.append(line)

    def save(self) -> None:
        """Append the lines said to ``out`` (nothing without one)."""
        if self.out:
            with open(self.out, "a") as fh:
                fh.write("\n".join(self.lines) + "\n")


def today() -> str:
    """The date that names a result file (ISO, local)."""
    return datetime.date.today().isoformat()


def write_result(results: Path, name: str, suffix: str, text: str) -> Path:
    """Write ``results/<name>-<today>.<suffix>`` (the folder made when missing); returns its path."""
    results.mkdir(parents=True, exist_ok=True)
    path = results / f"{name}-{today()}.{suffix}"
    path.write_text(text)
    return path


def write_json_result(results: Path, name: str, value: Any, indent: int = 2, newline: bool = True) -> Path:
    """:func:`write_result` of a JSON document (values JSON cannot hold written with ``str``)."""
    return write_result(
        results, name, "json", json.dumps(value, indent=indent, default=str) + ("\n" if newline else "")
    )


def load_best(run: Path) -> tuple[dict[str, Any], TaskSpec]:
    """A one-task run's ``best_params.json`` (its engine, tasks, space and params) and its task."""
    best = json.loads((run / "best_params.json").read_text())
    (task,) = parse_tasks(best["tasks"])
    return best, task


def simtune(*args: object) -> str:
    """Run one simtune command in a new process; its standard output (stops the benchmark on failure)."""
    command = [sys.executable, "-m", "simtune.cli", *map(str, args)]
    result = subprocess.run(command, check=False, capture_output=True, text=True)
    if result.returncode != 0:
        sys.exit(f"failed: simtune {' '.join(map(str, args))}\n{result.stderr}")
    return result.stdout


def last_json(text: str) -> dict:
    """The JSON object a --json command printed (the last line starting with '{')."""
    return json.loads(next(line for line in reversed(text.splitlines()) if line.startswith("{")))
