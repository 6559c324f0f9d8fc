"""The start-up cache (issue 44): what a run computes before it searches - the references, the opening's delay, the
generic score - read back by content, bit for bit, with the warnings it raised; and the first batch's first member
stored before the rest of the batch, with the batch's results unchanged."""

import pickle
import warnings

import numpy as np
import pytest

from simtune import alignment
from simtune.common.cache import CACHE_ENV
from simtune.data import cache
from simtune.data.cache import cached, content_key
from simtune.engines import engine_class
from simtune.errors import RecordingWarning
from simtune.objective import Objective, generic_score, load_references
from simtune.optimize.evaluator import Evaluator
from simtune.params import get_space
from simtune.reference import REFERENCE_DIR
from simtune.store import RunStore
from simtune.tasks import parse_tasks


@pytest.fixture
def empty_cache(tmp_path, monkeypatch):
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "cache"))
    return tmp_path / "cache"


def test_a_result_is_computed_once_and_its_warnings_are_raised_on_every_read(empty_cache):
    calls = []

    def compute():
        calls.append(1)
        warnings.warn("repeat 3 left out", RecordingWarning, stacklevel=1)
        return {"array": np.arange(3.0) / 7.0}

    for _ in range(2):
        with pytest.warns(RecordingWarning, match="repeat 3 left out"):
            value = cached("test", {"what": 1}, compute)
        np.testing.assert_array_equal(value["array"], np.arange(3.0) / 7.0)
    assert calls == [1]
    with pytest.warns(RecordingWarning):
        cached("test", {"what": 2}, compute)  # other inputs: another entry
    assert calls == [1, 1]


def test_a_read_back_warning_is_shown_once_per_process_under_the_default_filter(empty_cache):
    """An API user's loop of evaluations reads the same entries again and again: under Python's default action their
    warning is shown once, as the same warning raised in place would be, and every time where a filter says always."""

    def compute():
        warnings.warn("the clock of repeat 3 is late", RecordingWarning, stacklevel=1)
        return 1

    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("default")
        for _ in range(3):
            cached("test", "shown once", compute)
    assert [str(w.message) for w in said] == ["the clock of repeat 3 is late"]
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        for _ in range(3):
            cached("test", "shown once", compute)
    assert len(said) == 3


def test_an_edit_of_simtunes_code_or_a_damaged_entry_is_a_miss(empty_cache, monkeypatch):
    calls = []

    def compute():
        calls.append(1)
        return len(calls)

    assert cached("test", "x", compute) == 1
    path = next((empty_cache / "test").iterdir())
    path.write_bytes(pickle.dumps("not an entry")[:5])  # truncated
    assert cached("test", "x", compute) == 2
    monkeypatch.setattr(cache, "code_digest", lambda: "another version of simtune")
    assert cached("test", "x", compute) == 3


def test_the_key_sees_every_value_of_a_large_array():
    a = np.zeros(10_000)
    b = a.copy()
    b[5_000] = 1e-300  # in the part of the array its text leaves out
    assert content_key({"a": a}) != content_key({"a": b})
    assert content_key({"a": a}) == content_key({"a": a.copy()})


def test_a_failed_computation_raises_its_warnings_then_its_error_and_caches_nothing(empty_cache):
    def compute():
        warnings.warn("first", RecordingWarning, stacklevel=1)
        raise ValueError("broken")

    with pytest.warns(RecordingWarning, match="first"), pytest.raises(ValueError, match="broken"):
        cached("test", "x", compute)
    assert not (empty_cache / "test").exists() or not any((empty_cache / "test").iterdir())


def test_references_read_back_equal_the_ones_loaded_with_the_same_warnings(empty_cache):
    tasks = parse_tasks("cube")
    with warnings.catch_warnings(record=True) as first:
        warnings.simplefilter("always")
        loaded = load_references(REFERENCE_DIR, tasks, reference="aligned")["cube"]
    with warnings.catch_warnings(record=True) as again:
        warnings.simplefilter("always")
        read = load_references(REFERENCE_DIR, tasks, reference="aligned")["cube"]
    assert any((empty_cache / "references").iterdir())
    assert [str(w.message) for w in again] == [str(w.message) for w in first]
    assert pickle.dumps(read) == pickle.dumps(loaded)  # every array and field, bit for bit
    mean = load_references(REFERENCE_DIR, tasks, reference="mean")["cube"]  # other options: loaded anew
    assert mean.reference == "mean" and read.reference == "aligned"


