"""Differential evolution as in the seed paper, on SciPy's implementation.

best1bin, crossover 0.7, mutation dithered in [0.5, 1.0], population 1 x D,
latin-hypercube start; stop when the population's fitness spread falls below
1 % of its mean, or when a budget of the settings is spent (checked after
each generation: a generation is never cut short by a budget of evaluations,
so ``max_evaluations`` can be overshot by up to one generation of D
evaluations; the time cap cuts one, its finished evaluations stored).

By default the population is updated once per generation ("deferred"),
whether one process evaluates it or many: the same seed then gives the same
run with any number of workers.  SciPy calls the Evaluator as its ``workers``
map, with each trial's parent fitness known, so a trial that can no longer
beat its parent is stopped early (pruning) without changing the search.

``paper_exact`` runs SciPy as the seed paper did (``PAPER_DE_SETTINGS``): its
default immediate updating (each trial replaces its parent at once, so later
trials of the same generation already see it), one evaluation at a time, no
pruning, and SciPy's default polish of the best member with L-BFGS-B at the
end (its evaluations are stored too, after the last generation).  Given the
same seed and objective, it is step for step SciPy's own run.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import differential_evolution

from simtune.objective import Objective
from simtune.optimize.base import BatchSearch, BudgetSpent
from simtune.optimize.evaluator import TuneResult, TuneSettings
from simtune.store import RunStore

POPSIZE = 1  # members per parameter: the paper's population of 1 x D

DE_SETTINGS = dict(
    strategy="best1bin",
    recombination=0.7,
    mutation=(0.5, 1.0),
    popsize=POPSIZE,
    init="latinhypercube",
    tol=0.01,
    atol=0.0,
    polish=False,
    updating="deferred",
)
#: SciPy's own defaults where simtune's differ: what the seed paper ran (one core per optimisation)
PAPER_DE_SETTINGS = {**DE_SETTINGS, "polish": True, "updating": "immediate"}


def differential_evolution_tune(objective: Objective, store: RunStore, settings: TuneSettings) -> TuneResult:
    """Tune ``objective`` over its parameter space; every evaluation lands in ``store``."""
    exact = settings.paper_exact
    search = BatchSearch(objective, store, settings, prune=not exact)
    evaluator = search.evaluator
    evaluator.generation = 0  # the initial population is generation 0; the first checkpoint follows generation 1
    de_settings = PAPER_DE_SETTINGS if exact else DE_SETTINGS
    store.set(de_settings=de_settings)

    def checkpoint(intermediate_result) -> bool:
        population = intermediate_result.population
        energies = np.array(intermediate_result.population_energies, dtype=float)
        if exact:  # evaluations one at a time: from here on they belong to the next generation
            evaluator.generation += 1
        else:
            evaluator.parent_energies = energies
        search.track(population, energies)
        return search.checkpoint(population, energies)

    start = search.starting_points()
    init = start if start is not None and len(start) >= 5 else None  # SciPy needs 5 members or more
    members = _population_size(search.space.bounds, init)

    def score_one(x) -> float:
        """One trial at a time (immediate updating); the ones after the initial population are generation 1's."""
        if evaluator.requested == members:
            evaluator.generation = 1
        return evaluator.score_one(x)

    with search:
        try:
            result = differential_evolution(
                # deferred: never called, the Evaluator is SciPy's ``workers`` map and does the work
                score_one if exact else (lambda x: objective.score_vector(x).fitness),
                bounds=search.space.bounds,
                maxiter=settings.max_generations if settings.max_generations is not None else 10**9,
                rng=np.random.default_rng(settings.seed),
                workers=1 if exact else evaluator,
                callback=checkpoint,
                # a rescored DE run starts from its last population (it always has 5 members or more)
                **{**de_settings, **({"init": init} if init is not None else {})},
            )
        except BudgetSpent:  # the time cap cut a generation (or, one at a time, stopped before an evaluation)
            return search.result()
        if exact and result.fun < search.best_fitness:  # the polish found a better point
            search.track(np.atleast_2d(result.x), np.array([result.fun]))
        return search.result(
            search.stop_reason or result.message, converged=search.stop_reason is None and bool(result.success)
        )


def _population_size(bounds: list[tuple[float, float]], init: np.ndarray | None) -> int:
    """Members of SciPy's population: those of ``init``, else popsize (1) x the parameters whose bounds
    differ, at least 5 (SciPy's rule)."""
    if init is not None:
        return len(init)
    varying = sum(1 for low, high in bounds if high != low)
    return max(5, POPSIZE * max(1, varying))
