"""Local refinement of the best point: SciPy ``least_squares`` on the per-sample residuals.

After a global search (``--refine``), a bounded trust-region least-squares
solver starts from the best point and fits the per-sample residuals
(:meth:`simtune.objective.Objective.residuals_and_score`: marker minus mean
recorded wrist at every sample, stacked over tasks, plus the final object
position error).  It works in the unit cube (each parameter scaled to its
range) with a forward-difference Jacobian of step ``step`` (in units of each
range: simulations are not smooth at the scale of rounding errors), whose D
evaluations go to the process pool as one batch; workers a trial point would
leave idle evaluate the first columns of its own Jacobian meanwhile.

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

    Workers a batch would leave idle do work the solver is likely to ask for next: the start point goes out
    with its whole Jacobian (the solver always asks for it), and each trial point with the first columns of
    its own Jacobian, as many as there are workers besides the trial's (:func:`speculative_columns`).  The
    solver asks for that Jacobian as soon as the trial lowers the cost; a trial it rejects leaves those
    points stored but unused.  Points scored ahead are held back from the search's best point until the
    solver asks for them (:meth:`BatchSearch.hold`), so the search takes the same path on any number of
    workers; the run's best point is chosen among all of them at its end.
    """
    x0 = np.asarray(x0, dtype=float)
    u0 = search.to_unit(x0)
    cache: dict[bytes, np.ndarray] = {}
    spare = speculative_columns(search.evaluator.workers)

    def vector(u: np.ndarray) -> np.ndarray:
        return x0.copy() if np.array_equal(u, u0) else search.from_unit(u)

    def key(u: np.ndarray) -> bytes:  # the name of a point of the unit cube in the cache and the search's holds
        return np.asarray(u, dtype=float).tobytes()

    def batch(us: list[np.ndarray], asked: int) -> None:
        """Score ``us``: the first ``asked`` for the solver now, the rest held for when it asks."""
        xs = np.array([vector(u) for u in us])
        results = search.evaluator.residuals(xs)
        fitness = np.array([score.fitness for _, score in results])
        search.track(xs[:asked], fitness[:asked])
        for u, x, f in zip(us[asked:], xs[asked:], fitness[asked:]):
            search.hold(key(u), x, f)
        stop = search.checkpoint(xs, fitness, population=False)
        for u, (r, _) in zip(us, results):
            cache[key(u)] = r
        if stop:
            raise BudgetSpent

    def known(u: np.ndarray) -> bool:
        return key(u) in cache

    def fun(u: np.ndarray) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        if not known(u):
            first = len(cache) == 0  # the start point: its Jacobian comes next, whatever its residuals
            columns = jacobian_points(u, step)[0]
            batch([u, *[p for p in (columns if first else columns[:spare]) if not known(p)]], asked=1)
        search.release(key(u))
        return cache[key(u)]

    def jac(u: np.ndarray) -> np.ndarray:
        r0 = fun(u)
        points, h = jacobian_points(np.asarray(u, dtype=float), step)
        for p in points:  # asked for now: the columns scored ahead count before the batch of the others
            search.release(key(p))
        missing = [p for p in points if not known(p)]
        if missing:
            batch(missing, asked=len(missing))
        columns = [cache[key(p)] for p in points]
        return np.stack([(r - r0) / hi for r, hi in zip(columns, h)], axis=1)

    return least_squares(
        fun, np.clip(u0, 0.0, 1.0), jac=jac, bounds=(0.0, 1.0), method="trf", max_nfev=max_nfev, ftol=ftol
    )


def jacobian_points(u: np.ndarray, step: float) -> tuple[list[np.ndarray], np.ndarray]:
    """The D points of a forward-difference Jacobian at ``u`` (unit cube) and their signed steps: each
    coordinate moved by ``step``, backwards where forwards would leave the cube."""
    h = np.where(u + step <= 1.0, step, -step)
    points = []
    for i in range(len(u)):
        p = np.array(u, dtype=float)
        p[i] += h[i]
        points.append(p)
    return points, h


def speculative_columns(workers: int) -> int:
    """Jacobian columns evaluated alongside a trial point: one for each worker the trial leaves idle."""
    return max(0, workers - 1)


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