def test_the_opening_delay_and_the_generic_score_are_simulated_once(empty_cache, monkeypatch):
    specs = parse_tasks("cube")
    space = get_space("extended", engine_class("mujoco").supported(), ["command_delay", "mass_link_3"])
    objective = Objective("mujoco", specs, load_references(REFERENCE_DIR, specs), space)
    searched = []

    def estimate(objective, task, params, *, scan=True):
        assert scan is False  # auto's start-up keeps the one bounded search: it only places the opening
        searched.append(dict(params))
        return alignment.DelayEstimate(task.name, 1.0, 0.5, 0.5, 0.5 + len(searched) / 7, 0.2, 0.1, 13)

    monkeypatch.setattr(alignment, "estimate_delay", estimate)
    first = alignment.cached_delay(objective, specs[0], {"mass_link_3": 0.6})
    assert alignment.cached_delay(objective, specs[0], {"mass_link_3": 0.6}) == first
    assert len(searched) == 1
    other = alignment.cached_delay(objective, specs[0], {"mass_link_3": 0.7})  # other physics: searched anew
    assert len(searched) == 2 and other.delay_s != first.delay_s
    score = generic_score(objective)
    assert score == objective.score({})
    assert generic_score(objective) == score and len(list((empty_cache / "generic").iterdir())) == 1
    objective.close()


def test_the_first_batch_stores_its_first_member_before_the_rest_and_scores_each_as_in_one_batch(tmp_path):
    specs = parse_tasks("cube")
    space = get_space("extended", engine_class("mujoco").supported(), ["command_delay", "mass_link_3", "timestep"])
    objective = Objective("mujoco", specs, load_references(REFERENCE_DIR, specs), space)
    lo, hi = np.array(space.bounds).T
    xs = lo + np.array([[0.4, 0.5, 0.3], [0.45, 0.5, 0.3], [0.4, 0.55, 0.35]]) * (hi - lo)
    together = [objective.residuals_and_score(space.to_dict(x)) for x in xs]
    store = RunStore(tmp_path / "run", create=True)
    batches: list[list[int]] = []
    with Evaluator(objective, store, 1) as evaluator:
        run = evaluator._run

        def seen(work, jobs):
            batches.append(sorted(jobs))
            return run(work, jobs)

        evaluator._run = seen  # type: ignore[method-assign]
        results = evaluator.residuals(xs)
        evaluator.residuals(xs + 1e-3)  # a later batch: whole
    assert batches == [[0], [1, 2], [0, 1, 2]]
    for (r, s), (want_r, want_s) in zip(results, together):
        np.testing.assert_array_equal(r, want_r)
        assert s == want_s
    store.close()


@pytest.mark.parametrize("text", ["arm", 'say "hi"', "it's", "both ' and \"", "a<b>&c", "tab\there\nline\r", ""])
def test_the_model_generators_quoting_is_the_standard_librarys(text):
    from xml.sax.saxutils import quoteattr as standard

    from simtune.robot.generate import quoteattr

    assert quoteattr(text) == standard(text)


def test_the_least_recently_used_entries_beyond_the_limit_are_removed(empty_cache, monkeypatch):
    import os

    monkeypatch.setattr(cache, "MAX_ENTRIES", 3)
    for k in range(3):
        cached("test", k, lambda k=k: k)
        second = (k + 1) * 10**9
        os.utime(empty_cache / "test" / f"{content_key(k)}.pickle", ns=(second, second))  # written a second apart
    assert cached("test", 0, lambda: pytest.fail("read, not computed")) == 0  # used now: the most recent
    cached("test", 3, lambda: 3)
    assert len(list((empty_cache / "test").iterdir())) == 3
    assert cached("test", 1, lambda: "computed again") == "computed again"  # 1 was the least recently used


def test_a_warning_that_names_the_computations_caller_names_the_caller_of_cached(empty_cache):
    """A computation's warning raised with ``stacklevel=2`` (naming whoever called it) would name the cache's own
    module, a line of no use to the user: it names the line that called ``cached`` instead, computed or read."""

    def compute():
        warnings.warn("the clock of repeat 3 is late", RecordingWarning, stacklevel=2)
        return 1

    for _ in range(2):
        with pytest.warns(RecordingWarning) as said:
            cached("test", "warned", compute)
        assert [w.filename for w in said] == [__file__]


def test_the_former_cache_variable_is_read_with_a_warning_naming_the_documented_one(tmp_path, monkeypatch):
    """One cache, one documented variable (SIMTUNE_CACHE_DIR); the mesh cache's former SIMTUNE_CACHE is still
    read where it is not set, but no longer silently: a FutureWarning says which name to set."""
    from simtune.common.cache import FORMER_CACHE_ENV, cache_root

    monkeypatch.delenv(CACHE_ENV, raising=False)
    monkeypatch.setenv(FORMER_CACHE_ENV, str(tmp_path / "former"))
    with pytest.warns(FutureWarning, match=rf"^SIMTUNE_CACHE is deprecated: set SIMTUNE_CACHE_DIR={tmp_path}/former"):
        assert cache_root() == tmp_path / "former"
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "documented"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert cache_root() == tmp_path / "documented"
