"""The joint controller of every task, written once and run identically in every engine.

At 20 Hz of simulated time, for each driven joint of the task's robot::

    velocity [deg/s] = clamp(kp * (target - angle), -v_max, +v_max)

sent as a joint velocity target with a motor force limit, held until the next
update.  ``command_delay`` shifts the whole target schedule later in time (the
arm holds its start pose until then): the real recordings start 1.2-2 s before
the arm moves, and whether that is latency or a recording offset, a shift of the
schedule reproduces it.  The shift is continuous, not a whole number of control
periods: the controller's 20 Hz clock runs ``phase`` = delay mod 50 ms after the
recording's 20 Hz sample clock, as two free-running clocks do (otherwise the
fit could not tell delays within one period apart).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from simtune.tasks.spec import TaskSpec

CONTROL_PERIOD = 0.05  # seconds between controller updates (20 Hz)


def controller_parameters(n_joints: int) -> frozenset[str]:
    """The parameters the controller reads, for a robot with ``n_joints`` driven joints."""
    return frozenset({f"max_velocity_joint_{i}" for i in range(1, n_joints + 1)} | {"command_delay"})


#: those of the bundled six-joint MICO
CONTROLLER_PARAMETERS = controller_parameters(6)


class JointController:
    """Clamped proportional velocity control towards the task's joint targets.

    The gain is in (deg/s)/deg = 1/s, so the law holds unchanged in radians;
    the controller works in radians throughout.
    """

    def __init__(self, task: TaskSpec, params: dict[str, float] | None = None):
        params = params or {}
        self.task = task
        self.kp = float(task.kp)
        n = task.robot.n_joints
        v_max = [params.get(f"max_velocity_joint_{i}", task.max_velocity_deg) for i in range(1, n + 1)]
        self.v_max = np.radians(np.array(v_max, dtype=float))
        # a task's own delay (``command_delay_<task>``, tasks tuned together) before the shared one
        self.delay = float(params.get(f"command_delay_{task.name}", params.get("command_delay", 0.0)))
        #: how long after each 20 Hz sample instant the controller updates [s], in [0, CONTROL_PERIOD)
        self.phase = self.delay % CONTROL_PERIOD

    def targets(self, times: npt.ArrayLike) -> np.ndarray:
        """Joint targets [rad] in force at each simulated time of ``times`` (one row per time)."""
        starts, table = self.task.schedule
        rows = np.searchsorted(starts, np.asarray(times, dtype=float) - self.delay + 1e-12, side="right")
        return np.radians(table[rows])

    def velocity(self, target: np.ndarray, angles_rad: np.ndarray) -> np.ndarray:
        """Joint velocity targets [rad/s] towards ``target`` [rad] from ``angles_rad``."""
        # two ufuncs instead of np.clip: this runs at every control update of every rollout
        velocity = np.multiply(target - angles_rad, self.kp)
        return np.minimum(np.maximum(velocity, -self.v_max, out=velocity), self.v_max, out=velocity)

    def command(self, t: float, angles_rad: np.ndarray) -> np.ndarray:
        """Joint velocity targets [rad/s] at simulated time ``t`` for joint angles ``angles_rad``."""
        return self.velocity(self.targets([t])[0], angles_rad)
