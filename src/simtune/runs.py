"""Tuning runs: a run folder with its store, configuration and best parameters.

``start_run`` creates the folder and records everything needed to repeat the
run (configuration, versions, command line); ``resume_run`` reads it back and
continues.  ``best_params.json`` is rewritten atomically after every run
session, in the format ``--params-file`` reads.
"""

from __future__ import annotations

import json
import os
import platform
import sys
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

import simtune
from simtune.engines import engine_class
from simtune.errors import SimtuneError
from simtune.objective import Objective, load_references
from simtune.optimize.de import TuneResult, differential_evolution_tune
from simtune.params import get_space
from simtune.progress import TuneProgress
from simtune.store import RunStore
from simtune.tasks import parse_tasks

BEST_PARAMS_FILE = "best_params.json"


@dataclass
class RunConfig:
    engine: str
    tasks: str  # as given: "cube" or "single,cube"
    space: str
    data: str  # folder with one sub-folder of recordings per task
    seed: int = 0
    workers: int = 1
    max_seconds: float | None = None
    max_generations: int = 1000
    only: list[str] | None = None  # tune just these parameters of the space
    eval_timeout: float | None = None  # seconds before a worker's evaluation is abandoned
    prune: bool = True  # stop trials that can no longer beat their parent (same search, less simulation)
    target_fitness: float | None = None  # stop once the best fitness reaches this


def versions(engine: str) -> dict[str, str]:
    import scipy

    return {"simtune": simtune.__version__, engine: engine_class(engine).version(), "numpy": np.__version__,
            "scipy": scipy.__version__, "python": platform.python_version()}


def build_objective(config: RunConfig) -> Objective:
    tasks = parse_tasks(config.tasks)
    space = get_space(config.space, engine_class(config.engine).supported(), config.only)
    return Objective(config.engine, tasks, load_references(Path(config.data), tasks), space)


def write_json_atomic(path: Path, data: dict) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(data, indent=2) + "\n")
    os.replace(tmp, path)


def start_run(config: RunConfig, run_dir: Path, show_progress: bool = True) -> TuneResult:
    """Create ``run_dir`` and tune.  A folder that already holds a run is refused (use resume)."""
    run_dir = Path(run_dir)
    if (run_dir / "run.sqlite").exists():
        raise SimtuneError(f"{run_dir} already holds a run: `simtune resume {run_dir}` continues it")
    objective = build_objective(config)  # checks engine, tasks, space and data before any folder is made
    store = RunStore(run_dir, create=True)
    generic = objective.score({})
    store.set(config=asdict(config), versions=versions(config.engine), command=sys.argv,
              parameters=objective.space.names, bounds=objective.space.bounds,
              generic=generic.to_dict(), status="running", elapsed_s=0.0)
    return _run(objective, config, store, show_progress)


def resume_run(run_dir: Path, show_progress: bool = True) -> TuneResult:
    """Continue the run in ``run_dir`` where it stopped, reusing every stored evaluation."""
    store = RunStore(Path(run_dir))
    stored = store.get("config")
    if stored is None:
        raise SimtuneError(f"{run_dir}: run store has no configuration")
    config = RunConfig(**stored)
    objective = build_objective(config)
    if objective.space.names != store.get("parameters"):
        raise SimtuneError(f"{run_dir}: the stored parameter list differs from this simtune's {config.space!r} space")
    return _run(objective, config, store, show_progress)


def _run(objective: Objective, config: RunConfig, store: RunStore, show_progress: bool) -> TuneResult:
    with TuneProgress(enabled=show_progress, max_seconds=config.max_seconds) as progress:
        result = differential_evolution_tune(
            objective, store, seed=config.seed, workers=config.workers, max_seconds=config.max_seconds,
            max_generations=config.max_generations, elapsed_before=store.get("elapsed_s", 0.0),
            eval_timeout=config.eval_timeout, prune=config.prune, target_fitness=config.target_fitness,
            on_evaluation=progress.evaluation, on_generation=progress.generation,
        )
    generic = store.get("generic")
    write_json_atomic(store.run_dir / BEST_PARAMS_FILE, {
        "engine": config.engine, "tasks": config.tasks, "space": config.space,
        "fitness": result.score.fitness, "wrist_error": result.score.wrist_error,
        "object_error": result.score.object_error, "generic_fitness": generic["fitness"],
        "parameters": list(result.params), "params": result.params,
    })
    store.set(status="finished", message=result.message, best_fitness=result.score.fitness)
    store.close()
    return result
