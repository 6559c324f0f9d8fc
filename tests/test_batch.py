"""The batch seam: a batch scored at once (MuJoCo on threads) equals its members scored one at a time, bit for bit."""

import numpy as np
import pytest

from simtune.engines import engine_class
from simtune.objective import Objective, load_references
from simtune.optimize import evaluator as evaluator_module
from simtune.optimize.evaluator import Evaluator, batch_on_threads, chunks, has_batch_path
from simtune.params import get_space
from simtune.reference import REFERENCE_DIR
from simtune.store import RunStore
from simtune.tasks import parse_tasks


def objective(tasks: str = "cube", data=REFERENCE_DIR) -> Objective:
    specs = parse_tasks(tasks)
    space = get_space("extended", engine_class("mujoco").supported())
    return Objective("mujoco", specs, load_references(data, specs), space)


def vectors(obj: Objective, n: int, seed: int = 0) -> np.ndarray:
    """Random points of the space around its middle (stable, different masses and time steps)."""
    space = obj.vector_space()
    lo, hi = np.array(space.bounds).T
    u = 0.3 + 0.4 * np.random.default_rng(seed).random((n, len(lo)))
    return lo + u * (hi - lo)


def in_order(results) -> list:
    results = sorted(results, key=lambda item: item[0])
    return [value for _, value in results]


@pytest.mark.parametrize("threads", [1, 3])
def test_a_batch_scores_each_member_as_alone(threads, two_task_data):
    obj = objective("cube,single", two_task_data)
    space = obj.vector_space()
    params = [space.to_dict(x) for x in vectors(obj, 5)] + [{}]
    alone = [obj.score(p) for p in params]
    # bounds: none, far above, and below a member's fitness: pruned within its first task, after its first
    # task (its wrist error under the bound, wrist plus object error over it), within its second task
    cube = alone[2].tasks[0]
    bounds = [None, alone[1].tasks[0].fitness * 0.5, cube.wrist_error + cube.object_error / 2, 100.0, None, None]
    bounds[4] = alone[4].tasks[0].fitness + alone[4].tasks[1].fitness * 0.5
    pruned_alone = [obj.score(p, b) for p, b in zip(params, bounds)]
    assert [len(s.tasks) for s in pruned_alone] == [2, 1, 1, 2, 2, 2]
    assert [s.pruned for s in pruned_alone] == [False, True, False, False, True, False]
    fresh = objective("cube,single", two_task_data)  # engines built anew, as in a worker
    assert in_order(fresh.score_batch(params, threads=threads)) == alone
    assert in_order(fresh.score_batch(params, bounds, threads=threads)) == pruned_alone
    for (r, s), (want_r, want_s) in zip(
        in_order(fresh.residuals_batch(params, threads=threads)), [obj.residuals_and_score(p) for p in params]
    ):
        assert s == want_s
        np.testing.assert_array_equal(r, want_r)
    obj.close()
    fresh.close()


def test_threads_and_chunked_worker_processes_store_what_one_process_stores(tmp_path, monkeypatch):
    monkeypatch.setattr(evaluator_module, "POOL_BATCH", 2)
    obj = objective()
    xs = vectors(obj, 6, seed=1)
    rows = {}
    # "switched": worker processes asked for after threads (threads_first_s 0: the pool starts after the first
    # batch's first member, alone on threads, before the rest: 5 members, POOL_BATCH 2 a worker here); "threads
    # first": a budget of threads the batches never spend
    modes = (("one", 1, False, None), ("threads", 2, True, None), ("processes", 2, False, None))
    modes += (("switched", 2, False, 0.0), ("threads first", 2, False, 1e9))
    for name, workers, threads, threads_first_s in modes:
        store = RunStore(tmp_path / name, create=True)
        with Evaluator(objective(), store, workers, threads=threads, threads_first_s=threads_first_s) as evaluator:
            assert evaluator.chunked == (name == "processes")  # each worker runs its chunk through the batch path
            assert evaluator.threads == (name in ("threads", "switched", "threads first"))
            fitness = evaluator.evaluate(xs)
            assert (evaluator._pool is not None) == (name in ("processes", "switched"))
            assert evaluator.chunked == (name in ("processes", "switched"))
            evaluator.parent_energies = fitness * 0.5  # every trial pruned against a better parent
            evaluator.evaluate(xs + 1e-9)
            residuals = evaluator.residuals(xs[:3] - 1e-9)
        rows[name] = (
            sorted((tuple(e["x"]), e["fitness"], e["pruned"], e["wrist_error"]) for e in store.evaluations()),
            [(r.tolist(), s) for r, s in residuals],
        )
        store.close()
    assert rows["one"] == rows["threads"] == rows["processes"] == rows["switched"] == rows["threads first"]
    assert sum(pruned for _, _, pruned, _ in rows["one"][0]) == 6


@pytest.mark.slow  # the batch path's bit-identity stays in the default tier: tests/test_batch_vectorised.py
def test_a_run_on_threads_is_the_run_of_one_process(tmp_path):
    from simtune.runs import RunConfig, start_run

    base = dict(
        engine="mujoco",
        tasks="cube",
        space="extended",
        data=str(REFERENCE_DIR),
        seed=2,
        max_generations=2,
        optimizer="de",
    )
    base["only"] = ["command_delay", "max_velocity_joint_2", "mass_link_3"]
    one = start_run(RunConfig(**base), tmp_path / "one", show_progress=False)
    threaded = start_run(RunConfig(**base, workers=2, threads=True), tmp_path / "threads", show_progress=False)
    assert threaded.fitness == one.fitness and threaded.evaluations == one.evaluations
    np.testing.assert_array_equal(threaded.x, one.x)


