"""Run stores of every version stay usable: version 1 (vectors, scores and every generation's population as JSON
text) and version 2 (every vector as float64, one population) are read by the report, `compare` and `export`, and
resumed in their own format; version 3 keeps the exact vector only where it is read (the best, generation 0).

tests/fixtures/stores/ holds a small finished run of each version as the simtune of that format wrote it
(its README says how): each opens, reports, exports and resumes."""

import json
import re
import shutil
import sqlite3
from contextlib import closing
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import simtune
from simtune.cli import app
from simtune.export import export_run
from simtune.fitness import PENALTY, Score, TaskScore, pruned_message
from simtune.reference import REFERENCE_DIR
from simtune.reference.make import make as make_reference
from simtune.report.collect import load_run
from simtune.runs import BEST_PARAMS_FILE, RunConfig, read_run_record, resume_run, start_run
from simtune.store import STORE_FILE, RunStore, vector_key
from simtune.studies.compare import curve_from_store


def config(**kw) -> RunConfig:
    base = dict(
        engine="mujoco",
        tasks="cube",
        space="extended",
        data=str(REFERENCE_DIR),
        seed=5,
        max_generations=3,
        only=["command_delay", "max_velocity_joint_2"],
        optimizer="de",
    )
    return RunConfig(**{**base, **kw})


def as_version_1(run_dir: Path, populations: dict[int, np.ndarray]) -> None:
    """Rewrite the version 2 store of ``run_dir`` as a version 1 store of the same run, by plain SQL.

    Version 2 keeps only the last population: ``populations`` gives every generation's, as version 1 held them.
    """
    store = RunStore(run_dir)
    assert store.version == 2
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
    RunStore(run_dir, create=True, version=1).close()  # the tables of version 1, as simtune 0.x created them
    db = sqlite3.connect(run_dir / STORE_FILE)
    db.executemany("INSERT OR REPLACE INTO meta VALUES (?, ?)", meta)
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
    """One run in a store of each version (3: this simtune's; 2: the same run written as version 2; 1: that store
    rewritten as version 1), the run's result, every population and every vector it evaluated, in order."""
    root = tmp_path_factory.mktemp("versions")
    populations: dict[int, tuple] = {}
    vectors: list[np.ndarray] = []
    record_generation, record_evaluation = RunStore.record_generation, RunStore.record_evaluation

    def spy_generation(self, generation, population, energies, *args, **kwargs):  # every population, as v1 kept them
        populations[generation] = (np.array(population, dtype=float), np.array(energies, dtype=float))
        return record_generation(self, generation, population, energies, *args, **kwargs)

    def spy_evaluation(self, x, *args, **kwargs):
        if self.run_dir == root / "v3":  # not the scratch stores of the uncertainty at the end
            vectors.append(np.array(x, dtype=float))
        return record_evaluation(self, x, *args, **kwargs)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(RunStore, "record_generation", spy_generation)
        patch.setattr(RunStore, "record_evaluation", spy_evaluation)
        result = start_run(config(), root / "v3", show_progress=False)
        patch.setattr("simtune.store.runstore.SCHEMA_VERSION", 2)  # a version 2 store, to compare
        result_v2 = start_run(config(), root / "v2", show_progress=False)
    assert result_v2.fitness == result.fitness and result_v2.evaluations == result.evaluations
    shutil.copytree(root / "v2", root / "v1")
    as_version_1(root / "v1", populations)
    return {3: root / "v3", 2: root / "v2", 1: root / "v1"}, result, populations, vectors


