"""Run stores of version 1 (vectors, scores and every generation's population as JSON text) stay usable:
read by the report, `compare` and `export`, and resumed in their own format; version 2 keeps one population."""

import json
import shutil
import sqlite3
from pathlib import Path

import numpy as np
import pytest

from simtune.compare import curve_from_store
from simtune.export import export_run
from simtune.fitness import Score, TaskScore
from simtune.reference import REFERENCE_DIR
from simtune.report.collect import load_run
from simtune.runs import RunConfig, resume_run, start_run
from simtune.store import STORE_FILE, RunStore, vector_key

#: the tables of a version 1 store, as simtune 0.x created them
VERSION_1_SCHEMA = """
CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE evaluations (
    id INTEGER PRIMARY KEY, key TEXT UNIQUE NOT NULL, x TEXT NOT NULL, fitness REAL NOT NULL,
    wrist_error REAL, object_error REAL, stable INTEGER NOT NULL, pruned INTEGER NOT NULL DEFAULT 0,
    score TEXT NOT NULL, generation INTEGER NOT NULL, wall_s REAL NOT NULL, finished_at REAL NOT NULL
);
CREATE TABLE generations (
    generation INTEGER PRIMARY KEY, best_fitness REAL NOT NULL, best_x TEXT NOT NULL, population TEXT NOT NULL,
    energies TEXT NOT NULL, evaluations INTEGER NOT NULL, elapsed_s REAL NOT NULL, finished_at REAL NOT NULL
);
CREATE TABLE residuals (key TEXT PRIMARY KEY, r BLOB NOT NULL);
CREATE TABLE retried (key TEXT PRIMARY KEY);
"""


def config(**kw) -> RunConfig:
    base = dict(
        engine="mujoco",
        tasks="cube",
        space="extended",
        data=str(REFERENCE_DIR),
        seed=5,
        max_generations=3,
        only=["command_delay", "max_velocity_joint_2"],
    )
    return RunConfig(**{**base, **kw})


def as_version_1(run_dir: Path, populations: dict[int, np.ndarray]) -> None:
    """Rewrite the (version 2) store of ``run_dir`` as a version 1 store of the same run, by plain SQL.

    Version 2 keeps only the last population: ``populations`` gives every generation's, as version 1 held them.
    """
    store = RunStore(run_dir)
    meta = store.db.execute("SELECT key, value FROM meta").fetchall()
    rows = store.db.execute(
        "SELECT id, x, fitness, wrist_error, object_error, stable, pruned, generation, wall_s, finished_at"
        " FROM evaluations ORDER BY id"
    ).fetchall()
    scores = [store.lookup(np.frombuffer(r[1])) for r in rows]
    generations = store.db.execute(
        "SELECT generation, best_fitness, best_x, evaluations, elapsed_s, finished_at FROM generations"
    ).fetchall()
    store.close()
    (run_dir / STORE_FILE).unlink()
    db = sqlite3.connect(run_dir / STORE_FILE)
    db.executescript(VERSION_1_SCHEMA)
    db.executemany("INSERT INTO meta VALUES (?, ?)", meta)
    db.execute("UPDATE meta SET value = '1' WHERE key = 'schema_version'")
    for r, score in zip(rows, scores):
        x = np.frombuffer(r[1]).tolist()
        db.execute(
            "INSERT INTO evaluations VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
            (r[0], vector_key(x), json.dumps(x), *r[2:7], json.dumps(score.to_dict()), *r[7:]),
        )
    for g, best_fitness, best_x, evaluations, elapsed_s, finished_at in generations:
        population = np.asarray(populations[g][0])
        db.execute(
            "INSERT INTO generations VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
            (
                g,
                best_fitness,
                json.dumps(np.frombuffer(best_x).tolist()),
                json.dumps(population.tolist()),
                json.dumps(np.asarray(populations[g][1]).tolist()),
                evaluations,
                elapsed_s,
                finished_at,
            ),
        )
    db.commit()
    db.close()


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """A finished run in this version's store, and the same run's store rewritten as version 1."""
    root = tmp_path_factory.mktemp("versions")
    populations: dict[int, tuple] = {}
    from simtune.store import RunStore as Store

    record = Store.record_generation

    def spy(self, generation, population, energies, *args, **kwargs):  # every population, as version 1 kept them
        populations[generation] = (np.array(population, dtype=float), np.array(energies, dtype=float))
        return record(self, generation, population, energies, *args, **kwargs)

    Store.record_generation = spy
    try:
        result = start_run(config(), root / "new", show_progress=False)
    finally:
        Store.record_generation = record
    shutil.copytree(root / "new", root / "old")
    as_version_1(root / "old", populations)
    return root / "new", root / "old", result, populations


