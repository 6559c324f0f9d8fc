"""Faults inside worker processes: a crashing or hanging evaluation costs only itself."""

import os
import signal
import time

import numpy as np

from simtune.objective import Objective, load_references
from simtune.optimize import TuneSettings
from simtune.optimize.de import differential_evolution_tune
from simtune.params import get_space
from simtune.reference import REFERENCE_DIR
from simtune.store import RunStore
from simtune.tasks import parse_tasks


class FaultyObjective(Objective):
    """The real objective, except that chosen corners of the space kill or hang the worker process.

    Fault injection for the test: the physics of every other evaluation is real.
    """

    def score_vector(self, x, bound=None):
        delay = self.space.to_dict(x)["command_delay"]
        if (
            delay > 2.4
        ):  # command_delay in its top fifth (latin hypercube puts one member there): the worker dies as on a segfault
            os.kill(os.getpid(), signal.SIGKILL)
        if delay < 0.6:  # in its bottom fifth: the worker hangs
            time.sleep(120)
        return super().score_vector(x, bound)


def test_crashing_and_hanging_evaluations_are_recorded_and_the_run_goes_on(tmp_path):
    tasks = parse_tasks("cube")
    space = get_space("extended", None, ["command_delay", "max_velocity_joint_2"])
    objective = FaultyObjective("mujoco", tasks, load_references(REFERENCE_DIR, tasks), space)
    store = RunStore(tmp_path / "run", create=True)
    t0 = time.time()
    result = differential_evolution_tune(
        objective, store, TuneSettings(seed=5, workers=2, max_generations=3, eval_timeout=4.0)
    )
    assert time.time() - t0 < 100
    rows = store.evaluations()
    at = space.names.index("command_delay")
    delays = np.array([r["x"][at] for r in rows])
    failed = [r for r in rows if not r["stable"]]
    assert any(d > 2.4 for d in delays) and any(d < 0.6 for d in delays), "the seed must hit both faults"
    assert {round(r["x"][at], 9) for r in failed} == {round(d, 9) for d in delays if d > 2.4 or d < 0.6}
    messages = {store.lookup(r["x"]).tasks[0].message for r in failed}
    assert any("worker process died" in m for m in messages)
    assert any("ran past 4 s" in m for m in messages)
    assert 0.6 <= result.params["command_delay"] <= 2.4
    assert result.generations == 3
