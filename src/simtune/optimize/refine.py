"""Local refinement of the best point: SciPy ``least_squares`` on the per-sample residuals.

After a global search (``--refine``), a bounded trust-region least-squares
solver starts from the best point and fits the per-sample residuals
(:meth:`simtune.objective.Objective.residuals_and_score`: marker minus mean
recorded wrist at every sample, stacked over tasks, plus the final object
position error).  It works in the unit cube (each parameter scaled to its
range) with a forward-difference Jacobian of step ``step`` (in units of each
range: simulations are not smooth at the scale of rounding errors), whose D
evaluations go to the process pool as one batch.

Every evaluation, with its residual vector, lands in the run store, so a
resumed run replays the refinement without simulating again.  The
refinement stops after ``max_nfev`` solver steps (each costs 1 + D
evaluations at most); it is not bound by the search's time or evaluation
budget.  The best point of the run is the best of both stages by fitness
(the solver minimises squared errors, the fitness plain ones).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.optimize import least_squares

from simtune.objective import Objective
from simtune.optimize.base import BatchSearch
from simtune.optimize.evaluator import TuneResult, TuneSettings
from simtune.store import RunStore

MAX_NFEV = 10  # solver steps (residual evaluations); each may add a D-evaluation Jacobian
STEP = 0.01  # forward-difference step, as a fraction of each parameter's range


class BudgetSpent(Exception):
    """Raised inside SciPy's solver when a budget of the search says stop (SciPy has no other way out)."""


def least_squares_phase(search: BatchSearch, x0, *, max_nfev: int, step: float = STEP, ftol: float = 1e-8):
    """SciPy's bounded least squares from ``x0`` through ``search`` (its evaluator and checkpoints).

    Every batch (a trial point, or a Jacobian's D points) is checkpointed as a generation, not a population;
    :class:`BudgetSpent` is raised once a checkpoint says a budget is spent.  Returns SciPy's result.
    """
    x0 = np.asarray(x0, dtype=float)
    u0 = search.to_unit(x0)
    cache: dict[bytes, np.ndarray] = {}

    def vector(u: np.ndarray) -> np.ndarray:
        return x0.copy() if np.array_equal(u, u0) else search.from_unit(u)

    def batch(us: list[np.ndarray]) -> list[np.ndarray]:
        xs = np.array([vector(u) for u in us])
        results = search.evaluator.residuals(xs)
        fitness = np.array([score.fitness for _, score in results])
        search.track(xs, fitness)
        stop = search.checkpoint(xs, fitness, population=False)
        for u, (r, _) in zip(us, results):
            cache[np.asarray(u, dtype=float).tobytes()] = r
        if stop:
            raise BudgetSpent
        return [r for r, _ in results]

    def fun(u: np.ndarray) -> np.ndarray:
        key = np.asarray(u, dtype=float).tobytes()
        return cache[key] if key in cache else batch([u])[0]

    def jac(u: np.ndarray) -> np.ndarray:
        r0 = fun(u)
        h = np.where(u + step <= 1.0, step, -step)
        points = []
        for i in range(len(u)):
            p = np.array(u, dtype=float)
            p[i] += h[i]
            points.append(p)
        columns = batch(points)
        return np.stack([(r - r0) / hi for r, hi in zip(columns, h)], axis=1)

    return least_squares(
        fun, np.clip(u0, 0.0, 1.0), jac=jac, bounds=(0.0, 1.0), method="trf", max_nfev=max_nfev, ftol=ftol
    )


def least_squares_refine(
    objective: Objective,
    store: RunStore,
    x0,
    settings: TuneSettings,
    *,
    first_generation: int = 1,
    max_nfev: int = MAX_NFEV,
    step: float = STEP,
) -> TuneResult:
    """Refine ``x0`` with bounded least squares; checkpoints each batch as a generation from ``first_generation``.

    Of ``settings`` only the processes, the evaluation timeout, the callbacks and
    ``elapsed_before`` apply: the refinement's budget is ``max_nfev``.
    """
    settings = replace(settings, max_seconds=None, max_generations=None, max_evaluations=None, target_fitness=None)
    search = BatchSearch(objective, store, settings, first_generation=first_generation)
    with search:
        solution = least_squares_phase(search, x0, max_nfev=max_nfev, step=step)
        message = f"least squares: {solution.message.rstrip('.')} after {solution.nfev} steps"
        return search.result(message, converged=bool(solution.status > 0))
