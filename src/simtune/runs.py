"""Tuning runs: a run folder with its store, configuration and best parameters.

``start_run`` creates the folder and records everything needed to repeat the
run (configuration, versions, command line); ``resume_run`` reads it back and
continues: the optimiser (``RunConfig.optimizer``, see
:data:`simtune.optimize.OPTIMIZERS`) replays its search with the same seed,
taking every finished evaluation from the store, then the optional
least-squares refinement (``refine``) does the same.  ``best_params.json`` is rewritten atomically after every run
session, in the format ``--params-file`` reads.
"""

from __future__ import annotations

import json
import os
import platform
import sys
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

import simtune
from simtune.engines import engine_class
from simtune.errors import ConfigError, SimtuneError
from simtune.objective import Objective, load_references
from simtune.optimize import TuneResult, TuneSettings, get_optimizer, least_squares_refine
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
    optimizer: str = "de"  # a key of simtune.optimize.OPTIMIZERS
    refine: bool = False  # polish the best point with least squares on the residuals afterwards
    max_evaluations: int | None = None  # stop once this many evaluations were used (checked per batch)
    #: the seed paper's exact search: SciPy's DE with immediate updating and polish, one worker, no
    #: pruning, and the paper's whole parameter list (parameters the engine lacks kept, without effect)
    paper_exact: bool = False

    def check(self) -> None:
        """One-line ConfigError for settings no optimiser can run with."""
        get_optimizer(self.optimizer)
        if self.paper_exact:
            if self.optimizer != "de":
                raise ConfigError(f"--paper-exact runs differential evolution, not --optimizer {self.optimizer}")
            if self.space not in ("shared", "individual"):
                raise ConfigError(
                    f"--paper-exact needs one of the paper's spaces (shared, individual), not {self.space!r}"
                )
            if self.only:
                raise ConfigError("--paper-exact tunes the paper's whole parameter list: drop --only")
            if self.workers != 1:
                raise ConfigError(
                    "--paper-exact evaluates one trial at a time (SciPy's immediate updating): drop --workers"
                )
            if self.refine:
                raise ConfigError("--paper-exact ends with SciPy's own polish: drop --refine")
        if self.max_evaluations is not None and self.max_evaluations < 1:
            raise ConfigError(f"max_evaluations must be at least 1, got {self.max_evaluations}")
        if self.max_generations < 1:
            raise ConfigError(f"max_generations must be at least 1, got {self.max_generations}")


def versions(engine: str) -> dict[str, str]:
    import scipy

    return {
        "simtune": simtune.__version__,
        engine: engine_class(engine).version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "python": platform.python_version(),
    }


def build_objective(config: RunConfig) -> Objective:
    tasks = parse_tasks(config.tasks)
    # the paper's runs varied every parameter of its list in every engine, whether the engine used it or not
    supported = None if config.paper_exact else engine_class(config.engine).supported()
    space = get_space(config.space, supported, config.only)
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
    config.check()
    objective = build_objective(config)  # checks engine, tasks, space and data before any folder is made
    store = RunStore(run_dir, create=True)
    generic = objective.score({})
    store.set(
        config=asdict(config),
        versions=versions(config.engine),
        command=sys.argv,
        parameters=objective.vector_space().names,
        bounds=objective.vector_space().bounds,
        # in the search vector without effect in this engine (only --paper-exact keeps such parameters)
        inactive_parameters=[
            n for n in objective.vector_space().names if n not in engine_class(config.engine).supported()
        ],
        generic=generic.to_dict(),
        status="running",
        elapsed_s=0.0,
    )
    return _run(objective, config, store, show_progress)


def resume_run(run_dir: Path, show_progress: bool = True) -> TuneResult:
    """Continue the run in ``run_dir`` where it stopped, reusing every stored evaluation."""
    store = RunStore(Path(run_dir))
    stored = store.get("config")
    if stored is None:
        raise SimtuneError(f"{run_dir}: run store has no configuration")
    config = RunConfig(**stored)
    config.check()
    objective = build_objective(config)
    if objective.vector_space().names != store.get("parameters"):
        raise SimtuneError(f"{run_dir}: the stored parameter list differs from this simtune's {config.space!r} space")
    return _run(objective, config, store, show_progress)


def _run(objective: Objective, config: RunConfig, store: RunStore, show_progress: bool) -> TuneResult:
    tune = get_optimizer(config.optimizer)
    max_seconds, target, max_evaluations = config.max_seconds, config.target_fitness, config.max_evaluations
    searched = store.get("search_evaluations")
    elapsed_at_start = store.get("elapsed_s", 0.0)
    if searched is not None:
        # the search finished in an earlier session (a refinement followed): replay it to the same point,
        # whatever the clock says now
        max_seconds, target, max_evaluations = None, None, searched
    with TuneProgress(enabled=show_progress, max_seconds=config.max_seconds) as progress:
        settings = TuneSettings(
            seed=config.seed,
            workers=config.workers,
            max_seconds=max_seconds,
            max_generations=config.max_generations,
            max_evaluations=max_evaluations,
            elapsed_before=store.get("search_elapsed_s", store.get("elapsed_s", 0.0)),
            eval_timeout=config.eval_timeout,
            prune=config.prune and not config.paper_exact,
            paper_exact=config.paper_exact,
            target_fitness=target,
            on_evaluation=progress.evaluation,
            on_generation=progress.generation,
        )
        result = tune(objective, store, settings)
        if searched is None:
            store.set(
                search_evaluations=result.used_evaluations,
                search_elapsed_s=result.wall_s,
                search_message=result.message,
                search_converged=result.converged,
            )
        else:  # the replay stopped on the evaluation count: say why the search stopped first
            result.message = store.get("search_message", result.message)
            result.converged = bool(store.get("search_converged", result.converged))
        if config.refine:
            refined = least_squares_refine(
                objective,
                store,
                result.x,
                replace(settings, elapsed_before=max(result.wall_s, elapsed_at_start)),
                first_generation=result.generations + 1,
            )
            result = _combine(result, refined)
    generic = store.get("generic")
    write_json_atomic(
        store.run_dir / BEST_PARAMS_FILE,
        {
            "engine": config.engine,
            "tasks": config.tasks,
            "space": config.space,
            "fitness": result.score.fitness,
            "wrist_error": result.score.wrist_error,
            "object_error": result.score.object_error,
            "generic_fitness": generic["fitness"],
            "parameters": list(result.params),
            "params": result.params,
        },
    )
    store.set(status="finished", message=result.message, best_fitness=result.score.fitness)
    store.close()
    return result


def _combine(search: TuneResult, refined: TuneResult) -> TuneResult:
    """One result for a search followed by its refinement: the better point by fitness, counts added up."""
    best = refined if refined.fitness < search.fitness else search
    gain = search.fitness - best.fitness
    return TuneResult(
        best.x,
        best.params,
        best.score,
        search.generations + refined.generations,
        refined.evaluations,
        search.new_evaluations + refined.new_evaluations,
        refined.wall_s,
        f"{search.message}; refined by {gain:.4g} ({refined.message})",
        search.converged,
        search.history + refined.history,
        search.pruned_evaluations + refined.pruned_evaluations,
        search.steps + refined.steps,
        search.used_evaluations + refined.used_evaluations,
    )
