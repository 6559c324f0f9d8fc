"""Differential evolution as in the seed paper, on SciPy's implementation.

best1bin, crossover 0.7, mutation dithered in [0.5, 1.0], population 1 x D,
latin-hypercube start; stop when the population's fitness spread falls below
1 % of its mean, after ``max_generations``, or when ``max_seconds`` have passed.

The population is always updated once per generation ("deferred"), whether
one process evaluates it or many: the same seed then gives the same run with
any number of workers.  Evaluations go through :class:`Evaluator`, which takes
finished ones from the run store and commits new ones as they finish.
"""

from __future__ import annotations

import multiprocessing
import time
from collections.abc import Callable
from concurrent.futures import TimeoutError as FutureTimeout
from concurrent.futures import as_completed
from dataclasses import dataclass, field

import numpy as np
from pebble import ProcessExpired, ProcessPool
from scipy.optimize import differential_evolution

from simtune.errors import SimtuneError
from simtune.fitness import PENALTY, Score, TaskScore
from simtune.objective import Objective
from simtune.store import RunStore

DE_SETTINGS = dict(strategy="best1bin", recombination=0.7, mutation=(0.5, 1.0), popsize=1,
                   init="latinhypercube", tol=0.01, atol=0.0, polish=False, updating="deferred")


@dataclass
class TuneResult:
    """The outcome of a tuning run, in the spirit of SciPy's ``OptimizeResult``."""

    x: np.ndarray
    params: dict[str, float]
    score: Score
    generations: int
    evaluations: int  # evaluations in the store (all sessions of this run)
    new_evaluations: int  # evaluations simulated in this session
    wall_s: float  # elapsed over all sessions of this run
    message: str
    converged: bool
    history: list[float] = field(default_factory=list)  # best fitness per generation
    pruned_evaluations: int = 0  # evaluations of this session stopped early (could not beat their parent)
    steps: int = 0  # physics steps simulated in this session

    @property
    def fitness(self) -> float:
        return self.score.fitness


# --- worker processes ---------------------------------------------------------------------
_WORKER_OBJECTIVE: Objective | None = None


def _init_worker(objective: Objective) -> None:
    global _WORKER_OBJECTIVE
    _WORKER_OBJECTIVE = objective


def _evaluate_in_worker(x: np.ndarray, bound: float | None) -> tuple[dict, float]:
    t0 = time.perf_counter()
    score = _WORKER_OBJECTIVE.score_vector(x, bound)
    return score.to_dict(), time.perf_counter() - t0


def failed_score(reason: str) -> Score:
    """The score recorded for an evaluation whose worker crashed or hung: a flagged penalty."""
    return Score(PENALTY, PENALTY, None, [TaskScore("all", PENALTY, PENALTY, None, False, reason)])


