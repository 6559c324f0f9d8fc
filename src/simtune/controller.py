"""The joint controller of every task, written once and run identically in every engine.

At 20 Hz of simulated time, for each arm joint::

    velocity [deg/s] = clamp(kp * (target - angle), -v_max, +v_max)

sent as a joint velocity target with a motor force limit, held until the next
update.  ``command_delay`` shifts the whole target schedule later in time (the
arm holds its start pose until then): the real recordings start 1.2-2 s before
the arm moves, and whether that is latency or a recording offset, a shift of the
schedule reproduces it.
"""

from __future__ import annotations

import numpy as np

from simtune.tasks.spec import TaskSpec

CONTROL_PERIOD = 0.05  # seconds between controller updates (20 Hz)
CONTROLLER_PARAMETERS = frozenset({f"max_velocity_joint_{i}" for i in range(1, 7)} | {"command_delay"})


class JointController:
    """Clamped proportional velocity control towards the task's joint targets."""

    def __init__(self, task: TaskSpec, params: dict[str, float] | None = None):
        params = params or {}
        self.task = task
        self.kp = task.kp
        self.v_max = np.array([params.get(f"max_velocity_joint_{i}", task.max_velocity_deg) for i in range(1, 7)])
        self.delay = float(params.get("command_delay", 0.0))

    def command(self, t: float, angles_rad: np.ndarray) -> np.ndarray:
        """Joint velocity targets [rad/s] at simulated time ``t`` for joint angles ``angles_rad``."""
        target = self.task.targets_deg(t - self.delay)
        velocity = np.clip(self.kp * (target - np.degrees(angles_rad)), -self.v_max, self.v_max)
        return np.radians(velocity)
