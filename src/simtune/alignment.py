"""Time alignment per recording: each task's command delay, estimated from its own recordings.

A recording's clock starts when its operator pressed record, so the delay to the first
command differs from task to task (1.2 - 2.3 s in the qrg2019 recordings): a property of the
clocks, not of the physics.  Parameters tuned on some tasks carry their delay; scoring them on
an unseen task with that delay measures the clocks as much as the physics.

:func:`estimate_delay` aligns one task's clock with the physics held fixed: the median motion
onset of its repeats (:func:`simtune.data.onset.motion_onset`) minus the onset of the
simulation with no delay gives a first estimate; a bounded 1-D search over the delay alone
(SciPy's ``minimize_scalar``, within :data:`SEARCH_S` of it, the delay's range permitting)
then minimises the task's fitness.  The result is the task's ``command_delay_<task>``.  The
search itself is sequential (each point follows from the last); the rollouts that are not - the
unaligned score and the onset probe, then the first estimate and the search's first point - go
as two batches through the engine's batch path, bit for bit the rollouts one at a time.
"""

from __future__ import annotations

import math
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


def estimate_delay(objective: Objective, task: TaskSpec, params: dict[str, float], threads: int = 1) -> DelayEstimate:
    """The command delay of ``task``'s recordings with the physics of ``params`` held fixed (see the module's notes).

    The rollouts that do not wait on one another go as one batch (:meth:`Objective.scored_rollouts`, bit for bit
    the rollouts one at a time): the unaligned score with the probe, then the first estimate's score with the
    first point the bounded search asks for (:func:`first_bounded_point`).  The rest of the search is sequential.

    Args:
        objective: the run's objective (its engine and ``task``'s reference).
        task: whose delay.
        params: the physics held fixed (a delay among them is replaced).
        threads: how many threads the engine may use for a batch.
    Returns:
        The :class:`DelayEstimate`.
    """
    reference = objective.references[task.name]
    one = Objective(objective.engine, [task], {task.name: reference})
    bounds = find_parameter("command_delay")
    assert bounds is not None, "command_delay is a known parameter"
    name = delay_parameter(task.name)
    try:
        base = _without_delay(params, task.name)
        probe = {**base, name: PROBE_DELAY_S}
        (unaligned, _), (_, probed) = one.scored_rollouts([params, probe], threads)
        rollout, rollouts = probed[task.name], 2
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
        low, high = max(bounds.low, first - SEARCH_S), min(bounds.high, first + SEARCH_S)
        # scored ahead: the search's first point, taken from here when it asks for it (once: a point asked for
        # again is simulated again, as before)
        opening = first_bounded_point(low, high)
        ahead = [first] if opening == first else [first, opening]
        scored = one.scored_rollouts([{**base, name: d} for d in ahead], threads)
        rollouts += len(ahead)
        at_first, held = scored[0][0].fitness, {opening: scored[-1][0].fitness}

        def fitness(delay: float) -> float:
            nonlocal rollouts
            delay = float(delay)
            if delay in held:
                return held.pop(delay)
            rollouts += 1
            return one.score({**base, name: delay}).fitness

        result = minimize_scalar(fitness, bounds=(low, high), method="bounded", options={"xatol": TOLERANCE_S})
        delay, best = float(result.x), float(result.fun)
        if at_first <= best:  # the search never returns worse than its starting estimate
            delay, best = first, at_first
    finally:
        one.close()
    return DelayEstimate(task.name, recorded, simulated, first, delay, unaligned.fitness, best, rollouts)


def first_bounded_point(low: float, high: float) -> float:
    """The first point SciPy's bounded scalar search (``minimize_scalar(method="bounded")``) asks for: the golden
    section of its bounds, computed as SciPy does (a point computed otherwise only misses the batch: the search
    then simulates it itself).

    Args:
        low: the search's lower bound.
        high: its upper bound.
    Returns:
        The point.
    """
    golden_mean = 0.5 * (3.0 - math.sqrt(5.0))
    return low + golden_mean * (high - low)


def cached_delay(objective: Objective, task: TaskSpec, params: dict[str, float], threads: int = 1) -> DelayEstimate:
    """:func:`estimate_delay`, read from the start-up cache (:mod:`simtune.data.cache`) where the same search ran
    before: a dozen rollouts at every start of ``auto``.  The key is the engine and its version, the task and its
    robot by content, its reference by value and ``params``: what the search's rollouts and scores depend on (not
    ``threads``: a batch gives the rollouts one at a time would, bit for bit).

    Args:
        objective: the run's objective.
        task: whose delay.
        params: the physics held fixed.
        threads: how many threads the engine may use for a batch.
    Returns:
        The :class:`DelayEstimate`.
    """
    what = simulation_content(objective.engine, [task], objective.references)
    what["params"] = dict(sorted(params.items()))
    return cached("delay", what, lambda: estimate_delay(objective, task, params, threads))


def aligned(params: dict[str, float], estimates: list[DelayEstimate]) -> dict[str, float]:
    """``params`` with each estimated task's own delay set."""
    return {**params, **{e.parameter: e.delay_s for e in estimates}}
