"""Run folders under stress: racing processes, changed data, pauses, Ctrl-C, damaged or foreign stores.

Every run here is a real (short) tuning run of MuJoCo on the shipped reference
recording; folders and data roots are built by the tests.
"""

import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest
from conftest import kill_when, stored_evaluations

from simtune.errors import ConfigError, SimtuneError
from simtune.optimize import OPTIMIZERS
from simtune.optimize.evaluator import TIMEOUT_REASON, failed_score, timed_out
from simtune.reference import REFERENCE_DIR
from simtune.runs import RunConfig, fingerprint_differences, resume_run, start_run, write_json_atomic
from simtune.store import STORE_FILE, RunStore
from simtune.store.lock import LOCK_FILE

ONLY = ["command_delay", "max_velocity_joint_2"]


def config(**kw) -> RunConfig:
    base = dict(
        engine="mujoco",
        tasks="cube",
        space="extended",
        data=str(REFERENCE_DIR),
        seed=3,
        max_generations=2,
        only=ONLY,
        optimizer="de",
    )
    base.update(kw)
    return RunConfig(**base)


def tune_cmd(out: Path, *extra: str, data: Path = REFERENCE_DIR) -> list[str]:
    """A short tune: differential evolution (its kills and resumes count DE's generations of 1 x D trials)."""
    return [
        sys.executable,
        "-m",
        "simtune.cli",
        "tune",
        "--task",
        "cube",
        "--data",
        str(data),
        "--only",
        ",".join(ONLY),
        "--out",
        str(out),
        "--quiet",
        "--optimizer",
        "de",
        *extra,
    ]


def resume_cmd(run_dir: Path, *extra: str) -> list[str]:
    return [sys.executable, "-m", "simtune.cli", "resume", str(run_dir), "--quiet", *extra]


def run(cmd: list[str]) -> subprocess.CompletedProcess:
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300)


def one_line_error(proc: subprocess.CompletedProcess, *fragments: str) -> str:
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    return lines[0]


def wait_for_holder(run_dir: Path, proc: subprocess.Popen, limit_s: float = 120) -> None:
    """Until ``proc`` holds the run folder's lock (it wrote its process id into the lock file)."""
    deadline = time.time() + limit_s
    while time.time() < deadline and proc.poll() is None:
        try:
            if json.loads((run_dir / LOCK_FILE).read_text() or "{}").get("pid") == proc.pid:
                return
        except (OSError, ValueError):
            pass
        time.sleep(0.02)
    raise AssertionError("the first process never took the lock")


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory) -> Path:
    """A short finished run (2 generations of DE on two parameters), to be copied by each test."""
    run_dir = tmp_path_factory.mktemp("finished") / "run"
    start_run(config(), run_dir, show_progress=False)
    return run_dir


def copy_run(run_dir: Path, to: Path) -> Path:
    shutil.copytree(run_dir, to)
    return to


