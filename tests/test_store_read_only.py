"""Read-only access to a run store: the queries of a writer, no writes, nothing left in the run folder."""

import sqlite3

import pytest

from simtune.errors import SimtuneError
from simtune.fitness import Score
from simtune.store import RunStore


def _store_with_evaluations(run_dir, n: int = 3) -> RunStore:
    store = RunStore(run_dir, create=True)
    store.set(status="finished", config={"engine": "mujoco"})
    for i in range(n):
        store.record_evaluation([float(i), 0.5], Score(1.0 + i, 0.5, None), generation=i // 2, wall_s=0.1)
    store.record_generation(0, [[0.0, 0.5], [1.0, 0.5]], [1.0, 2.0], [0.0, 0.5], 1.0, 2, 1.5)
    return store


def _queries(store: RunStore) -> tuple:
    return (
        store.get("status"),
        store.get("config"),
        store.count_evaluations(),
        store.count_outcomes(),
        store.evaluations(),
        store.best_evaluation(),
        store.generations(),
        store.initial_fitness(),
        store.lookup([1.0, 0.5]),
    )


def test_read_only_store_answers_like_the_writer_and_changes_nothing(tmp_path):
    writer = _store_with_evaluations(tmp_path)
    expected = _queries(writer)
    writer.close()
    files = {p.name: (p.stat().st_mtime_ns, p.read_bytes()) for p in tmp_path.iterdir()}
    assert list(files) == ["run.sqlite"]

    reader = RunStore.open_read_only(tmp_path)
    assert _queries(reader) == expected
    assert reader.initial_fitness() == [1.0, 2.0]
    with pytest.raises(SimtuneError, match="read-only"):
        reader.set(status="running")
    with pytest.raises(SimtuneError, match="read-only"):
        reader.record_evaluation([9.0, 9.0], Score(0.1, 0.1, None), generation=5, wall_s=0.1)
    with pytest.raises(sqlite3.OperationalError, match="readonly"):  # even SQL written past the API
        reader.db.execute("DELETE FROM evaluations")
    reader.close()
    assert {p.name: (p.stat().st_mtime_ns, p.read_bytes()) for p in tmp_path.iterdir()} == files


def test_read_only_store_sees_what_a_live_writer_committed(tmp_path):
    writer = _store_with_evaluations(tmp_path, n=2)  # still open: its evaluations are in the -wal file
    assert (tmp_path / "run.sqlite-wal").exists()
    reader = RunStore.open_read_only(tmp_path)
    assert reader.count_evaluations() == 2
    writer.record_evaluation([7.0, 7.0], Score(0.5, 0.5, None), generation=1, wall_s=0.1)
    assert reader.count_evaluations() == 3
    assert reader.best_evaluation()["x"] == [7.0, 7.0]
    reader.close()
    writer.close()


def test_read_only_open_names_what_is_wrong(tmp_path):
    with pytest.raises(SimtuneError, match="is not a run folder"):
        RunStore.open_read_only(tmp_path)
    (tmp_path / "run.sqlite").write_bytes(b"not a database" * 100)
    with pytest.raises(sqlite3.DatabaseError):
        RunStore.open_read_only(tmp_path)
    other = tmp_path / "other"
    versioned = RunStore(other, create=True)
    versioned.set(schema_version=99)
    versioned.close()
    with pytest.raises(SimtuneError, match="run store version 99"):
        RunStore.open_read_only(other)
