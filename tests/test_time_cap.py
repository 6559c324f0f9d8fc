"""`--max-seconds` reaches into a batch (issue 70 item 5): a batch goes out in slices checked against the cap, the
slice that would end past it is not started, every evaluation that finished stays in the store, and a search that
never reaches its cap takes the very path it takes without one."""

import time

import numpy as np
import pytest
from test_tune import config as tune_config

from simtune.objective import generic_values
from simtune.optimize import evaluator as evaluator_module
from simtune.optimize.base import BatchSearch, BudgetSpent
from simtune.optimize.evaluator import TuneSettings
from simtune.optimize.progress import _ClockBar
from simtune.run_plan import plan_run
from simtune.runs import RunConfig, start_run
from simtune.store import RunStore

ONLY = ["command_delay", "max_velocity_joint_2", "mass_cube_plastic", "max_velocity_joint_3", "marker_offset_z"]


def config(**kw) -> RunConfig:
    """test_tune's DE run on the shipped `cube`, over five parameters for two generations."""
    return tune_config(**{"only": ONLY, "max_generations": 2, **kw})


def test_a_time_budgets_bar_fills_with_the_clock_not_with_the_last_evaluation():
    """Probe 5: the bar stood still for 3 minutes while one batch ran; it follows the clock at each refresh."""
    from rich.progress import Task, TaskID

    now = [100.0]
    task = Task(TaskID(0), "tune", total=20.0, completed=0.0, _get_time=lambda: now[0])
    task.start_time = 95.0
    assert _ClockBar().render(task).completed == pytest.approx(5.0)
    now[0] = 130.0
    assert _ClockBar().render(task).completed == pytest.approx(20.0)  # full at its cap, never past it


@pytest.mark.slow  # about 20 rollouts of cube on threads, then in two worker processes: about 15 s
@pytest.mark.parametrize("processes", [False, True], ids=["threads", "processes"])
def test_a_batch_is_cut_at_the_cap_and_keeps_every_evaluation_that_finished(tmp_path, processes):
    """A batch of 20 rollouts with a cap three rollouts away ends within a slice of the cap, not 17 rollouts past it;
    the evaluations done are stored, as an uncut batch scores them, and the same batch asked again (a resumed
    search) simulates only the rest."""
    objective = plan_run(config()).objective()
    space = objective.vector_space()
    generic = space.vector_within_bounds(generic_values(objective, space.names))
    rng = np.random.default_rng(0)
    width = np.array([hi - lo for lo, hi in space.bounds])
    points = np.clip(generic + rng.normal(0, 0.01, (22, len(generic))) * width, *np.array(space.bounds).T)
    batch = points[2:]
    store = RunStore(tmp_path / "run", create=True)
    settings = TuneSettings(workers=2 if processes else 1, threads=not processes, max_seconds=3600.0)
    search = BatchSearch(objective, store, settings)
    with search:
        search.evaluate(points[:1])  # the engines built
        started = time.perf_counter()
        search.evaluate(points[1:2])  # the pace of one
        pace = time.perf_counter() - started
        search.settings.max_seconds = search.elapsed() + 3 * pace
        with pytest.raises(BudgetSpent):
            search.evaluate(batch)
        over = search.elapsed() - search.settings.max_seconds
        done = store.count_evaluations() - 2
        assert search.stop_code == "max-seconds"
        assert f"{done} of its 20 evaluations done and stored" in (search.stop_reason or "")
        assert 1 <= done < 12 and over < 3 * pace + evaluator_module.SLICE_S
        kept = {x.tobytes(): known.fitness for x in batch if (known := store.lookup(x)) is not None}
        assert len(kept) == done
        search.settings.max_seconds = None  # the batch asked again, as a resumed search asks it
        before = search.evaluator.new_evaluations
        fitness = search.evaluate(batch)
        assert search.evaluator.new_evaluations - before == 20 - done
    store.close()
    fresh = plan_run(config()).objective()
    try:  # what was kept is what an uncut batch scores
        for x, f in zip(batch, fitness):
            if x.tobytes() in kept:
                assert kept[x.tobytes()] == f == fresh.score_vector(x).fitness
    finally:
        fresh.close()
        objective.close()


@pytest.mark.slow  # three DE runs of two generations, one in worker processes: about 20 s
def test_a_cap_never_reached_leaves_the_search_as_it_is_without_one(tmp_path, monkeypatch):
    """Slices as small as can be (one member each, on threads and in worker processes) give the same seeded run,
    point for point, as one batch a generation: the batch path's results do not depend on the batch."""
    plain = start_run(config(), tmp_path / "plain", show_progress=False)
    monkeypatch.setattr(evaluator_module, "SLICE_S", 1e-6)
    sliced = start_run(config(max_seconds=3600.0), tmp_path / "sliced", show_progress=False)
    fed = start_run(config(max_seconds=3600.0, workers=2, threads=False), tmp_path / "fed", show_progress=False)
    rows = []
    for name in ("plain", "sliced", "fed"):
        store = RunStore.open_read_only(tmp_path / name)
        rows.append(sorted((r["fitness"], tuple(np.float32(r["x"]).tolist())) for r in store.evaluations()))
        store.close()
    assert rows[0] == rows[1] == rows[2]
    for run in (sliced, fed):
        assert run.fitness == plain.fitness and run.stop_reason == plain.stop_reason == "max-generations"
        np.testing.assert_array_equal(run.x, plain.x)
