"""Time alignment per recording: each task's command delay, estimated from its own recordings.

A recording's clock starts when its operator pressed record, so the delay to the first
command differs from task to task (1.2 - 2.3 s in the qrg2019 recordings): a property of the
clocks, not of the physics.  Parameters tuned on some tasks carry their delay; scoring them on
an unseen task with that delay measures the clocks as much as the physics.

:func:`estimate_delay` aligns one task's clock with the physics held fixed: the median motion
onset of its repeats (:func:`simtune.data.onset.motion_onset`) minus the onset of the
simulation with no delay gives a first estimate; a bounded 1-D search over the delay alone
(SciPy's ``minimize_scalar``, within :data:`SEARCH_S` of it, the delay's range permitting)
then minimises the task's fitness.  The result is the task's ``command_delay_<task>``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from simtune.data.cache import cached
from simtune.data.onset import motion_onset
from simtune.fitness import marker_positions
from simtune.objective import Objective, simulation_content
from simtune.params import find_parameter
from simtune.tasks import TaskSpec

#: How far [s] the 1-D search may move the delay from the onset estimate, each way.
SEARCH_S = 0.5
#: The simulation's onset is measured with this delay, then taken off: the arm rests long enough before it
#: moves for its rest position to be known (a recording's onset is measured the same way).
PROBE_DELAY_S = 1.0
#: The search stops when the delay is known to this [s] (a tenth of a 20 Hz sample).
TOLERANCE_S = 0.005


@dataclass
class DelayEstimate:
    """One task's clock alignment: the onsets, the first estimate, the searched delay and the fitness it gives."""

    task: str
    recorded_onset_s: float | None
    simulated_onset_s: float | None
    onset_delay_s: float
    delay_s: float
    fitness_unaligned: float
    fitness: float
    rollouts: int

    @property
    def parameter(self) -> str:
        return delay_parameter(self.task)


def delay_parameter(task: str) -> str:
    """The name of a task's own command delay."""
    return f"command_delay_{task}"


def _without_delay(params: dict[str, float], task: str) -> dict[str, float]:
    return {k: v for k, v in params.items() if k not in ("command_delay", delay_parameter(task))}


def estimate_delay(objective: Objective, task: TaskSpec, params: dict[str, float]) -> DelayEstimate:
    """The command delay of ``task``'s recordings with the physics of ``params`` held fixed (see the module's notes)."""
    reference = objective.references[task.name]
    one = Objective(objective.engine, [task], {task.name: reference})
    bounds = find_parameter("command_delay")
    assert bounds is not None, "command_delay is a known parameter"
    rollouts = 0
    try:
        base = _without_delay(params, task.name)
        unaligned = one.score(params).fitness
        probe = {**base, delay_parameter(task.name): PROBE_DELAY_S}
        rollout = one.rollouts(probe)[task.name]
        rollouts += 2
        onset = motion_onset(rollout.times, marker_positions(rollout, probe))
        simulated = None if onset is None else onset - PROBE_DELAY_S
        onsets = [
            motion_onset(reference.times, track)
            for track in (reference.wrist_repeats if reference.wrist_repeats is not None else ())
        ]
        found = [o for o in onsets if o is not None]
        recorded = float(np.median(found)) if found else None
        first = 0.0 if recorded is None or simulated is None else recorded - simulated
        first = float(np.clip(first, bounds.low, bounds.high))

        def fitness(delay: float) -> float:
            nonlocal rollouts
            rollouts += 1
            return one.score({**base, delay_parameter(task.name): float(delay)}).fitness

        low, high = max(bounds.low, first - SEARCH_S), min(bounds.high, first + SEARCH_S)
        result = minimize_scalar(fitness, bounds=(low, high), method="bounded", options={"xatol": TOLERANCE_S})
        delay, best = float(result.x), float(result.fun)
        at_first = fitness(first)
        if at_first <= best:  # the search never returns worse than its starting estimate
            delay, best = first, at_first
    finally:
        one.close()
    return DelayEstimate(task.name, recorded, simulated, first, delay, unaligned, best, rollouts)


def cached_delay(objective: Objective, task: TaskSpec, params: dict[str, float]) -> DelayEstimate:
    """:func:`estimate_delay`, read from the start-up cache (:mod:`simtune.data.cache`) where the same search ran
    before: a dozen rollouts at every start of ``auto``.  The key is the engine and its version, the task and its
    robot by content, its reference by value and ``params``: what the search's rollouts and scores depend on."""
    what = simulation_content(objective.engine, [task], objective.references)
    what["params"] = dict(sorted(params.items()))
    return cached("delay", what, lambda: estimate_delay(objective, task, params))


def aligned(params: dict[str, float], estimates: list[DelayEstimate]) -> dict[str, float]:
    """``params`` with each estimated task's own delay set."""
    return {**params, **{e.parameter: e.delay_s for e in estimates}}
