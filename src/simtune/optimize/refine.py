"""Local refinement of the best point: SciPy ``least_squares`` on the per-sample residuals.

After a global search (``--refine``), a bounded trust-region least-squares
solver starts from the best point and fits the per-sample residuals
(:meth:`simtune.objective.Objective.residuals_and_score`: marker minus mean
recorded wrist at every sample, stacked over tasks, plus the final object
position error).  It works in the unit cube (each parameter scaled to its
range) with a forward-difference Jacobian of step ``step`` (in units of each
range: simulations are not smooth at the scale of rounding errors), whose D
evaluations go to the process pool as one batch; workers a trial point would
leave idle evaluate the trials the solver asks for next if it rejects this one.

Every evaluation, with its residual vector, lands in the run store, so a
resumed run replays the refinement without simulating again.  The
refinement stops after ``max_nfev`` solver steps (each costs 1 + D
evaluations at most); it is not bound by the search's time or evaluation
budget.  The best point of the run is the best of both stages by fitness
(the solver minimises squared errors, the fitness plain ones).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np
from scipy.optimize import least_squares

from simtune.objective import Objective
from simtune.optimize.base import BatchSearch, BudgetSpent
from simtune.optimize.evaluator import TuneResult, TuneSettings
from simtune.store import RunStore

MAX_NFEV = 10  # solver steps (residual evaluations); each may add a D-evaluation Jacobian
STEP = 0.01  # forward-difference step, as a fraction of each parameter's range


def least_squares_phase(
    search: BatchSearch,
    x0,
    *,
    max_nfev: int,
    step: float = STEP,
    ftol: float = 1e-8,
    on_first_jacobian: Callable[[np.ndarray, np.ndarray], None] | None = None,
):
    """SciPy's bounded least squares from ``x0`` through ``search`` (its evaluator and checkpoints).

    ``on_first_jacobian`` is called once with the first Jacobian the solver takes (at ``x0``, in the unit cube)
    and the residuals there: the start's diagnosis (:mod:`simtune.optimize.start_check`) at no extra rollout.

    Every batch (a trial point, or a Jacobian's D points) is checkpointed as a generation, not a population;
    :class:`BudgetSpent` is raised once a checkpoint says a budget is spent.  Returns SciPy's result.

    Workers a batch would leave idle do work the solver is likely to ask for next: the start point goes out
    with its whole Jacobian (the solver always asks for it), and each trial point with the trial points the
    solver will ask for if it rejects this one and the ones before (:func:`trials_after_rejection`: on the
    arms' objectives most trials are rejected, the trust region shrinking each time), then, where the solver
    would stop before asking for more, the first columns of the trial's own Jacobian - as many points as
    there are workers besides the trial's (:func:`speculative_points`).  Points the solver does not ask for
    stay stored but unused.  Points scored ahead are held back from the search's best point until the
    solver asks for them (:meth:`BatchSearch.hold`), so the search takes the same path on any number of
    workers; the run's best point is chosen among all of them at its end.
    """
    x0 = np.asarray(x0, dtype=float)
    u0 = search.to_unit(x0)
    cache: dict[bytes, np.ndarray] = {}
    spare = speculative_points(search.evaluator.workers)
    diagnosed: list[bool] = []  # whether on_first_jacobian was called

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

    def fun(u: np.ndarray) -> np.ndarray:  # the solver asks for a point: one of its steps
        search.solver_steps += 1
        return residuals_at(u)

    def residuals_at(u: np.ndarray) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        if not known(u):
            columns = [p for p in jacobian_points(u, step)[0] if not known(p)]
            if not cache:  # the start point: its Jacobian comes next, whatever its residuals
                batch([u, *columns], asked=1)
            else:
                ahead = trials_after_rejection(solve, jacobian_at, cache, u, spare)
                batch([u, *ahead, *columns[: spare - len(ahead)]], asked=1)
        search.release(key(u))
        return cache[key(u)]

    def jac(u: np.ndarray) -> np.ndarray:
        residuals_at(u)  # scored already (the solver asks for a point's Jacobian after the point); released here
        points, _ = jacobian_points(np.asarray(u, dtype=float), step)
        for p in points:  # asked for now: the columns scored ahead count before the batch of the others
            search.release(key(p))
        missing = [p for p in points if not known(p)]
        if missing:
            batch(missing, asked=len(missing))
        jacobian = jacobian_at(u)  # the replays' own Jacobian: the same numbers by construction
        if on_first_jacobian is not None and not diagnosed:
            diagnosed.append(True)
            on_first_jacobian(jacobian, cache[key(u)])
        return jacobian

    def solve(residuals: Callable[[np.ndarray], np.ndarray], jacobian: Callable[[np.ndarray], np.ndarray]):
        return least_squares(
            residuals,
            np.clip(u0, 0.0, 1.0),
            jac=jacobian,
            bounds=(0.0, 1.0),
            method="trf",
            max_nfev=max_nfev,
            ftol=ftol,
        )

    def jacobian_at(u: np.ndarray) -> np.ndarray:  # the Jacobian from the cache alone (as the replays need it)
        points, h = jacobian_points(np.asarray(u, dtype=float), step)
        if not all(known(p) for p in points):
            raise _Asked(None)
        return jacobian_from(cache[key(u)], [cache[key(p)] for p in points], h)

    return solve(fun, jac)


class _Asked(Exception):
    """A replay of the solver reached a point it has no residuals for (``point``; None: a Jacobian)."""

    def __init__(self, point: np.ndarray | None):
        super().__init__()
        self.point = point


def trials_after_rejection(
    solve: Callable, jacobian_at: Callable, cache: dict[bytes, np.ndarray], trial: np.ndarray, n: int
) -> list[np.ndarray]:
    """The next ``n`` trial points the solver asks for if it rejects ``trial`` and each of them in turn (fewer
    where it would stop, or take a step, before).

    SciPy's trust-region solver keeps no state a caller can copy, so the solver is replayed: ``solve`` runs
    it again from its start, on the residuals of ``cache`` (its Jacobians by ``jacobian_at``) and with the
    points assumed rejected given residuals far worse than any known, until it asks for a point it has none
    for - the one it would ask for next.  A rejected trial changes the solver's state only by being worse
    than the current point (its residuals are not kept), so the point is the very one, bit for bit, the
    solver asks for after a real rejection (where it is not - a trial exactly as good as the current point -
    the point is never asked for: a wasted evaluation, not a changed path).  A replay costs the solver's own
    linear algebra, no simulation.
    """
    if n <= 0:
        return []
    worse = 10.0 * (1.0 + max(float(np.max(np.abs(r), initial=0.0)) for r in cache.values()))
    rejected = {np.asarray(trial, dtype=float).tobytes()}
    size = len(next(iter(cache.values())))
    ahead: list[np.ndarray] = []

    def residuals(u: np.ndarray) -> np.ndarray:
        name = np.asarray(u, dtype=float).tobytes()
        if name in rejected:
            return np.full(size, worse)
        if name in cache:
            return cache[name]
        raise _Asked(np.array(u, dtype=float))

    while len(ahead) < n:
        try:
            solve(residuals, jacobian_at)
            break  # it stops before asking for another point
        except _Asked as asked:
            if asked.point is None:
                break
            ahead.append(asked.point)
            rejected.add(asked.point.tobytes())
    return ahead


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


def jacobian_from(r0: np.ndarray, columns: list[np.ndarray], h: np.ndarray) -> np.ndarray:
    """The forward-difference Jacobian from the residuals at the point, at its D moved points and their steps."""
    return np.stack([(r - r0) / hi for r, hi in zip(columns, h)], axis=1)


def speculative_points(workers: int) -> int:
    """Points evaluated alongside a trial point: one for each worker the trial leaves idle."""
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
