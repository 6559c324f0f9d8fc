"""Experiment grids: local and Dask executors agree, a killed worker loses nothing."""

import glob
import os
import pwd
import shutil
import signal
import subprocess
import tempfile
import threading
import time
from pathlib import Path

import pytest
from conftest import stored_evaluations

from simtune.errors import SimtuneError
from simtune.grid import GridIndex, GridSpec, PostgresGridIndex, SQLiteGridIndex, Unit, open_index, plan_grid, run_grid
from simtune.store import RunStore

distributed = pytest.importorskip("distributed")


def small_spec(root) -> GridSpec:
    return GridSpec(
        engines=["mujoco", "pybullet"],
        tasks=["single", "cube"],
        spaces=["extended"],
        repeats=2,
        data=str(root),
        max_generations=2,
        only=["command_delay", "max_velocity_joint_2", "marker_offset_z"],
    )


def results(index: GridIndex) -> dict[str, tuple]:
    return {r["id"]: (r["status"], r["fitness"], r["evaluations"]) for r in index.rows()}


@pytest.fixture(scope="module")
def local_grid(two_task_data, tmp_path_factory):
    grid_dir = tmp_path_factory.mktemp("local")
    index = run_grid(small_spec(two_task_data), grid_dir, executor="local", workers=2)
    return grid_dir, results(index)


@pytest.mark.slow  # the local grid fixture: 17 s
def test_local_grid_runs_every_unit_once(local_grid):
    grid_dir, res = local_grid
    assert len(res) == 8 and all(status == "done" for status, _, _ in res.values())
    for unit_id, (_, fitness, evaluations) in res.items():
        store = RunStore(grid_dir / "runs" / unit_id)
        assert store.count_evaluations() == evaluations
        assert store.best_evaluation()["score"]["fitness"] == pytest.approx(fitness)


@pytest.mark.slow  # the local grid fixture: 17 s
def test_running_again_skips_finished_units(local_grid, two_task_data):
    grid_dir, res = local_grid
    before = {u: RunStore(grid_dir / "runs" / u).count_evaluations() for u in res}
    index = run_grid(small_spec(two_task_data), grid_dir, executor="local", workers=2)
    assert results(index) == res
    # nothing simulated again: every store holds what it held
    assert {u: RunStore(grid_dir / "runs" / u).count_evaluations() for u in res} == before


@pytest.mark.slow
def test_dask_grid_with_a_killed_worker_matches_local(local_grid, two_task_data, tmp_path):
    _, expected = local_grid
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    client = distributed.Client(cluster)
    grid_dir = tmp_path / "dask"
    outcome = {}

    def run():
        outcome["index"] = results(
            run_grid(small_spec(two_task_data), grid_dir, executor="dask", scheduler=cluster.scheduler_address)
        )

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
        counts = open_index(grid_dir).counts()
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


# --- a PostgreSQL index ------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def postgres_url():
    """A throwaway PostgreSQL server on a Unix socket (Debian's postgresql package; .ci/run installs it)."""
    pytest.importorskip("psycopg")
    found = sorted(glob.glob("/usr/lib/postgresql/*/bin/initdb")) or (
        [shutil.which("initdb")] if shutil.which("initdb") else []
    )
    if not found:
        pytest.skip("PostgreSQL server programs not installed (apt-get install postgresql)")
    bindir = Path(found[-1]).parent
    root = Path(tempfile.mkdtemp(prefix="simtune-pg-"))
    as_user: list[str] = []
    if os.geteuid() == 0:  # PostgreSQL refuses to run as root
        try:
            owner = pwd.getpwnam("postgres")
        except KeyError:
            pytest.skip("running as root and there is no postgres user to run PostgreSQL as")
        os.chown(root, owner.pw_uid, owner.pw_gid)
        as_user = ["runuser", "-u", "postgres", "--"]
    data = root / "data"
    subprocess.run(
        as_user + [str(bindir / "initdb"), "-D", str(data), "-A", "trust", "-U", "simtune", "--no-sync"],
        check=True,
        capture_output=True,
    )
    subprocess.run(
        as_user
        + [
            str(bindir / "pg_ctl"),
            "-D",
            str(data),
            "-l",
            str(root / "log"),
            "-w",
            "-o",
            f"-k {root} -c listen_addresses='' -c fsync=off",
            "start",
        ],
        check=True,
        capture_output=True,
    )
    try:
        yield f"postgresql://simtune@/postgres?host={root}"
    finally:
        subprocess.run(
            as_user + [str(bindir / "pg_ctl"), "-D", str(data), "-m", "immediate", "stop"], capture_output=True
        )
        shutil.rmtree(root, ignore_errors=True)


