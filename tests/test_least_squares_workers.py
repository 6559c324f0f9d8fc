"""Least squares keeps idle workers busy with the Jacobian it will ask for next, without changing its path
(the whole of `auto` on several workers: tests/test_pipeline.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from simtune.optimize.base import BatchSearch
from simtune.optimize.evaluator import TuneSettings
from simtune.optimize.refine import least_squares_phase
from simtune.reference import REFERENCE_DIR
from simtune.run_plan import RunConfig, plan_run
from simtune.store import RunStore

ONLY = ["command_delay", "max_velocity_joint_2", "marker_offset_z"]


def _phase(run_dir: Path, workers: int):
    """A local phase from a fixed start on ``workers`` threads: SciPy's result and the size of each batch."""
    config = RunConfig(engine="mujoco", tasks="cube", space="extended", data=str(REFERENCE_DIR), only=ONLY)
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
        solution = least_squares_phase(search, start, max_nfev=4)
    store.close()
    return solution, sizes


def test_spare_workers_evaluate_the_next_jacobian_and_the_solver_path_is_unchanged(tmp_path: Path) -> None:
    alone, alone_sizes = _phase(tmp_path / "one", workers=1)
    shared, shared_sizes = _phase(tmp_path / "four", workers=4)
    # the solver saw the same numbers: the same steps, the same end point
    np.testing.assert_array_equal(shared.x, alone.x)
    assert shared.nfev == alone.nfev and shared.cost == alone.cost
    # the start point goes out with its whole Jacobian on any worker count (the solver always asks for it)
    assert alone_sizes[0] == shared_sizes[0] == 1 + len(ONLY)
    # one worker: a trial point alone, then its Jacobian when the solver takes the step
    assert alone_sizes[1:] == [1, len(ONLY)] * (alone.njev - 1)
    # four workers: each trial with the three columns of its Jacobian; a taken step needs no other batch
    assert shared_sizes[1:] == [1 + len(ONLY)] * (shared.nfev - 1)
    assert len(shared_sizes) < len(alone_sizes)