def test_a_new_store_keeps_exact_vectors_where_they_are_read_and_float32_elsewhere(runs):
    stores, result, populations, vectors = runs
    store = RunStore.open_read_only(stores[3])
    assert store.version == 3
    rows = store.db.execute("SELECT key, x, x32, generation, fitness FROM evaluations ORDER BY id").fetchall()
    assert len(rows) == len(vectors) == result.evaluations
    best_row = min(range(len(rows)), key=lambda i: (rows[i][4], i))
    floats32 = 0
    for i, ((key, x, x32, generation, _), wanted) in enumerate(zip(rows, vectors)):
        assert key == bytes.fromhex(vector_key(wanted))
        assert (x is None) != (x32 is None)  # one of the two, never both
        if x is None:
            floats32 += 1
            assert np.frombuffer(x32, dtype=np.float32).tobytes() == wanted.astype(np.float32).tobytes()
        else:
            assert x == wanted.tobytes()
        if generation == 0 or i == best_row:
            assert x is not None
    assert floats32 > len(rows) / 2
    # what reads vectors gets them exact: the best point, generation 0, the last population, best_params.json
    best = store.best_evaluation()
    np.testing.assert_array_equal(best["x"], result.x)
    assert best["score"]["fitness"] == result.fitness
    assert store.initial_population() == [v.tolist() for v, r in zip(vectors, rows) if r[3] == 0]
    held = store.db.execute("SELECT generation FROM generations WHERE population IS NOT NULL").fetchall()
    assert held == [(3,)] and len(store.generations()) == 3
    np.testing.assert_array_equal(store.last_checkpoint()["population"], populations[3][0])
    np.testing.assert_array_equal(store.last_checkpoint()["energies"], populations[3][1])
    store.close()
    params = json.loads((stores[3] / BEST_PARAMS_FILE).read_text())["params"]
    assert list(params.values()) == result.x.tolist()
    assert load_run(stores[3]).best_x == result.x.tolist()


def test_a_version_2_store_keeps_every_vector_exact_and_only_the_last_population(runs):
    stores, result, populations, vectors = runs
    store = RunStore.open_read_only(stores[2])
    assert store.version == 2
    kinds = store.db.execute("SELECT DISTINCT typeof(key), typeof(x) FROM evaluations").fetchall()
    assert kinds == [("blob", "blob")]
    assert [r["x"] for r in store.evaluations()] == [v.tolist() for v in vectors]
    held = store.db.execute("SELECT generation FROM generations WHERE population IS NOT NULL").fetchall()
    assert held == [(3,)] and len(store.generations()) == 3
    np.testing.assert_array_equal(store.last_checkpoint()["population"], populations[3][0])
    np.testing.assert_array_equal(store.best_evaluation()["x"], result.x)
    store.close()


def test_stores_of_every_version_read_as_the_same_run(runs):
    stores, _, populations, _ = runs
    new, v2, v1 = (RunStore.open_read_only(stores[v]) for v in (3, 2, 1))
    assert [s.version for s in (new, v2, v1)] == [3, 2, 1]
    assert v2.evaluations() == v1.evaluations()
    for rows in zip(new.evaluations(), v2.evaluations(), strict=True):  # the same, but for float32 vectors
        a, b = (dict(r) for r in rows)
        np.testing.assert_allclose(a.pop("x"), b.pop("x"), rtol=1e-7)
        assert a.pop("wall_s") >= 0 and b.pop("wall_s") >= 0  # (two runs: their times differ)
        assert a == b
    for other in (v2, v1):
        assert new.best_evaluation() == other.best_evaluation()
        untimed = [[{k: v for k, v in g.items() if k != "elapsed_s"} for g in s.generations()] for s in (new, other)]
        assert untimed[0] == untimed[1]
        assert new.initial_population() == other.initial_population()
        assert new.initial_fitness() == other.initial_fitness()
        assert new.count_outcomes() == other.count_outcomes()
        x = v2.evaluations()[-1]["x"]  # exact in version 2: every vector's key is found in every version
        assert new.lookup(x) == other.lookup(x) and new.lookup(x) is not None
    for g in (1, 2):  # version 1 kept every generation's population
        np.testing.assert_array_equal(v1.last_checkpoint(up_to=g)["population"], populations[g][0])
    for s in (new, v2, v1):
        s.close()
    # the report and `compare` read them
    records = [load_run(stores[v]) for v in (3, 2, 1)]
    assert len({r.best_fitness for r in records}) == 1 and len({tuple(r.best_x) for r in records}) == 1
    assert records[0].random_start == records[1].random_start == records[2].random_start != []
    assert records[0].random_start_fitness == records[1].random_start_fitness == records[2].random_start_fitness
    assert (
        curve_from_store(stores[3], 10)[0] == curve_from_store(stores[2], 10)[0] == curve_from_store(stores[1], 10)[0]
    )