def test_a_new_store_keeps_binary_vectors_and_only_the_last_population(runs):
    new, _, result, populations = runs
    store = RunStore.open_read_only(new)
    assert store.version == 2
    kinds = store.db.execute("SELECT DISTINCT typeof(key), typeof(x) FROM evaluations").fetchall()
    assert kinds == [("blob", "blob")]
    held = store.db.execute("SELECT generation FROM generations WHERE population IS NOT NULL").fetchall()
    assert held == [(3,)] and len(store.generations()) == 3
    last = store.last_checkpoint()
    np.testing.assert_array_equal(last["population"], populations[3][0])
    np.testing.assert_array_equal(last["energies"], populations[3][1])
    np.testing.assert_array_equal(store.best_evaluation()["x"], result.x)
    store.close()


def test_a_version_1_store_reads_as_the_same_run(runs):
    new, old, _, populations = runs
    stores = [RunStore.open_read_only(new), RunStore.open_read_only(old)]
    assert [s.version for s in stores] == [2, 1]
    a, b = stores
    assert a.evaluations() == b.evaluations()
    assert a.best_evaluation() == b.best_evaluation()
    assert a.generations() == b.generations()
    assert a.initial_population() == b.initial_population()
    x = a.evaluations()[4]["x"]
    assert a.lookup(x) == b.lookup(x)
    for g in (1, 2):  # version 1 kept every generation's population
        np.testing.assert_array_equal(b.last_checkpoint(up_to=g)["population"], populations[g][0])
    for s in stores:
        s.close()
    # the report, `compare` and `export` read it
    record = load_run(old)
    assert record.best_fitness == load_run(new).best_fitness
    assert curve_from_store(old, 10)[0] == curve_from_store(new, 10)[0]


def test_a_version_1_store_exports_the_same_model(runs, tmp_path):
    new, old, _, _ = runs
    exported = {}
    for name, run_dir in (("new", new), ("old", old)):
        export_run(run_dir, tmp_path / name, engine="mujoco")
        exported[name] = {
            p.relative_to(tmp_path / name): [line for line in p.read_text().splitlines() if str(run_dir) not in line]
            for p in sorted((tmp_path / name).rglob("*"))
            if p.is_file() and p.suffix in (".xml", ".yaml")
        }
    assert exported["old"] and exported["old"] == exported["new"]


def test_a_version_1_run_resumes_in_its_own_format_losing_and_redoing_nothing(runs, tmp_path):
    _, old, reference, _ = runs
    run_dir = tmp_path / "crashed"
    shutil.copytree(old, run_dir)
    (run_dir / "best_params.json").unlink()
    with sqlite3.connect(run_dir / STORE_FILE) as db:  # cut back to what a kill in the last generation leaves
        kept = db.execute("SELECT MIN(id) + 1 FROM evaluations WHERE generation = 3").fetchone()[0]
        lost = db.execute("DELETE FROM evaluations WHERE id > ?", (kept,)).rowcount
        db.execute("DELETE FROM generations WHERE generation >= 3")
        db.execute("UPDATE meta SET value = ? WHERE key = 'status'", ('"running"',))
    assert lost > 0
    resumed = resume_run(run_dir, show_progress=False)
    assert resumed.new_evaluations == lost
    assert resumed.evaluations == reference.evaluations
    assert resumed.fitness == reference.fitness
    np.testing.assert_array_equal(resumed.x, reference.x)
    store = RunStore.open_read_only(run_dir)
    assert store.version == 1
    assert store.db.execute("SELECT DISTINCT typeof(x) FROM evaluations").fetchall() == [("text",)]
    assert len(store.generations()) == 3 and store.last_checkpoint(up_to=1) is not None
    store.close()


def test_scores_come_back_from_the_store_exactly(tmp_path):
    store = RunStore(tmp_path, create=True)
    one = Score.combine([TaskScore("cube", 0.1 + 0.2, 0.1, 0.2, steps=5000)])
    two = Score.combine(
        [
            TaskScore("cube", 1 / 3, 0.25, 1 / 3 - 0.25, steps=17),
            TaskScore("single", 10.0, 2.5, None, False, "unstable at t=1.00 s: wrist 3.0 m from the base", steps=9),
        ]
    )
    pruned = Score.combine([TaskScore("cube", 0.5, 0.5, None, True, "pruned at t=0.40 s", pruned=True, steps=300)])
    for i, score in enumerate((one, two, pruned, Score(1.0, 0.5, None))):
        x = np.array([i, np.pi, -0.0])
        store.record_evaluation(x, score, 0, 0.1)
        assert store.lookup(x) == score
        assert store.lookup(x.copy()) is not None and store.lookup(x + 1e-16 * (i + 1) + 1e-12) is None
    store.close()
