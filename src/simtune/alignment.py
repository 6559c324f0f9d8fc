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

A contact task's fitness over the delay is not one valley: on the real ``cube`` it has minima about 0.1 s
apart and 0.02-0.03 s wide (the gripper meets the cube at another moment of the arm's swing), so a bounded
search from one bracket settles in whichever it meets first (measured: 0.0135 where the delay the run was tuned
with scores 0.0097, docs/calibration.md).  Where the delay is the answer (``evaluate`` and ``transfer`` aligning
a test task's clock, a held-out split) the search therefore scans the whole window every :data:`SCAN_STEP_S`,
refines the grid's :data:`SCAN_REFINE` best valleys and never returns worse than the delay ``params`` carry: about
a hundred rollouts (15 s on the real ``cube`` in MuJoCo, minutes in Drake).  A task without contact needs it too:
on the real ``single`` the fitness over the delay saw-tooths every 0.05 s or so (the time step's whole steps per
control period), and one search ended at 0.00635 where the scan finds 0.00599.
``auto``'s start-up (:func:`cached_delay`) keeps the single bounded search: it only places the opening, whose
searches then move the delay with everything else.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from simtune.data.cache import cached
from simtune.data.onset import motion_onset
from simtune.engines.controller import given_delay
from simtune.fitness import marker_positions
from simtune.objective import Objective, simulation_content
from simtune.params import find_parameter
from simtune.params.kinds import DELAY, delay_names, task_delay_name
from simtune.tasks import TaskSpec

#: How far [s] the 1-D search may move the delay from the onset estimate, each way.
SEARCH_S = 0.5
#: The simulation's onset is measured with this delay, then taken off: the arm rests long enough before it
#: moves for its rest position to be known (a recording's onset is measured the same way).
PROBE_DELAY_S = 1.0
#: The search stops when the delay is known to this [s] (a tenth of a 20 Hz sample).
TOLERANCE_S = 0.005
#: The scan's grid step [s]: a third of the narrowest valley measured on a contact task (about 0.03 s wide).
SCAN_STEP_S = 0.01
#: How many of the scan's best grid valleys are refined by the bounded search, each within a step of its point.
SCAN_REFINE = 3


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
        return task_delay_name(self.task)


def _without_delay(params: dict[str, float], task: str) -> dict[str, float]:
    return {k: v for k, v in params.items() if k not in delay_names(task)}


def estimate_delay(
    objective: Objective, task: TaskSpec, params: dict[str, float], *, scan: bool = True
) -> DelayEstimate:
    """The command delay of ``task``'s recordings with the physics of ``params`` held fixed (see the module's notes).

    Args:
        objective: an objective that holds ``task`` and its reference.
        task: the task whose clock is aligned.
        params: the physics (and other settings); their own delay for the task, if any, is one candidate.
        scan: scan the whole window before refining (the default; see the module's notes) rather than one
            bounded search from the onset estimate.
    Returns:
        The onsets, the first estimate, the delay found and the task's fitness before and after.
    """
    reference = objective.references[task.name]
    one = Objective(objective.engine, [task], {task.name: reference})
    bounds = find_parameter(DELAY)
    assert bounds is not None, "the command delay is a known parameter"
    rollouts = 0
    try:
        base = _without_delay(params, task.name)
        unaligned = one.score(params).fitness
        probe = {**base, task_delay_name(task.name): PROBE_DELAY_S}
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
            return one.score({**base, task_delay_name(task.name): float(delay)}).fitness

        low, high = max(bounds.low, first - SEARCH_S), min(bounds.high, first + SEARCH_S)
        if scan:
            delay, best = _scanned(fitness, low, high)
        else:
            result = minimize_scalar(fitness, bounds=(low, high), method="bounded", options={"xatol": TOLERANCE_S})
            delay, best = float(result.x), float(result.fun)
        at_first = fitness(first)
        if at_first <= best:  # the search never returns worse than its starting estimate
            delay, best = first, at_first
        own = given_delay(task.name, params)
        if scan and own is not None and unaligned < best:  # nor than the delay the parameters carry
            delay, best = own, unaligned
    finally:
        one.close()
    return DelayEstimate(task.name, recorded, simulated, first, delay, unaligned, best, rollouts)


def _scanned(fitness: Callable[[float], float], low: float, high: float) -> tuple[float, float]:
    """The least of ``fitness`` on ``[low, high]``: a grid every :data:`SCAN_STEP_S`, then a bounded search within
    a step of each of the grid's :data:`SCAN_REFINE` best local minima."""
    grid = np.linspace(low, high, max(2, round((high - low) / SCAN_STEP_S) + 1))
    values = np.array([fitness(float(d)) for d in grid])
    padded = np.concatenate(([np.inf], values, [np.inf]))
    valleys = [i for i in range(len(grid)) if padded[i + 1] <= padded[i] and padded[i + 1] <= padded[i + 2]]
    at = int(np.argmin(values))
    delay, best = float(grid[at]), float(values[at])
    for i in sorted(valleys, key=lambda i: values[i])[:SCAN_REFINE]:
        a, b = float(grid[max(i - 1, 0)]), float(grid[min(i + 1, len(grid) - 1)])
        result = minimize_scalar(fitness, bounds=(a, b), method="bounded", options={"xatol": TOLERANCE_S / 5})
        if float(result.fun) < best:
            delay, best = float(result.x), float(result.fun)
    return delay, best


def cached_delay(objective: Objective, task: TaskSpec, params: dict[str, float]) -> DelayEstimate:
    """:func:`estimate_delay`, read from the start-up cache (:mod:`simtune.data.cache`) where the same search ran
    before: a dozen rollouts at every start of ``auto``.  The key is the engine and its version, the task and its
    robot by content, its reference by value and ``params``: what the search's rollouts and scores depend on."""
    what = simulation_content(objective.engine, [task], objective.references)
    what["params"] = dict(sorted(params.items()))
    return cached("delay", what, lambda: estimate_delay(objective, task, params, scan=False))


def aligned(params: dict[str, float], estimates: list[DelayEstimate]) -> dict[str, float]:
    """``params`` with each estimated task's own delay set."""
    return {**params, **{e.parameter: e.delay_s for e in estimates}}