# --- one writer per run folder ------------------------------------------------------------------------------
@pytest.mark.slow  # two `simtune tune` processes at once (about 11 s)
def test_two_tunes_on_one_folder_one_runs_the_other_is_refused_at_once(tmp_path):
    out = tmp_path / "latest"
    first = subprocess.Popen(
        tune_cmd(out, "--seed", "0", "--max-generations", "3", "--json"),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    wait_for_holder(out, first)
    first.send_signal(signal.SIGSTOP)  # holding the lock, mid-run, for as long as the second one takes
    try:
        second = run(tune_cmd(out, "--seed", "5", "--max-generations", "3"))
    finally:
        first.send_signal(signal.SIGCONT)
    one_line_error(second, str(out), f"process {first.pid}", "simtune tune")
    stdout, stderr = first.communicate(timeout=300)
    assert first.returncode == 0, stderr
    reported = json.loads(stdout)
    store = RunStore(out)
    assert store.get("config")["seed"] == 0
    rows = store.evaluations()
    assert len(rows) == reported["evaluations"]  # nothing from the refused seed-5 run
    assert len({tuple(r["x"]) for r in rows}) == len(rows)
    store.close()


@pytest.mark.slow  # 9 s
def test_two_resumes_of_one_run_one_continues_the_other_is_refused_at_once(tmp_path):
    run_dir = tmp_path / "run"
    kept = kill_when(tune_cmd(run_dir, "--max-generations", "3", "--no-prune"), run_dir, 8)
    assert kept >= 8
    first = subprocess.Popen(resume_cmd(run_dir), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wait_for_holder(run_dir, first)
    first.send_signal(signal.SIGSTOP)
    try:
        second = run(resume_cmd(run_dir))
    finally:
        first.send_signal(signal.SIGCONT)
    one_line_error(second, f"process {first.pid}", "simtune resume")
    _, stderr = first.communicate(timeout=300)
    assert first.returncode == 0, stderr
    store = RunStore(run_dir)
    assert store.get("status") == "finished"
    assert len({tuple(r["x"]) for r in store.evaluations()}) == store.count_evaluations()
    store.close()


def test_best_params_are_written_whole_by_concurrent_writers(tmp_path):
    path = tmp_path / "best_params.json"
    errors = []

    def write(n: int) -> None:
        try:
            for i in range(50):
                write_json_atomic(path, {"writer": n, "i": i, "pad": "x" * 2000})
        except Exception as exc:  # a shared temporary name would collide here
            errors.append(exc)

    threads = [threading.Thread(target=write, args=(n,)) for n in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    assert json.loads(path.read_text())["i"] == 49
    assert [p.name for p in tmp_path.iterdir()] == ["best_params.json"]  # no temporary file left


# --- the data a run was tuned on -----------------------------------------------------------------------------
def _data_root(tmp_path: Path) -> Path:
    root = tmp_path / "data"
    shutil.copytree(REFERENCE_DIR / "cube", root / "cube")
    return root


@pytest.mark.slow  # about 11 s: a killed run, a refused resume and a rescored one
def test_resume_after_the_data_changed_is_refused_naming_the_file_and_rescore_starts_anew(tmp_path):
    data = _data_root(tmp_path)
    run_dir = tmp_path / "run"
    kept = kill_when(tune_cmd(run_dir, "--max-generations", "4", "--no-prune", data=data), run_dir, 13)
    assert kept >= 13
    old = RunStore(run_dir)
    old_population = old.last_checkpoint()["population"]
    old_generic = old.get("generic")["fitness"]
    old_count = old.count_evaluations()
    old.close()
    # one repeat replaced by another: still a valid recording, different data
    shutil.copy(data / "cube" / "cube0001.tsv.gz", data / "cube" / "cube0002.tsv.gz")

    one_line_error(run(resume_cmd(run_dir)), "cube/cube0002.tsv.gz changed", "--rescore")
    assert stored_evaluations(run_dir) == old_count  # refused before anything was written

    proc = run(resume_cmd(run_dir, "--rescore", "--json"))
    assert proc.returncode == 0, proc.stderr
    superseded = list((run_dir / "superseded").glob("run-*.sqlite"))
    assert len(superseded) == 1
    archived = RunStore(run_dir / "superseded", filename=superseded[0].name)
    assert archived.count_evaluations() == old_count  # the old run is kept whole
    archived.close()
    new = RunStore(run_dir)
    assert new.get("generic")["fitness"] != old_generic  # scored anew on the new data
    assert new.get("rescored_from")["changes"] == ["cube/cube0002.tsv.gz changed"]
    first_generation = [r["x"] for r in new.evaluations() if r["generation"] == 0]
    # started from the old population: SciPy's DE holds its population scaled to the unit cube, and scaling a
    # member there and back may move it by an ulp (it did once the data moved these values)
    np.testing.assert_allclose(np.array(first_generation), old_population, rtol=4 * np.finfo(float).eps, atol=0)
    new.close()
    assert run(resume_cmd(run_dir)).returncode == 0  # the new run resumes normally on the new data


def test_fingerprint_names_changed_tasks_and_engine_versions():
    stored = {"data": {"cube": [{"file": "a.tsv", "bytes": 3, "sha256": "1"}]}, "tasks": {"cube": "x"}, "engine": "m 1"}
    now = {
        "data": {"cube": [{"file": "a.tsv", "bytes": 3, "sha256": "2"}, {"file": "b.tsv", "bytes": 3, "sha256": "3"}]},
        "tasks": {"cube": "y"},
        "engine": "m 2",
    }
    assert fingerprint_differences(stored, now) == [
        "cube/a.tsv changed",
        "cube/b.tsv added",
        "the definition of task 'cube' changed",
        "engine m 1 is now m 2",
    ]
    assert fingerprint_differences(stored, stored) == []


# the default tier rescores differential evolution; the other optimisers (about 3 s each) in the slow tier
@pytest.mark.parametrize(
    "optimizer", [pytest.param(name, marks=[] if name == "de" else [pytest.mark.slow]) for name in OPTIMIZERS]
)
def test_rescore_starts_every_optimizer_from_the_old_population(optimizer, tmp_path):
    data = _data_root(tmp_path)
    # auto opens with a least-squares phase (no population) before its first DE population
    budget = 60 if optimizer == "auto" else 12
    cfg = config(optimizer=optimizer, data=str(data), max_evaluations=budget, max_generations=1000, workers=1)
    start_run(cfg, tmp_path / "run", show_progress=False)
    store = RunStore(tmp_path / "run")
    checkpoint = store.last_checkpoint()
    assert checkpoint is not None, "the run ended before its first population"
    last = checkpoint["population"]
    store.close()
    shutil.copy(data / "cube" / "cube0001.tsv.gz", data / "cube" / "cube0003.tsv.gz")
    with pytest.raises(SimtuneError, match=r"cube/cube0003.tsv.gz changed"):
        resume_run(tmp_path / "run", show_progress=False)
    resume_run(tmp_path / "run", show_progress=False, rescore=True)
    store = RunStore(tmp_path / "run")
    xs = np.array([r["x"] for r in store.evaluations()])
    store.close()
    # the first points scored are the old population (auto's: through SciPy's scaling to the unit cube and back,
    # which its opening's points, not drawn by SciPy, may not survive to the last bit)
    if optimizer == "auto":
        np.testing.assert_allclose(xs[: len(last)], last, rtol=1e-14, atol=0)
    else:
        np.testing.assert_array_equal(xs[: len(last)], last)


# --- pauses and time-outs --------------------------------------------------------------------------------------
@pytest.mark.slow
def test_a_paused_coordinator_does_not_turn_evaluations_into_time_outs(tmp_path):
    out = tmp_path / "run"
    proc = subprocess.Popen(
        tune_cmd(out, "--workers", "2", "--eval-timeout", "2", "--max-generations", "10", "--no-prune"),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    for group in (False, True):  # the coordinator alone (SIGSTOP), then every process (a laptop lid)
        deadline = time.time() + 120
        start = stored_evaluations(out)
        while time.time() < deadline and stored_evaluations(out) < start + 4 and proc.poll() is None:
            time.sleep(0.05)
        assert proc.poll() is None, "the run must still be going when it is paused"
        (os.killpg if group else os.kill)(proc.pid, signal.SIGSTOP)
        time.sleep(5)  # longer than --eval-timeout
        (os.killpg if group else os.kill)(proc.pid, signal.SIGCONT)
    _, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 0, stderr
    store = RunStore(out)
    failed = [r for r in store.evaluations() if not r["stable"]]
    store.close()
    assert failed == []


def test_an_evaluation_that_timed_out_is_retried_once_on_resume(finished_run, tmp_path):
    run_dir = copy_run(finished_run, tmp_path / "run")
    store = RunStore(run_dir)
    rows = store.evaluations()
    victim = rows[3]
    reference = resume_run(copy_run(finished_run, tmp_path / "reference"), show_progress=False)
    # the store as a time-out leaves it: this evaluation recorded as failed instead of its score
    store.db.execute("DELETE FROM evaluations WHERE x = ?", (json.dumps(victim["x"]),))
    store.db.commit()
    store.record_evaluation(np.array(victim["x"]), failed_score(f"{TIMEOUT_REASON}4 s; worker replaced"), 0, 4.0)
    assert timed_out(store.lookup(victim["x"]))
    store.close()

    resumed = resume_run(run_dir, show_progress=False)
    assert resumed.new_evaluations == 1  # the failed one, simulated again; all else from the store
    assert resumed.fitness == reference.fitness
    np.testing.assert_array_equal(resumed.x, reference.x)
    store = RunStore(run_dir)
    assert store.lookup(victim["x"]).fitness == victim["fitness"]
    # once only: a failure that was already retried stays as it is
    assert store.release_failures(timed_out) == 0
    store.close()


def test_a_failure_is_released_for_retry_only_once(tmp_path):
    store = RunStore(tmp_path / "s", create=True)
    x = np.array([1.0, 2.0])
    store.record_evaluation(x, failed_score(f"{TIMEOUT_REASON}5 s; worker replaced"), 0, 5.0)
    store.record_evaluation(x + 1, failed_score("worker process died (exit code -11); worker replaced"), 0, 1.0)
    assert store.release_failures(timed_out) == 1  # only the time-out; a crash would crash again
    assert store.lookup(x) is None and store.lookup(x + 1) is not None
    store.record_evaluation(x, failed_score(f"{TIMEOUT_REASON}5 s; worker replaced"), 3, 5.0)  # failed again
    assert store.release_failures(timed_out) == 0
    assert timed_out(store.lookup(x))


# --- replayed generations ------------------------------------------------------------------------------------
def test_resume_keeps_the_counts_and_times_of_replayed_generations(finished_run, tmp_path):
    run_dir = copy_run(finished_run, tmp_path / "run")
    columns = "generation, evaluations, elapsed_s, finished_at"
    store = RunStore(run_dir)
    before = store.db.execute(f"SELECT {columns} FROM generations ORDER BY generation").fetchall()
    store.close()
    resume_run(run_dir, show_progress=False)
    store = RunStore(run_dir)
    after = store.db.execute(f"SELECT {columns} FROM generations ORDER BY generation").fetchall()
    store.close()
    assert after == before
    assert [row[1] for row in before] == sorted({row[1] for row in before})  # counts grow generation by generation


def test_a_replay_that_takes_another_path_replaces_the_later_checkpoints(tmp_path):
    store = RunStore(tmp_path / "s", create=True)
    pop = np.arange(6.0).reshape(3, 2)
    for g in (1, 2, 3):
        store.record_generation(g, pop + g, [1.0, 2.0, 3.0], pop[0] + g, 1.0, 3 * g, float(g))
    store.record_generation(2, pop + 2, [1.0, 2.0, 3.0], pop[0] + 2, 1.0, 99, 99.0)  # the same: kept
    assert [(g["generation"], g["evaluations"]) for g in store.generations()] == [(1, 3), (2, 6), (3, 9)]
    store.record_generation(2, pop - 7, [0.5, 2.0, 3.0], pop[0] - 7, 0.5, 7, 7.0)  # another path from here on
    assert [(g["generation"], g["evaluations"]) for g in store.generations()] == [(1, 3), (2, 7)]


# --- Ctrl-C ------------------------------------------------------------------------------------------------
@pytest.mark.slow  # a kill test: a run on two workers is sent SIGINT (about 5 s each)
@pytest.mark.parametrize("command", ["tune", "resume", "tune --json"])
def test_ctrl_c_exits_130_saying_how_to_resume(command, tmp_path):
    """With --json a script still gets its one object (probe 5 #22: it got none): stop_reason "interrupted"."""
    out = tmp_path / "run"
    if command == "resume":
        kill_when(tune_cmd(out, "--max-generations", "40", "--no-prune"), out, 6)
    cmd = tune_cmd(out, "--workers", "2", "--max-generations", "40", "--no-prune")  # stopped long before the end
    if command == "tune --json":
        cmd = [*cmd, "--json"]
    proc = subprocess.Popen(
        cmd if command != "resume" else resume_cmd(out),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group, as a terminal's foreground job
        # Python ignores SIGINT for good when started with it ignored (pytest run in the background)
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),  # noqa: PLW1509
    )
    start = stored_evaluations(out)
    deadline = time.time() + 120
    while time.time() < deadline and stored_evaluations(out) < start + 3 and proc.poll() is None:
        time.sleep(0.02)
    os.killpg(proc.pid, signal.SIGINT)  # Ctrl-C reaches every process of the group, workers included
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130
    assert stderr.strip().splitlines() == [f"interrupted - resume with: simtune resume {out}"], stderr
    if command == "tune --json":
        printed = json.loads(stdout)
        assert printed["stop_reason"] == "interrupted" and printed["run_dir"] == str(out)
        assert printed["resume"] == f"simtune resume {out}" and printed["evaluations"] >= 3
    store = RunStore(out)
    assert store.get("config") is not None and store.get("status") == "running"  # a run to resume
    store.close()


# --- damaged, foreign and occupied folders ----------------------------------------------------------------------
def damage_page(run_dir: Path, table: str, seed: int) -> Path:
    """Overwrite the first page of the store's ``table`` with random bytes, as a failing disk would; the store."""
    path = run_dir / STORE_FILE
    store = RunStore(run_dir)
    page_size = store.db.execute("PRAGMA page_size").fetchone()[0]
    root = store.db.execute("SELECT rootpage FROM sqlite_master WHERE name = ?", (table,)).fetchone()[0]
    store.close()
    with open(path, "r+b") as fh:
        fh.seek((root - 1) * page_size)
        fh.write(np.random.default_rng(seed).bytes(page_size))
    return path


def test_resume_of_a_store_with_a_damaged_page_is_one_line(finished_run, tmp_path):
    run_dir = copy_run(finished_run, tmp_path / "run")
    path = damage_page(run_dir, "evaluations", 0)
    one_line_error(run(resume_cmd(run_dir)), str(path), "damaged")


def test_report_and_export_refuse_a_store_with_a_damaged_page_as_resume_does(finished_run, tmp_path):
    """They used to read around the damage and report or export from it without a word."""
    run_dir = copy_run(finished_run, tmp_path / "run")
    path = damage_page(run_dir, "generations", 1)
    export = [sys.executable, "-m", "simtune.cli", "export", str(run_dir), "--out", str(tmp_path / "export")]
    one_line_error(run(export), str(path), "damaged")
    # a report skips an unusable run of several with a warning naming it: here the only one, so nothing to report
    report = run([sys.executable, "-m", "simtune.cli", "report", str(run_dir), "--out", str(tmp_path / "report")])
    assert report.returncode == 2 and "Traceback" not in report.stderr
    assert f"{path} is damaged" in report.stderr and "no finished runs to report" in report.stderr
    assert not (tmp_path / "export").exists() and not (tmp_path / "report").exists()


def test_resuming_a_finished_run_keeps_its_wall_time(finished_run, tmp_path):
    """A finished run resumed replays its search from the store: no tuning time, the same stored wall time."""
    from simtune.runs import read_run_record

    run_dir = copy_run(finished_run, tmp_path / "run")
    before = read_run_record(run_dir).elapsed_s
    for _ in range(2):
        again = resume_run(run_dir, show_progress=False)
        assert again.new_evaluations == 0 and again.wall_s == before
    assert read_run_record(run_dir).elapsed_s == before


def test_resume_names_an_unknown_key_of_the_stored_configuration(finished_run, tmp_path):
    run_dir = copy_run(finished_run, tmp_path / "run")
    store = RunStore(run_dir)
    store.set(config={**store.get("config"), "colour": "red"})
    store.close()
    one_line_error(run(resume_cmd(run_dir)), "unknown key 'colour'")
    with pytest.raises(ConfigError, match="seed must be an integer"):
        RunConfig.from_stored({**config().__dict__, "seed": -1}, "x")


def test_resume_reads_a_foreign_store_without_writing_to_it(tmp_path):
    import sqlite3

    folder = tmp_path / "mine"
    folder.mkdir()
    db = sqlite3.connect(folder / STORE_FILE)
    db.execute("CREATE TABLE notes (text TEXT)")
    db.execute("INSERT INTO notes VALUES ('keep me')")
    db.commit()
    db.close()
    digest = hashlib.sha256((folder / STORE_FILE).read_bytes()).hexdigest()
    one_line_error(run(resume_cmd(folder)), "not a simtune run store", "left unchanged")
    assert hashlib.sha256((folder / STORE_FILE).read_bytes()).hexdigest() == digest
    assert sorted(p.name for p in folder.iterdir()) == [STORE_FILE]  # no lock file, journal or tables added
    one_line_error(run(tune_cmd(folder)), "not a simtune run store")  # nor will tune overwrite it


def test_a_users_meta_table_is_never_taken_for_a_store_set_up_halfway(tmp_path):
    """Probe 5 #17: a run.sqlite holding only a table named ``meta`` (a user's, with rows) was taken for a store whose
    process died while creating it, and `tune` deleted its rows."""
    import sqlite3

    folder = tmp_path / "p25"
    folder.mkdir()
    db = sqlite3.connect(folder / STORE_FILE)
    db.execute("CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT)")
    db.execute("INSERT INTO meta VALUES ('owner', 'me')")
    db.commit()
    db.close()
    digest = hashlib.sha256((folder / STORE_FILE).read_bytes()).hexdigest()
    one_line_error(run(resume_cmd(folder)), "not a simtune run store", "left unchanged")
    one_line_error(run(tune_cmd(folder, "--max-generations", "1")), "not a simtune run store", "left unchanged")
    assert hashlib.sha256((folder / STORE_FILE).read_bytes()).hexdigest() == digest


def test_tune_into_a_folder_with_other_files_is_refused(tmp_path):
    folder = tmp_path / "results"
    folder.mkdir()
    (folder / "best_params.json").write_text('{"mine": 1}')
    one_line_error(run(tune_cmd(folder, "--max-generations", "1")), "not empty", "best_params.json")
    assert (folder / "best_params.json").read_text() == '{"mine": 1}'
    assert sorted(p.name for p in folder.iterdir()) == ["best_params.json"]


def test_a_run_killed_while_being_set_up_can_be_started_again(tmp_path):
    run_dir = tmp_path / "run"
    RunStore(run_dir, create=True).close()  # the store exists, its configuration was never written
    with pytest.raises(SimtuneError, match="never set up"):
        resume_run(run_dir, show_progress=False)
    start_run(config(max_generations=1), run_dir, show_progress=False)
    assert RunStore(run_dir).get("status") == "finished"


@pytest.mark.parametrize("left", ["empty file", "empty database", "tables without a version"])
def test_a_store_killed_while_being_created_is_replaced_not_refused(tmp_path, left):
    # a kill -9 (or a Dask worker killed) inside RunStore(create=True) leaves one of these behind
    import sqlite3

    from simtune.store import _SCHEMA

    run_dir = tmp_path / "run"
    run_dir.mkdir()
    path = run_dir / "run.sqlite"
    if left == "empty file":
        path.write_bytes(b"")
    else:
        db = sqlite3.connect(path)
        db.execute("PRAGMA user_version = 0")
        if left == "tables without a version":
            db.executescript(_SCHEMA)
        db.commit()
        db.close()
    with pytest.raises(SimtuneError, match="never set up"):
        resume_run(run_dir, show_progress=False)
    start_run(config(max_generations=1), run_dir, show_progress=False)
    assert RunStore(run_dir).get("status") == "finished"


def test_the_lock_is_reentrant_removed_when_done_and_a_stale_file_does_not_block(tmp_path):
    from simtune.store.lock import RunBusy, check_free, holds, run_lock

    (tmp_path / LOCK_FILE).write_text('{"pid": 999999999, "host": "gone"}\n')  # left by a killed process
    with run_lock(tmp_path):
        with run_lock(tmp_path):  # start_run inside resume --rescore or a grid unit
            check_free(tmp_path)
        assert holds(tmp_path)
        assert json.loads((tmp_path / LOCK_FILE).read_text())["pid"] == os.getpid()
        other = subprocess.run(
            [
                sys.executable,
                "-c",
                "from simtune.store.lock import run_lock; import sys; run_lock(sys.argv[1]).__enter__()",
            ]
            + [str(tmp_path)],
            capture_output=True,
            text=True,
        )
        assert "RunBusy" in other.stderr and f"process {os.getpid()}" in other.stderr
    assert not holds(tmp_path) and not (tmp_path / LOCK_FILE).exists()
    with held_elsewhere(tmp_path) as pid, pytest.raises(RunBusy, match=f"process {pid} "):
        check_free(tmp_path)  # what tune asks before loading any data


@contextmanager
def held_elsewhere(folder: Path):
    """Another process holds ``folder``'s run lock meanwhile; yields its process id."""
    holder = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys, time; from simtune.store.lock import run_lock\n"
            "with run_lock(sys.argv[1]):\n    print('held', flush=True); time.sleep(60)",
            str(folder),
        ],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout.readline().strip() == "held"
        yield holder.pid
    finally:
        holder.kill()
        holder.wait()


def test_a_grid_unit_whose_folder_another_process_writes_is_refused(tmp_path):
    from simtune.grid import GridSpec, Unit, run_unit
    from simtune.store.lock import RunBusy

    unit = Unit("mujoco", "cube", "extended", 0)
    spec = GridSpec(["mujoco"], ["cube"], ["extended"], 1, str(REFERENCE_DIR), max_generations=1, only=ONLY)
    folder = tmp_path / unit.id
    folder.mkdir()
    with held_elsewhere(folder) as pid, pytest.raises(RunBusy, match=f"process {pid} "):
        run_unit(unit, str(folder), spec)
    assert sorted(p.name for p in folder.iterdir()) == [LOCK_FILE]  # no store: only the killed holder's lock file
