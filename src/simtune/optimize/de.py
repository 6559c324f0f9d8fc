"""Differential evolution as in the seed paper, on SciPy's implementation.

best1bin, crossover 0.7, mutation dithered in [0.5, 1.0], population 1 x D,
latin-hypercube start; stop when the population's fitness spread falls below
1 % of its mean, or when a budget of the settings is spent (checked after
each generation: a generation is never cut short, so ``max_evaluations`` can
be overshot by up to one generation of D evaluations).

The population is always updated once per generation ("deferred"), whether
one process evaluates it or many: the same seed then gives the same run with
any number of workers.  SciPy calls the Evaluator as its ``workers`` map, with
each trial's parent fitness known, so a trial that can no longer beat its
parent is stopped early (pruning) without changing the search.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import differential_evolution

from simtune.objective import Objective
from simtune.optimize.base import BatchSearch
from simtune.optimize.evaluator import TuneResult, TuneSettings
from simtune.store import RunStore

DE_SETTINGS = dict(
    strategy="best1bin",
    recombination=0.7,
    mutation=(0.5, 1.0),
    popsize=1,
    init="latinhypercube",
    tol=0.01,
    atol=0.0,
    polish=False,
    updating="deferred",
)


def differential_evolution_tune(objective: Objective, store: RunStore, settings: TuneSettings) -> TuneResult:
    """Tune ``objective`` over its parameter space; every evaluation lands in ``store``."""
    search = BatchSearch(objective, store, settings, prune=True)
    evaluator = search.evaluator
    evaluator.generation = 0  # the initial population is generation 0; the first checkpoint follows generation 1

    def checkpoint(intermediate_result) -> bool:
        population = intermediate_result.population
        energies = np.array(intermediate_result.population_energies, dtype=float)
        evaluator.parent_energies = energies
        search.track(population, energies)
        return search.checkpoint(population, energies)

    start = search.starting_points()
    with search:
        result = differential_evolution(
            lambda x: objective.score_vector(x).fitness,  # never called: the Evaluator does the work
            bounds=search.space.bounds,
            maxiter=settings.max_generations if settings.max_generations is not None else 10**9,
            rng=np.random.default_rng(settings.seed),
            workers=evaluator,
            callback=checkpoint,
            # SciPy needs 5 members or more; a rescored DE run's population always has them
            **{**DE_SETTINGS, **({"init": start} if start is not None and len(start) >= 5 else {})},
        )
        return search.result(
            search.stop_reason or result.message, converged=search.stop_reason is None and bool(result.success)
        )
