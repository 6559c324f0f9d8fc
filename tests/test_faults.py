"""Faults inside worker processes: a crashing or hanging evaluation costs only itself."""

import os
import signal
import time

import numpy as np
import pytest

from simtune.objective import Objective, load_references
from simtune.optimize import TuneSettings
from simtune.optimize.de import differential_evolution_tune
from simtune.optimize.evaluator import Evaluator
from simtune.params import get_space
from simtune.reference import REFERENCE_DIR
from simtune.store import RunStore
from simtune.tasks import parse_tasks


class FaultyObjective(Objective):
    """The real objective, except that chosen corners of the space kill or hang the worker process.

    Fault injection for the test: the physics of every other evaluation is real.
    """

    @staticmethod
    def _fault(params):
        delay = params["command_delay"]
        if delay > 2.4:  # command_delay in its top fifth: the worker dies as on a segfault
            os.kill(os.getpid(), signal.SIGKILL)
        if delay < 0.6:  # in its bottom fifth: the worker hangs
            time.sleep(120)

    def score_vector(self, x, bound=None):
        self._fault(self.space.to_dict(x))
        return super().score_vector(x, bound)

    def score_batch(self, params, bounds=None, threads=1):  # a chunk of a batch (MuJoCo's batch path)
        for p in params:
            self._fault(p)
        yield from super().score_batch(params, bounds, threads)


def faulty_objective():
    tasks = parse_tasks("cube")
    space = get_space("extended", None, ["command_delay", "max_velocity_joint_2"])
    return FaultyObjective("mujoco", tasks, load_references(REFERENCE_DIR, tasks), space), space


def test_a_crashing_and_a_hanging_evaluation_cost_only_themselves(tmp_path):
    objective, space = faulty_objective()
    store = RunStore(tmp_path / "run", create=True)
    delays = (1.4, 2.8, 0.2, 1.2)  # fine, crash, hang, fine
    batch = np.array([space.to_vector({"command_delay": d, "max_velocity_joint_2": 30.0}) for d in delays])
    with Evaluator(objective, store, workers=2, eval_timeout=2.0) as evaluator:
        # MuJoCo's workers take the batch in two chunks: each has a fault, fails whole and goes out again singly
        assert evaluator.chunked
        fitness = evaluator.evaluate(batch)
    assert evaluator.failed_evaluations == 2 and store.count_evaluations() == 4
    crashed, hung = store.lookup(batch[1]), store.lookup(batch[2])
    assert "worker process died" in crashed.tasks[0].message and not crashed.tasks[0].stable
    assert "ran past 2 s" in hung.tasks[0].message and not hung.tasks[0].stable
    for i in (0, 3):  # the others were simulated as usual
        assert store.lookup(batch[i]).tasks[0].stable and 0 < fitness[i] < 1


@pytest.mark.slow
def test_crashing_and_hanging_evaluations_are_recorded_and_the_run_goes_on(tmp_path):
    objective, space = faulty_objective()
    store = RunStore(tmp_path / "run", create=True)
    result = differential_evolution_tune(
        objective, store, TuneSettings(seed=5, workers=2, max_generations=3, eval_timeout=4.0)
    )
    rows = store.evaluations()
    at = space.names.index("command_delay")
    delays = np.array([r["x"][at] for r in rows])
    faulty = {round(d, 9) for d in delays if d > 2.4 or d < 0.6}
    failed = [r for r in rows if not r["stable"]]
    assert any(d > 2.4 for d in delays) and any(d < 0.6 for d in delays), "the seed must hit both faults"
    # exactly the faulty evaluations failed, each stored with why; every other one was simulated
    assert {round(r["x"][at], 9) for r in failed} == faulty
    # (a failed row keeps a float32 copy of its vector: its score is read as it is stored, not looked up by it)
    messages = {score.tasks[0].message for score in store.failed_scores()}
    assert len(messages) >= 2 and len(store.failed_scores()) == len(failed)
    assert any("worker process died" in m for m in messages)
    assert any("ran past 4 s" in m for m in messages)  # the 120 s hang was cut at its time-out
    assert len(rows) == result.evaluations and all(np.isfinite(r["fitness"]) for r in rows)
    # and the run went on to its end
    assert result.generations == 3 and len(store.generations()) == 3
    assert 0.6 <= result.params["command_delay"] <= 2.4