class Evaluator:
    """A map-like callable for SciPy: scores a batch of vectors, from the store or by simulating.

    ``workers`` > 1 evaluates in that many processes, each building its
    engines once.  In worker processes an evaluation that crashes its process
    (a segfault inside an engine) or runs past ``eval_timeout`` seconds costs
    only itself: the worker is replaced, the evaluation is stored as failed with
    a penalty fitness, and the run goes on.  ``on_evaluation(score, reused)`` is
    called for every result (for progress display).
    """

    def __init__(self, objective: Objective, store: RunStore, workers: int = 1,
                 on_evaluation: Callable[[Score, bool], None] | None = None, eval_timeout: float | None = None,
                 prune: bool = True):
        self.objective = objective
        self.store = store
        self.workers = max(1, int(workers))
        self.on_evaluation = on_evaluation
        self.eval_timeout = eval_timeout
        self.generation = 0
        self.new_evaluations = 0
        self.failed_evaluations = 0
        self.pruned_evaluations = 0
        self.steps = 0
        #: fitness of each trial's parent, in SciPy's population order (None: no pruning)
        self.parent_energies: np.ndarray | None = None
        self.prune = prune
        self._pool: ProcessPool | None = None

    def __enter__(self) -> "Evaluator":
        if self.workers > 1:
            # spawn: engines hold native handles that must not be shared through fork
            self._pool = ProcessPool(self.workers, initializer=_init_worker, initargs=(self.objective,),
                                     context=multiprocessing.get_context("spawn"))
        return self

    def __exit__(self, *exc) -> None:
        if self._pool is not None:
            self._pool.stop()
            self._pool.join()
            self._pool = None
        self.objective.close()

    def _failed(self, reason: str) -> Score:
        self.failed_evaluations += 1
        self._batch_failures.append(reason)
        return failed_score(reason)

    def _finish(self, x, score: Score, wall_s: float) -> float:
        self.store.record_evaluation(x, score, self.generation, wall_s)
        self.new_evaluations += 1
        self.pruned_evaluations += score.pruned
        self.steps += sum(t.steps for t in score.tasks)
        if self.on_evaluation:
            self.on_evaluation(score, False)
        return score.fitness

    def __call__(self, func, vectors) -> list[float]:
        vectors = [np.asarray(x, dtype=float) for x in vectors]
        fitness: list[float | None] = [None] * len(vectors)
        self._batch_failures: list[str] = []
        parents = self.parent_energies
        bounds = [None] * len(vectors)
        if self.prune and parents is not None and len(parents) == len(vectors):
            bounds = [float(e) for e in parents]  # trial i competes with population member i
        todo = []
        for i, x in enumerate(vectors):
            known = self.store.lookup(x)
            if known is not None:
                fitness[i] = known.fitness
                if self.on_evaluation:
                    self.on_evaluation(known, True)
            else:
                todo.append(i)
        if self._pool is None:
            for i in todo:
                t0 = time.perf_counter()
                try:
                    score = self.objective.score_vector(vectors[i], bounds[i])
                except SimtuneError:
                    raise
                except Exception as exc:  # an engine error at a corner of the space costs this evaluation only
                    score = self._failed(f"{type(exc).__name__}: {exc}")
                fitness[i] = self._finish(vectors[i], score, time.perf_counter() - t0)
        else:
            futures = {self._pool.schedule(_evaluate_in_worker, (vectors[i], bounds[i]),
                                           timeout=self.eval_timeout): i for i in todo}
            started = time.perf_counter()
            for future in as_completed(futures):
                i = futures[future]
                wall_s = time.perf_counter() - started
                try:
                    score_dict, wall_s = future.result()
                    score = Score.from_dict(score_dict)
                except FutureTimeout:
                    score = self._failed(f"evaluation ran past {self.eval_timeout:g} s; worker replaced")
                except ProcessExpired as exc:
                    score = self._failed(f"worker process died (exit code {exc.exitcode}); worker replaced")
                except SimtuneError:
                    raise
                except Exception as exc:
                    score = self._failed(f"{type(exc).__name__}: {exc}")
                fitness[i] = self._finish(vectors[i], score, wall_s)
        if todo and len(self._batch_failures) == len(todo):
            # nothing could be simulated at all: a broken set-up, not a corner of the space
            raise SimtuneError(f"every evaluation of generation {self.generation} failed: {self._batch_failures[0]}")
        if self.generation == 0:
            # the initial population: SciPy then swaps its best member to the front
            energies = np.array(fitness, dtype=float)
            best = int(np.argmin(energies))
            energies[[0, best]] = energies[[best, 0]]
            self.parent_energies = energies
        self.generation += 1
        return fitness  # type: ignore[return-value]


def differential_evolution_tune(
    objective: Objective,
    store: RunStore,
    *,
    seed: int = 0,
    workers: int = 1,
    max_seconds: float | None = None,
    max_generations: int = 1000,
    elapsed_before: float = 0.0,
    eval_timeout: float | None = None,
    prune: bool = True,
    target_fitness: float | None = None,
    on_evaluation: Callable[[Score, bool], None] | None = None,
    on_generation: Callable[[int, float], None] | None = None,
) -> TuneResult:
    """Tune ``objective`` over its parameter space; every evaluation lands in ``store``.

    ``elapsed_before`` is the wall time earlier sessions of the same run spent
    (it counts against ``max_seconds`` when a run is resumed).
    """
    space = objective.space
    start = time.perf_counter()
    history: list[float] = []
    stop_reason: str | None = None

    def elapsed() -> float:
        return elapsed_before + time.perf_counter() - start

    def checkpoint(intermediate_result) -> bool:
        generation = len(history) + 1
        history.append(float(intermediate_result.fun))
        evaluator.parent_energies = np.array(intermediate_result.population_energies, dtype=float)
        store.record_generation(generation, intermediate_result.population, intermediate_result.population_energies,
                                intermediate_result.x, intermediate_result.fun, store.count_evaluations(), elapsed())
        store.set(elapsed_s=elapsed())
        if on_generation:
            on_generation(generation, float(intermediate_result.fun))
        nonlocal stop_reason
        if max_seconds is not None and elapsed() >= max_seconds:
            stop_reason = f"stopped after {max_seconds:g} s"
        elif target_fitness is not None and intermediate_result.fun <= target_fitness:
            stop_reason = f"reached the target fitness {target_fitness:g}"
        return stop_reason is not None

    evaluator = Evaluator(objective, store, workers, on_evaluation, eval_timeout, prune)
    with evaluator:
        result = differential_evolution(
            lambda x: objective.score_vector(x).fitness,  # never called: the Evaluator does the work
            bounds=space.bounds, maxiter=max_generations, rng=np.random.default_rng(seed),
            workers=evaluator, callback=checkpoint, **DE_SETTINGS,
        )
        best_x = np.asarray(result.x, dtype=float)
        best = store.lookup(best_x) or objective.score_vector(best_x)
    message = stop_reason or result.message
    converged = stop_reason is None and bool(result.success)
    return TuneResult(best_x, space.to_dict(best_x), best, len(history), store.count_evaluations(), evaluator.new_evaluations,
                      elapsed(), message, converged, history, evaluator.pruned_evaluations, evaluator.steps)
