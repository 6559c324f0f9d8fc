"""Experiment grids: local and Dask executors agree, a killed worker loses nothing."""

import os
import signal
import threading
import time

import pytest

from simtune.grid import GridIndex, GridSpec, Unit, plan_grid, run_grid
from simtune.store import RunStore

from conftest import stored_evaluations

distributed = pytest.importorskip("distributed")


def small_spec(root) -> GridSpec:
    return GridSpec(engines=["mujoco", "pybullet"], tasks=["single", "cube"], spaces=["extended"], repeats=2,
                    data=str(root), max_generations=2,
                    only=["command_delay", "max_velocity_joint_2", "marker_offset_z"])


def results(index: GridIndex) -> dict[str, tuple]:
    return {r["id"]: (r["status"], r["fitness"], r["evaluations"]) for r in index.rows()}


@pytest.fixture(scope="module")
def local_grid(two_task_data, tmp_path_factory):
    grid_dir = tmp_path_factory.mktemp("local")
    index = run_grid(small_spec(two_task_data), grid_dir, executor="local", workers=2)
    return grid_dir, results(index)


def test_local_grid_runs_every_unit_once(local_grid):
    grid_dir, res = local_grid
    assert len(res) == 8 and all(status == "done" for status, _, _ in res.values())
    for unit_id, (_, fitness, evaluations) in res.items():
        store = RunStore(grid_dir / "runs" / unit_id)
        assert store.count_evaluations() == evaluations
        assert store.best_evaluation()["score"]["fitness"] == pytest.approx(fitness)


def test_running_again_skips_finished_units(local_grid, two_task_data):
    grid_dir, res = local_grid
    before = {u: RunStore(grid_dir / "runs" / u).count_evaluations() for u in res}
    t0 = time.time()
    index = run_grid(small_spec(two_task_data), grid_dir, executor="local", workers=2)
    assert results(index) == res
    assert {u: RunStore(grid_dir / "runs" / u).count_evaluations() for u in res} == before
    assert time.time() - t0 < 30


def test_dask_grid_with_a_killed_worker_matches_local(local_grid, two_task_data, tmp_path):
    _, expected = local_grid
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    client = distributed.Client(cluster)
    grid_dir = tmp_path / "dask"
    outcome = {}

    def run():
        outcome["index"] = results(run_grid(small_spec(two_task_data), grid_dir, executor="dask",
                                            scheduler=cluster.scheduler_address))

    thread = threading.Thread(target=run)
    thread.start()
    try:
        # wait until some unit has committed evaluations but the grid is far from done, then kill a worker
        deadline = time.time() + 120
        while time.time() < deadline:
            runs = list((grid_dir / "runs").glob("*/run.sqlite")) if (grid_dir / "runs").exists() else []
            if any(stored_evaluations(p.parent) >= 3 for p in runs):
                break
            time.sleep(0.05)
        counts = GridIndex(grid_dir).counts()
        assert counts.get("done", 0) < 8, "the kill must land mid-grid"
        pids = client.run(os.getpid)
        victim = sorted(pids.values())[0]
        os.kill(victim, signal.SIGKILL)
        thread.join(timeout=300)
        assert not thread.is_alive()
    finally:
        client.close()
        cluster.close()
    got = outcome["index"]
    assert got.keys() == expected.keys()
    for unit_id, (status, fitness, evaluations) in got.items():
        assert status == "done", unit_id
        assert fitness == pytest.approx(expected[unit_id][1], abs=1e-12), unit_id  # same seeds, same results
        assert evaluations == expected[unit_id][2], unit_id  # every evaluation kept exactly once


def test_plan_measures_costs(two_task_data):
    spec = small_spec(two_task_data)
    spec.repeats = 10
    rows = plan_grid(spec, samples=1)
    assert len(rows) == 4
    for r in rows:
        assert r["eval_s"] > 0 and r["parameters"] == 3
        assert r["core_hours"] == pytest.approx(10 * r["run_hours"])


def test_unit_ids_are_stable():
    assert Unit("mujoco", "single,cube", "shared", 3).id == "mujoco-single+cube-shared-s3"
