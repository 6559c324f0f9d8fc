"""CMA-ES (the ``cmaes`` package): ask/tell in batches of its population size, within the bounds.

The search runs in the unit cube (each parameter scaled to [0, 1] of its
range), so one step size suits parameters whose ranges differ by orders of
magnitude.  It starts at the centre with step size 0.3 and the default
population 4 + 3 ln D; when CMA-ES says it has converged it restarts from a
random point with twice the population (IPOP), until a budget is spent.
Every random draw comes from the seed, so a resumed run replays the search.
"""

from __future__ import annotations

import numpy as np

from simtune.errors import SimtuneError
from simtune.objective import Objective
from simtune.optimize.base import BatchSearch, BudgetSpent
from simtune.optimize.evaluator import TuneResult, TuneSettings
from simtune.store import RunStore

SIGMA0 = 0.3  # initial step size, in units of each parameter's range


def _cma_class():
    try:
        from cmaes import CMA
    except ImportError:
        raise SimtuneError("optimizer 'cmaes' needs the cmaes package: pip install 'simtune[opt]'") from None
    return CMA


def cmaes_tune(objective: Objective, store: RunStore, settings: TuneSettings) -> TuneResult:
    """CMA-ES with restarts; a generation is one population of CMA-ES."""
    CMA = _cma_class()
    dim = len(objective.vector_space())
    rng = np.random.default_rng(settings.seed)
    search = BatchSearch(objective, store, settings)
    bounds = np.tile([0.0, 1.0], (dim, 1))
    restarts = 0
    with search:
        mean = np.full(dim, 0.5)
        try:
            first = search.initial_batch()
            if first is not None:  # start from the best of the given points
                batch, fitness, stop = first
                if stop:
                    return search.result(search.stop_reason)
                mean = np.clip(search.to_unit(batch[int(np.argmin(fitness))]), 0.0, 1.0)
            optimizer = CMA(mean=mean, sigma=SIGMA0, bounds=bounds, seed=settings.seed)
            while True:
                u = np.array([optimizer.ask() for _ in range(optimizer.population_size)])
                left = search.remaining()
                batch = search.from_unit(u if left is None else u[:left])
                fitness = search.evaluate(batch)
                if search.checkpoint(batch, fitness):
                    break
                optimizer.tell([(ui, float(f)) for ui, f in zip(u, fitness)])
                if optimizer.should_stop():
                    restarts += 1
                    optimizer = CMA(
                        mean=rng.random(dim),
                        sigma=SIGMA0,
                        bounds=bounds,
                        seed=settings.seed + 1000 * restarts,
                        population_size=optimizer.population_size * 2,
                    )
        except BudgetSpent:  # the time cap cut a batch
            pass
        assert search.stop_reason is not None, "the loop ends only when a budget says stop"
        message = search.stop_reason + (f" ({restarts} restarts)" if restarts else "")
        return search.result(message)
