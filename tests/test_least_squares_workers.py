"""Least squares keeps idle workers busy with the trials it will ask for next if it rejects the current one,
without changing its path (the whole of `auto` on several workers: tests/test_pipeline.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import least_squares

from simtune.optimize.base import BatchSearch
from simtune.optimize.evaluator import TuneSettings
from simtune.optimize.refine import STEP, jacobian_from, jacobian_points, least_squares_phase, trials_after_rejection
from simtune.reference import REFERENCE_DIR
from simtune.run_plan import RunConfig, plan_run
from simtune.store import RunStore

ONLY = ["command_delay", "max_velocity_joint_2", "marker_offset_z"]


def _phase(run_dir: Path, workers: int, max_nfev: int):
    """A local phase from a fixed start on ``workers`` threads: SciPy's result and the size of each batch."""
    config = RunConfig(
        optimizer="de", engine="mujoco", tasks="cube", space="extended", data=str(REFERENCE_DIR), only=ONLY
    )
    objective = plan_run(config).objective()
    store = RunStore(run_dir, create=True)
    search = BatchSearch(objective, store, TuneSettings(workers=workers, threads=True))
    start = search.from_unit(np.array([0.3, 0.6, 0.7]))
    sizes: list[int] = []
    residuals = search.evaluator.residuals

    def counted(vectors):
        sizes.append(len(vectors))
        return residuals(vectors)

    search.evaluator.residuals = counted  # type: ignore[method-assign]
    with search:
        solution = least_squares_phase(search, start, max_nfev=max_nfev)
    store.close()
    return solution, sizes


@pytest.mark.slow  # local phases on 1, 2 and 4 workers (about 23 s); the replay's own test is in the default tier
def test_spare_workers_score_the_trials_after_a_rejection_and_the_solver_path_is_unchanged(tmp_path: Path) -> None:
    alone, alone_sizes = _phase(tmp_path / "one", workers=1, max_nfev=8)
    for workers in (2, 4):
        shared, shared_sizes = _phase(tmp_path / f"w{workers}", workers=workers, max_nfev=8)
        # the solver saw the same numbers: the same steps, the same end point
        np.testing.assert_array_equal(shared.x, alone.x)
        assert shared.nfev == alone.nfev and shared.cost == alone.cost
        # the start point goes out with its whole Jacobian on any worker count (the solver always asks for it)
        assert alone_sizes[0] == shared_sizes[0] == 1 + len(ONLY)
        # a trial goes out with a point for each spare worker
        assert max(shared_sizes[1:]) <= max(workers, len(ONLY))
        # the trial after a rejection was scored with the rejected one: fewer batches than one worker's
        assert len(shared_sizes) < len(alone_sizes)
    # one worker: a trial point alone, then its Jacobian when the solver takes the step
    assert set(alone_sizes[1:]) == {1, len(ONLY)}
    assert alone_sizes.count(len(ONLY)) == alone.njev - 1


def test_a_replayed_solver_names_the_trials_after_a_rejection_bit_for_bit() -> None:
    """On a rough function (most trials rejected), the trials predicted at each trial, assuming it and the
    ones after it rejected, are exactly those SciPy asks for whenever it does reject them."""

    def rough(u: np.ndarray) -> np.ndarray:
        return np.concatenate([u - 0.4 + 0.05 * np.sin(2000.0 * u), [3.0 * np.prod(u) - 0.2]])  # rough below STEP

    cache: dict[bytes, np.ndarray] = {}
    calls: list[tuple[str, bytes]] = []  # ("f" trial or "j" Jacobian, point)
    predicted: dict[bytes, list[bytes]] = {}

    def key(u: np.ndarray) -> bytes:
        return np.asarray(u, dtype=float).tobytes()

    def jacobian_at(u: np.ndarray) -> np.ndarray:
        points, h = jacobian_points(np.asarray(u, dtype=float), STEP)
        if not all(key(p) in cache for p in points):
            raise LookupError  # never: the real solver scores every column before a replay needs them
        return jacobian_from(cache[key(u)], [cache[key(p)] for p in points], h)

    def solve(fun, jac):
        return least_squares(fun, np.full(3, 0.5), jac=jac, bounds=(0.0, 1.0), method="trf", max_nfev=30)

    def fun(u: np.ndarray) -> np.ndarray:
        if cache:  # a trial: what would come after it, were it rejected
            predicted[key(u)] = [key(p) for p in trials_after_rejection(solve, jacobian_at, dict(cache), u, 3)]
        calls.append(("f", key(u)))
        cache[key(u)] = rough(np.asarray(u, dtype=float))
        return cache[key(u)]

    def jac(u: np.ndarray) -> np.ndarray:
        calls.append(("j", key(u)))
        points, _ = jacobian_points(np.asarray(u, dtype=float), STEP)
        for p in points:
            cache[key(p)] = rough(p)
        return jacobian_at(u)

    solve(fun, jac)
    trials = [(i, point) for i, (kind, point) in enumerate(calls) if kind == "f"][1:]
    rejected = 0
    for n, (_, point) in enumerate(trials):
        # the trials after this one, as long as each came right after the one before (rejected: no Jacobian)
        after: list[bytes] = []
        before = point
        for j, later in trials[n + 1 : n + 4]:
            if calls[j - 1] != ("f", before):
                break
            after.append(later)
            before = later
        rejected += bool(after)
        assert predicted[point][: len(after)] == after
    assert rejected >= 8  # a rough function: most trials were rejected, and each prediction held