def test_mujoco_batches_run_on_threads_by_default_where_they_win(tmp_path):
    """Left unsaid, MuJoCo's batches go to its batch path on up to 2 workers (where threads beat processes), unless a
    time-out needs worker processes; what is asked for is done."""
    assert batch_on_threads("mujoco", 2, None, None) and batch_on_threads("mujoco", 1, None, None)
    assert not batch_on_threads("mujoco", 2, None, 30.0) and not batch_on_threads("mujoco", 8, None, None)
    assert not batch_on_threads("pybullet", 2, None, None) and batch_on_threads("pybullet", 2, True, None)
    assert not batch_on_threads("mujoco", 2, False, None)
    store = RunStore(tmp_path / "run", create=True)
    with Evaluator(objective(), store, 2) as evaluator:
        assert evaluator.threads and evaluator._pool is None
    with Evaluator(objective(), store, 2, eval_timeout=60.0) as evaluator:
        assert not evaluator.threads and evaluator._pool is not None
    store.close()


def test_worker_processes_get_chunks_where_the_engine_has_a_batch_path():
    assert has_batch_path("mujoco") and not has_batch_path("pybullet")
    # balanced by cost (a member's steps per period), each chunk in order, none empty
    assert chunks([1.0, 1.0, 1.0], 2) == [[0, 2], [1]]
    assert chunks([50.0, 1.0, 1.0, 1.0, 1.0, 1.0], 2) == [[0], [1, 2, 3, 4, 5]]
    assert chunks([2.0, 1.0], 5) == [[0], [1]]
    parts = chunks(list(np.random.default_rng(0).random(13) * 50 + 1), 2)
    assert sorted(i for part in parts for i in part) == list(range(13)) and all(p == sorted(p) for p in parts)


def test_small_batches_stay_on_threads_past_the_threads_budget(tmp_path):
    """Worker processes pay for their start on large batches only: a search of batches smaller than POOL_BATCH
    rollouts a worker (a Jacobian of a few parameters) never starts them, however long it runs."""
    store = RunStore(tmp_path / "run", create=True)
    obj = objective()
    with Evaluator(obj, store, 2, threads=False, threads_first_s=0.0) as evaluator:
        evaluator.evaluate(vectors(obj, 3, seed=4))
        evaluator.residuals(vectors(obj, 2, seed=5))
        assert evaluator._pool is None and evaluator.threads and evaluator.simulated_seconds > 0
        assert not evaluator._need_pool(evaluator_module.POOL_BATCH * 2 - 1)
        assert evaluator._need_pool(evaluator_module.POOL_BATCH * 2)
    store.close()


def test_members_that_differ_in_the_marker_offset_alone_share_one_simulation(two_task_data):
    """A Jacobian's marker-offset columns move only what the fitness's marker model reads: their members are
    simulated once, or not at all where a recent rollout simulated the same (the point the Jacobian is taken at),
    each scored with its own offset, every result as the member's alone, bit for bit."""
    obj = objective("cube,single", two_task_data)
    space = obj.vector_space()
    base = space.to_dict(vectors(obj, 1, seed=3)[0])
    moved = [{**base, f"marker_offset_{a}": base[f"marker_offset_{a}"] + 1e-3} for a in "xyz"]
    params = [base, *moved, {**base, "command_delay": base["command_delay"] + 0.01}]
    alone = [obj.residuals_and_score(p) for p in params]
    assert len({s.fitness for _, s in alone}) == len(params)  # the offset does change each member's score
    fresh = objective("cube,single", two_task_data)
    sizes: list[int] = []
    for task in fresh.tasks:
        engine = fresh._engine(task)
        real = engine.rollout_batch

        def counted(members, *args, real=real, **kwargs):
            sizes.append(len(members))
            return real(members, *args, **kwargs)

        engine.rollout_batch = counted
    for (r, s), (want_r, want_s) in zip(in_order(fresh.residuals_batch(params, threads=2)), alone):
        assert s == want_s
        np.testing.assert_array_equal(r, want_r)
    assert sizes == [2, 2]  # per task: the base (with its three offsets) and the delayed member
    # others simulated since, then the same points again: from the rollouts kept, as they were
    sizes.clear()
    others = [space.to_dict(x) for x in vectors(obj, 3, seed=4)]
    assert len(in_order(fresh.score_batch(others))) == 3 and sizes == [3, 3]
    again = [{**p, "marker_offset_x": p["marker_offset_x"] - 2e-3} for p in params]
    sizes.clear()
    assert in_order(fresh.score_batch(again)) == [obj.score(p) for p in again]
    assert sizes == [0, 0]
    # a member watched by a pruning monitor reads its own offset while simulating: simulated alone
    sizes.clear()
    assert in_order(fresh.score_batch(params, [None, 100.0, None, None, None])) == [s for _, s in alone]
    assert sizes == [1, 1]  # the watched member; the others' rollouts were kept
    obj.close()
    fresh.close()


def test_worker_processes_get_the_members_that_share_a_simulation_together(tmp_path):
    obj = objective()
    store = RunStore(tmp_path / "run", create=True)
    space = obj.vector_space()
    x = vectors(obj, 2, seed=6)
    marker = space.names.index("marker_offset_y")
    shifted = x[0].copy()
    shifted[marker] += 1e-3
    with Evaluator(obj, store, 2, threads=False) as evaluator:
        assert evaluator._simulation_groups([x[0], x[1], shifted, x[0]]) == [[0, 2, 3], [1]]
    store.close()