TIMESTAMP = re.compile(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d")


def test_stores_of_every_version_export_the_same_model(runs, tmp_path):
    stores = runs[0]
    exported = {}
    for version, run_dir in stores.items():
        export_run(run_dir, tmp_path / str(version), engine="mujoco")
        exported[version] = {
            p.relative_to(tmp_path / str(version)): [  # less the run's path, and the export's own date (a second
                # may pass between two exports)
                line
                for line in p.read_text().splitlines()
                if str(run_dir) not in line and not TIMESTAMP.search(line)
            ]
            for p in sorted((tmp_path / str(version)).rglob("*"))
            if p.is_file() and p.suffix in (".xml", ".yaml")
        }
    assert exported[1] and exported[1] == exported[2] == exported[3]


@pytest.mark.parametrize("version", [1, 2, 3])
def test_a_run_resumes_in_its_own_format_losing_and_redoing_nothing(runs, version, tmp_path):
    stores, reference, _, _ = runs
    run_dir = tmp_path / "crashed"
    shutil.copytree(stores[version], run_dir)
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
    store, uninterrupted = RunStore.open_read_only(run_dir), RunStore.open_read_only(stores[version])
    assert store.version == version
    kinds = {1: [("text",)], 2: [("blob",)], 3: [("blob",), ("null",)]}[version]
    assert sorted(store.db.execute("SELECT DISTINCT typeof(x) FROM evaluations").fetchall()) == kinds
    # the same vectors kept exact as by the run that was never interrupted
    exact = "SELECT key FROM evaluations WHERE x IS NOT NULL ORDER BY key"
    assert store.db.execute(exact).fetchall() == uninterrupted.db.execute(exact).fetchall()
    assert len(store.generations()) == 3 and (store.last_checkpoint(up_to=1) is not None) == (version == 1)
    store.close()
    uninterrupted.close()


def test_version_3_keeps_the_exact_vector_of_every_evaluation_that_could_be_the_best(tmp_path):
    """Generation 0 and whatever is at least as good as every stable evaluation of the generations before its
    own: the best one is always exact, and a batch's order does not change what is kept."""
    rng = np.random.default_rng(3)
    xs = rng.uniform(size=(12, 5))

    def score(fitness: float, stable: bool = True) -> Score:
        return Score.combine([TaskScore("cube", fitness, fitness, None, stable, steps=7)])

    batches = [  # (generation, [(vector, fitness, stable)])
        (0, [(0, 0.5, True), (1, 0.9, True), (2, PENALTY, False)]),
        (1, [(3, 0.7, True), (4, 0.4, True), (5, 0.45, True), (6, 0.3, False)]),
        (2, [(7, 0.4, True), (8, 0.41, True), (9, 0.35, True)]),
    ]
    exact = {0, 1, 2, 4, 5, 6, 7, 9}  # generation 0; then at most 0.5; then at most 0.4
    kept = []
    for order in (1, -1):  # each batch's results in one order, then in the other
        store = RunStore(tmp_path / str(order), create=True)
        recorded: list[tuple[float, int]] = []
        for generation, batch in batches:
            for i, fitness, stable in batch[::order]:
                store.record_evaluation(xs[i], score(fitness, stable), generation, 0.25)
                recorded.append((fitness, i))
                best = min(recorded, key=lambda r: r[0])[1]  # the first stored of equals, as the store's
                assert np.array(store.best_evaluation()["x"]).tobytes() == xs[best].tobytes()
        rows = store.evaluations()
        got = {i for i in range(12) if any(np.array(r["x"]).tobytes() == xs[i].tobytes() for r in rows)}
        assert got == exact
        for r in rows:  # the others as float32, as floats
            assert any(np.array(r["x"], dtype=np.float32).tobytes() == x.astype(np.float32).tobytes() for x in xs)
        assert rows[0]["wall_s"] == 0.25
        kept.append(store.db.execute("SELECT key FROM evaluations WHERE x IS NOT NULL ORDER BY key").fetchall())
        # stored again (outside the Evaluator): the row keeps its place and gets its exact vector
        store.record_evaluation(xs[8], score(0.2), 2, 0.1)
        assert np.array(store.best_evaluation()["x"]).tobytes() == xs[8].tobytes()
        store.close()
    assert kept[0] == kept[1]


@pytest.mark.parametrize("version", [1, 2, 3])
def test_scores_come_back_from_the_store_exactly(tmp_path, version):
    store = RunStore(tmp_path, create=True, version=version)
    assert store.version == version
    one = Score.combine([TaskScore("cube", 0.1 + 0.2, 0.1, 0.2, steps=5000)])
    two = Score.combine(
        [
            TaskScore("cube", 1 / 3, 0.25, 1 / 3 - 0.25, steps=17),
            TaskScore("single", 10.0, 2.5, None, False, "unstable at t=1.00 s: wrist 3.0 m from the base", steps=9),
        ]
    )
    pruned = Score.combine([TaskScore("cube", 0.5, 0.5, None, True, "pruned at t=0.40 s", pruned=True, steps=300)])
    as_pruned = Score.combine([TaskScore("cube", 0.5, 0.5, None, True, pruned_message("16.90"), pruned=True, steps=9)])
    others = [
        Score.combine([TaskScore("cube", 0.2, 0.1, 0.1)]),  # no steps
        Score.combine([TaskScore("single", 0.2, 0.1, None, steps=3)]),  # not the first score's task
        Score.combine([TaskScore("cube", 0.6, 0.25, 0.1, joint_error=0.5, steps=3)]),
        Score.combine([TaskScore("cube", 0.6, 0.25, 0.1, steps=3), TaskScore("cube", 0.5, 0.5, None, steps=4)]),
        Score.combine([TaskScore("cube", 0.2, 0.1, 0.1, pruned=True, steps=5)]),  # pruned without the message
        Score.combine([TaskScore("cube", 0.2, 0.1, 0.1, message=pruned_message("1.00"), steps=5)]),  # not pruned
    ]
    for i, score in enumerate((one, two, pruned, Score(1.0, 0.5, None), as_pruned, *others)):
        x = np.array([i, np.pi, -0.0])
        store.record_evaluation(x, score, 0, 0.1)
        assert store.lookup(x) == score
        assert store.lookup(x.copy()) is not None and store.lookup(x + 1e-16 * (i + 1) + 1e-12) is None
    if version == 3:  # a one-task score of the store's task that holds its steps alone: that integer
        assert store.db.execute("SELECT score FROM evaluations ORDER BY id LIMIT 1").fetchone() == (5000,)
    store.close()


FIXTURES = Path(__file__).parent / "fixtures" / "stores"
#: the engine the fixture stores were made with (their fingerprints name it): the tests assume no other
FIXTURE_ENGINE = "mujoco 4.0.0"


def installed_engine() -> str:
    from simtune.engines import engine_class

    return f"mujoco {engine_class('mujoco').version()}"


@pytest.fixture(scope="module")
def published_reference(tmp_path_factory) -> Path:
    """The reference recordings simtune shipped before the cube's phase-2 target was corrected, which the fixture
    runs were tuned on: ``make(targets="published")`` writes them again byte for byte."""
    root = tmp_path_factory.mktemp("published-reference")
    make_reference(root, targets="published", truth_file=None)
    return root


def fixture_run(version: int, root: Path, data: Path, running: bool = False, **config) -> Path:
    """A copy of the fixture run of store ``version``, its data folder ``data`` (the store names the absolute
    folder it was tuned on) and its stored configuration updated by ``config``; with ``running``, as a run killed
    before its end leaves it (status "running")."""
    run_dir = root / f"v{version}"
    shutil.copytree(FIXTURES / f"v{version}", run_dir)
    with closing(sqlite3.connect(run_dir / STORE_FILE)) as db, db:
        stored = json.loads(db.execute("SELECT value FROM meta WHERE key = 'config'").fetchone()[0])
        stored.update(data=str(data), **config)
        db.execute("UPDATE meta SET value = ? WHERE key = 'config'", (json.dumps(stored),))
        if running:
            db.execute("UPDATE meta SET value = '\"running\"' WHERE key = 'status'")
            db.execute("DELETE FROM meta WHERE key LIKE 'search%'")  # written when the search ends
    return run_dir


def as_made_by_this_simtune(run_dir: Path) -> None:
    """Export refuses a run another simtune version tuned: the fixtures name the version that made them."""
    with closing(sqlite3.connect(run_dir / STORE_FILE)) as db, db:
        versions = json.loads(db.execute("SELECT value FROM meta WHERE key = 'versions'").fetchone()[0])
        versions["simtune"] = simtune.__version__
        db.execute("UPDATE meta SET value = ? WHERE key = 'versions'", (json.dumps(versions),))


@pytest.mark.parametrize("version", [1, 2, 3])
def test_each_fixture_store_reads_as_the_same_record(version):
    record = read_run_record(FIXTURES / f"v{version}")
    assert record.version == version and record.status == "finished"
    assert (record.engine, record.tasks, record.space, record.optimizer) == ("mujoco", "cube", "extended", "de")
    assert record.parameters == ["max_velocity_joint_2", "command_delay"] and record.active == [True, True]
    assert record.evaluations == 15 and len(record.initial_population) == len(record.initial_fitness) == 5
    assert [g["generation"] for g in record.generations] == [1, 2]
    assert set(record.data_fingerprint or {}) == {"cube"} and record.finished_at is not None
    best = json.loads((FIXTURES / f"v{version}" / BEST_PARAMS_FILE).read_text())
    assert record.best is not None and record.best["score"]["fitness"] == best["fitness"]
    assert dict(zip(record.parameters, record.best["x"])) == best["params"]
    reference = read_run_record(FIXTURES / "v3")
    for name in ("best", "generic", "initial_population", "initial_fitness", "outcomes", "inactive", "uncertainty"):
        assert getattr(record, name) == getattr(reference, name), name


@pytest.mark.slow
@pytest.mark.parametrize("version", [1, 2, 3])
def test_each_fixture_store_reports_exports_and_resumes(version, tmp_path, published_reference):
    """With the schedule it ran: the fixtures were tuned before the cube's phase 2 was corrected, and their resumed
    search takes its two generations from the store (a changed task would refuse to resume)."""
    run_dir = fixture_run(version, tmp_path / "runs", published_reference)
    runner = CliRunner()
    reported = runner.invoke(app, ["report", str(run_dir), "--out", str(tmp_path / "report"), "-q"])
    assert reported.exit_code == 0, reported.output
    assert (tmp_path / "report" / "index.html").is_file()
    as_made_by_this_simtune(run_dir)
    exported = runner.invoke(app, ["export", str(run_dir), "--out", str(tmp_path / "export"), "--engine", "mujoco"])
    assert exported.exit_code == 0, exported.output
    assert (tmp_path / "export" / "scene_cube.xml").is_file()
    # killed with one generation more to go: its two are replayed from the store, the third is new
    resumable = fixture_run(version, tmp_path / "resumed", published_reference, running=True, max_generations=3)
    resumed = runner.invoke(app, ["resume", str(resumable), "-q", "--json"])
    assert resumed.exit_code == 0, resumed.output
    record = read_run_record(resumable)
    assert record.version == version and record.status == "finished"
    assert record.evaluations == 20 and [g["generation"] for g in record.generations] == [1, 2, 3]
    assert (
        record.best is not None and record.best["score"]["fitness"] <= read_run_record(run_dir).best["score"]["fitness"]
    )


def test_a_fixture_store_runs_its_tasks_with_the_published_targets(published_reference, tmp_path):
    """A store made before the correction names no targets: its plan runs the cube's published phase 2 (65 deg),
    whose fingerprint is the one the store holds; a new run's plan runs the task file's (74 deg)."""
    from simtune.run_plan import plan_run
    from simtune.runs import engine_change, fingerprint_differences, run_fingerprint

    run_dir = fixture_run(3, tmp_path, published_reference)
    record = read_run_record(run_dir)
    config = record.settings
    stored = RunStore.open_read_only(run_dir)
    assert config.targets == "published" and "targets" not in stored.get("config")
    stored.close()
    plan = plan_run(config)
    assert plan.tasks[0].phases[1].targets_deg[2] == 65.0
    assert record.fingerprint is not None and record.fingerprint["engine"] == FIXTURE_ENGINE
    # the engine version differs wherever another MuJoCo than the fixtures' is installed, and nothing else does
    engine = [] if installed_engine() == FIXTURE_ENGINE else [engine_change(FIXTURE_ENGINE, installed_engine())]
    assert fingerprint_differences(record.fingerprint, run_fingerprint(plan)) == engine
    new = plan_run(RunConfig(**{**config.record(), "targets": "task"}))
    assert new.tasks[0].phases[1].targets_deg[2] == 74.0
    assert fingerprint_differences(record.fingerprint, run_fingerprint(new)) == [
        "the definition of task 'cube' changed",
        *engine,
    ]


def as_made_with_engine(run_dir: Path, engine: str, best_fitness_offset: float = 0.0) -> None:
    """The stored run as if tuned with ``engine`` (its fingerprint's "engine"), its stored best fitness moved by
    ``best_fitness_offset`` (as an engine version whose rollouts differ would score it)."""
    with closing(sqlite3.connect(run_dir / STORE_FILE)) as db, db:
        fingerprint = json.loads(db.execute("SELECT value FROM meta WHERE key = 'fingerprint'").fetchone()[0])
        fingerprint["engine"] = engine
        db.execute("UPDATE meta SET value = ? WHERE key = 'fingerprint'", (json.dumps(fingerprint),))
        if best_fitness_offset:
            (best_id,) = db.execute("SELECT id FROM evaluations ORDER BY fitness, id LIMIT 1").fetchone()
            db.execute("UPDATE evaluations SET fitness = fitness + ? WHERE id = ?", (best_fitness_offset, best_id))


def test_a_run_stored_under_another_engine_version_resumes_where_it_replays(published_reference, tmp_path):
    """Measured for MuJoCo 4.0.0 and 4.0.1 (benchmarks/engine_versions.py: bit-identical rollouts): a run of one goes
    on under the other, saying so in one line; here as a run whose fingerprint names a version that is not installed."""
    run_dir = fixture_run(3, tmp_path, published_reference, running=True, max_generations=3)
    as_made_with_engine(run_dir, "mujoco 3.99.0")
    from simtune.errors import EngineVersionWarning

    with pytest.warns(EngineVersionWarning) as said:  # the command line prints each as one `warning:` line
        resumed = CliRunner().invoke(app, ["resume", str(run_dir), "-q", "--json"])
    assert resumed.exit_code == 0, resumed.output
    (line,) = [str(w.message) for w in said if issubclass(w.category, EngineVersionWarning)]
    assert f"was tuned with mujoco 3.99.0; {installed_engine()} replays its stored evaluations" in line
    record = read_run_record(run_dir)
    assert record.status == "finished" and [g["generation"] for g in record.generations] == [1, 2, 3]


def test_a_run_another_engine_version_scores_otherwise_is_refused(published_reference, tmp_path):
    run_dir = fixture_run(3, tmp_path, published_reference, running=True, max_generations=3)
    as_made_with_engine(run_dir, "mujoco 3.99.0", best_fitness_offset=1e-6)
    from simtune.errors import SimtuneError

    resumed = CliRunner().invoke(app, ["resume", str(run_dir), "-q"])  # simtune's main prints it as one line, rc 2
    assert isinstance(resumed.exception, SimtuneError), resumed.output
    message = str(resumed.exception)
    assert f"engine mujoco 3.99.0 is now {installed_engine()} and scores its stored evaluations differently" in message
    assert "--rescore" in message


def test_a_stored_run_keeps_the_parameters_it_was_made_with(published_reference, tmp_path):
    """A space that has grown since a run was made (a kind added to ``extended``) is searched, for that run, over the
    stored list: each name as this simtune defines it, in the stored order; a stored name this simtune no longer
    has leaves the space as it is, for the caller to name the difference."""
    from simtune.run_plan import plan_run

    run_dir = fixture_run(3, tmp_path, published_reference, only=None)  # as if made before extended grew
    plan = plan_run(read_run_record(run_dir).settings)
    full = plan.full_space
    stored = ["max_velocity_joint_2", "command_delay"]
    assert len(full) > len(stored) and set(stored) < set(full.names)
    kept = plan.stored_space(full, stored)
    assert kept.names == stored and kept.name == full.name
    assert list(kept.parameters) == [p for p in full.parameters if p.name in stored]
    assert plan.stored_space(full, full.names) is full
    assert plan.stored_space(full, [*stored, "no_such_parameter_1"]) is full


@pytest.mark.slow
def test_a_run_made_with_fewer_parameters_than_the_space_now_holds_resumes_with_its_own(published_reference, tmp_path):
    """Resumed after its space grew, a run goes on over the parameters it was made with (the others at their generic
    values, as it simulated them), replaying its two generations from the store."""
    run_dir = fixture_run(3, tmp_path, published_reference, running=True, max_generations=3, only=None)
    resumed = resume_run(run_dir, show_progress=False)
    record = read_run_record(run_dir)
    assert record.parameters == ["max_velocity_joint_2", "command_delay"] and record.status == "finished"
    assert record.evaluations == 20 and resumed.new_evaluations == 5 and len(resumed.x) == 2