@pytest.mark.slow  # the local grid fixture: 17 s
def test_postgres_index_records_the_same_grid(local_grid, two_task_data, postgres_url, tmp_path):
    grid_dir, expected = local_grid
    # a fresh index for a finished grid: every unit resumes from its store, nothing is simulated again
    before = {u: RunStore(grid_dir / "runs" / u).count_evaluations() for u in expected}
    index = run_grid(small_spec(two_task_data), grid_dir, executor="local", workers=2, index_url=postgres_url)
    assert index.location.startswith("postgresql://")
    assert results(index) == expected
    assert {u: RunStore(grid_dir / "runs" / u).count_evaluations() for u in expected} == before
    assert dict(index.counts()) == {"done": 8}
    assert len(list(index.best())) == 4
    # again: finished units are skipped; another grid in the same database is kept apart
    again = run_grid(small_spec(two_task_data), grid_dir, executor="local", workers=2, index_url=postgres_url)
    assert results(again) == results(index)
    other = open_index(tmp_path / "other", postgres_url)
    other.add([Unit("mujoco", "cube", "shared", 0)])
    assert [r["id"] for r in other.rows()] == ["mujoco-cube-shared-s0"]
    assert len(open_index(grid_dir, postgres_url).rows()) == 8


def test_bad_index_urls_are_named(tmp_path):
    with pytest.raises(SimtuneError, match="not a postgresql:// URL"):
        open_index(tmp_path, "mysql://someone@host/db")
    pytest.importorskip("psycopg")
    with pytest.raises(SimtuneError, match=r"cannot open grid index postgresql://bob:\*\*\*@"):
        open_index(tmp_path, f"postgresql://bob:secret@/db?host={tmp_path}/nowhere")


@pytest.fixture(params=["sqlite", "postgresql"])
def index_url(request) -> str | None:
    return None if request.param == "sqlite" else request.getfixturevalue("postgres_url")


def test_both_index_classes_keep_the_same_record(index_url, tmp_path):
    index = open_index(tmp_path / "grid", index_url)
    assert isinstance(index, SQLiteGridIndex if index_url is None else PostgresGridIndex)
    a, b, c = (
        Unit("mujoco", "cube", "shared", 0),
        Unit("mujoco", "cube", "shared", 1),
        Unit("ode", "single", "shared", 0),
    )
    index.add([a, b, c])
    assert index.counts() == {"pending": 3}
    index.mark(a, "running")
    index.mark(a, "done", {"fitness": 0.25, "generic_fitness": 0.5, "evaluations": 7, "generations": 2, "wall_s": 1.5})
    index.mark(b, "running")
    index.mark(b, "pending", error="worker process died")
    index.mark(b, "running")
    index.mark(b, "done", {"fitness": 0.125})
    index.mark(c, "running")
    index.mark(c, "failed", error="no recordings")
    index.add([a, b, c])  # again: known units keep their rows
    index.set_meta("spec", "{}")
    index.set_meta("spec", '{"repeats": 2}')
    assert (index.status(a), index.attempts(a), index.attempts(b), index.attempts(c)) == ("done", 1, 2, 1)
    assert index.counts() == {"done": 2, "failed": 1}
    assert list(index.best()) == [("mujoco", "cube", 0.125)]
    rows = {r["id"]: r for r in index.rows()}
    assert list(rows) == sorted(u.id for u in (a, b, c))
    assert (rows[a.id]["fitness"], rows[a.id]["evaluations"], rows[a.id]["wall_s"]) == (0.25, 7, 1.5)
    assert rows[b.id]["error"] is None and rows[c.id]["error"] == "no recordings"
    assert rows[a.id]["run_dir"] == str(index.run_dir(a)) == str(tmp_path / "grid" / "runs" / a.id)
    index.close()
    again = open_index(tmp_path / "grid", index_url)  # the record outlives the connection
    assert again.counts() == {"done": 2, "failed": 1}
    again.close()


def test_a_grid_run_again_with_other_settings_is_refused_not_reported_as_done(two_task_data, tmp_path):
    """Probe 5 #10: the same --out with another --data or --only reported every old cell `done` with its old
    fitness, and a run of other settings copied into a cell's folder was adopted as that cell."""
    from dataclasses import replace

    spec = GridSpec(
        engines=["mujoco"], tasks=["single"], spaces=["extended"], repeats=1, data=str(two_task_data),
        max_generations=1, only=["command_delay"],
    )  # fmt: skip
    grid_dir = tmp_path / "grid"
    (row,) = run_grid(spec, grid_dir, executor="local", workers=1).rows()
    assert row["status"] == "done"
    cell = grid_dir / "runs" / row["id"]
    stored = RunStore(cell).count_evaluations()
    with pytest.raises(SimtuneError, match=r"holds a run with other settings \(only differ"):
        run_grid(replace(spec, only=["command_delay", "marker_offset_z"]), grid_dir, executor="local", workers=1)
    # a run of other settings copied into a new grid's cell folder: refused, its store as it was
    other = tmp_path / "other"
    shutil.copytree(grid_dir, other)
    with pytest.raises(SimtuneError, match=r"\(max_generations differ"):
        run_grid(replace(spec, max_generations=2), other, executor="local", workers=1)
    assert RunStore(cell).count_evaluations() == stored == RunStore(other / "runs" / row["id"]).count_evaluations()
