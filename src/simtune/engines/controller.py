"""The joint controller of every task, written once and run identically in every engine.

At 20 Hz of simulated time, for each driven joint of the task's robot::

    velocity [deg/s] = clamp(kp * (target - angle), -v_max, +v_max)

with the task's gain kp, or the joint's own ``kp_joint_<n>`` [1/s] (a servo's hidden
firmware gain), sent as a joint velocity target with a motor force limit, held until the next
update.  ``command_delay`` shifts the whole target schedule later in time (the
arm holds its start pose until then): the real recordings start 1.2-2 s before
the arm moves, and whether that is latency or a recording offset, a shift of the
schedule reproduces it.  The shift is continuous, not a whole number of control
periods: the controller's 20 Hz clock runs ``phase`` = delay mod 50 ms after the
recording's 20 Hz sample clock, as two free-running clocks do (otherwise the
fit could not tell delays within one period apart).

The controller reads the joints through the arm's encoders, which the
calibration parameters (``--space calibrated``) model: an encoder reads

    encoder = true angle - compliance x gravity torque(true angles) + zero offset

``joint_offset_<n>`` [deg] is the encoder's zero error, and
``compliance_joint_<n>`` [rad/(N m)] the elastic deflection of the joint's drive
under the static gravity load (the encoder sits on the motor side of a harmonic
drive, the link sags past it by compliance x load).  The arm therefore settles
where the encoder reads the target: at target - offset + compliance x gravity
torque.  Without these parameters the encoder reads the true angle.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import numpy.typing as npt

from simtune.params.kinds import CONTROLLER, ENCODERS, applied_outside, delay_names
from simtune.tasks.spec import TaskSpec

CONTROL_PERIOD = 0.05  # seconds between controller updates (20 Hz)


def controller_parameters(n_joints: int) -> frozenset[str]:
    """The parameters the controller reads, for a robot with ``n_joints`` driven joints (its kinds in
    :data:`simtune.params.kinds.KINDS`)."""
    return applied_outside(n_joints, (CONTROLLER,))


def encoder_parameters(n_joints: int) -> frozenset[str]:
    """The calibration parameters of the encoders' model, for a robot with ``n_joints`` driven joints."""
    return applied_outside(n_joints, (ENCODERS,))


#: those of the bundled six-joint MICO
CONTROLLER_PARAMETERS = controller_parameters(6)


def given_delay(task: str, params: Mapping[str, float]) -> float | None:
    """The command delay [s] ``params`` give ``task``: its own (``command_delay_<task>``, tasks tuned together)
    before the shared ``command_delay``; None where they give neither (the controller then runs without one)."""
    own, shared = delay_names(task)
    value = params.get(own, params.get(shared))
    return None if value is None else float(value)


class JointController:
    """Clamped proportional velocity control towards the task's joint targets.

    The gain is in (deg/s)/deg = 1/s, so the law holds unchanged in radians;
    the controller works in radians throughout.
    """

    def __init__(self, task: TaskSpec, params: dict[str, float] | None = None):
        params = params or {}
        self.task = task
        n = task.robot.n_joints
        #: the gain of each joint [1/s]: ``kp_joint_<n>``, else the task's
        self.kp = np.array([params.get(f"kp_joint_{i}", task.kp) for i in range(1, n + 1)], dtype=float)
        v_max = [params.get(f"max_velocity_joint_{i}", task.max_velocity_deg) for i in range(1, n + 1)]
        self.v_max = np.radians(np.array(v_max, dtype=float))
        delay = given_delay(task.name, params)
        self.delay = 0.0 if delay is None else delay
        #: how long after each 20 Hz sample instant the controller updates [s], in [0, CONTROL_PERIOD)
        self.phase = self.delay % CONTROL_PERIOD
        robot = task.robot
        self.offset = np.radians([params.get(f"joint_offset_{i}", 0.0) for i in range(1, n + 1)])
        self.compliance = np.array([params.get(f"compliance_joint_{i}", 0.0) for i in range(1, n + 1)], dtype=float)
        self._gravity = None
        if self.compliance.any():  # the masses the engine simulates load the joints
            masses = {
                link: params[f"mass_link_{i}"]
                for i, link in enumerate(robot.driven_links, start=1)
                if f"mass_link_{i}" in params
            }
            self._gravity = robot.gravity(masses)
        #: whether the encoders read anything but the true angles
        self.calibrated = bool(self.offset.any()) or self._gravity is not None

    def encoder(self, angles_rad: np.ndarray) -> np.ndarray:
        """What the encoders read [rad] with the joints at ``angles_rad`` (true angles)."""
        if not self.calibrated:
            return angles_rad
        reading = angles_rad + self.offset
        if self._gravity is not None:
            reading = reading - self.compliance * self._gravity(angles_rad)
        return reading

    def true_angles(self, reading_rad: np.ndarray, iterations: int = 4) -> np.ndarray:
        """The true angles [rad] at which the encoders read ``reading_rad`` (the deflection is a small
        correction, so a few fixed-point steps settle it to far below a micro-radian)."""
        angles = np.asarray(reading_rad, dtype=float) - self.offset
        if self._gravity is None:
            return angles
        base = angles
        for _ in range(iterations):
            angles = base + self.compliance * self._gravity(angles)
        return angles

    def start_angles(self) -> np.ndarray:
        """The true joint angles [rad] the arm starts at: where its encoders read the task's start pose
        (the controller holds the start pose until the first phase, so the arm starts at rest)."""
        return self.true_angles(np.radians(np.asarray(self.task.start_pose_deg, dtype=float)))

    def targets(self, times: npt.ArrayLike) -> np.ndarray:
        """Joint targets [rad] in force at each simulated time of ``times`` (one row per time)."""
        starts, table = self.task.schedule
        sent = np.asarray(times, dtype=float) - self.delay
        rows = np.searchsorted(starts, sent + 1e-12, side="right")
        if self.task.interpolation == "hold" or len(starts) < 2:
            return np.radians(table[rows])
        # linear: between set-point k (row k + 1) and the next, the share of the time between them that has passed
        ramping = (rows >= 1) & (rows < len(starts))
        k = np.clip(rows - 1, 0, len(starts) - 2)
        share = np.where(ramping, (sent - starts[k]) / (starts[k + 1] - starts[k]), 0.0)
        return np.radians(table[rows] + share[:, None] * (table[np.minimum(rows + 1, len(starts))] - table[rows]))

    def velocity(self, target: np.ndarray, angles_rad: np.ndarray) -> np.ndarray:
        """Joint velocity targets [rad/s] towards ``target`` [rad] from ``angles_rad``."""
        # two ufuncs instead of np.clip: this runs at every control update of every rollout
        velocity = np.multiply(target - angles_rad, self.kp)
        return np.minimum(np.maximum(velocity, -self.v_max, out=velocity), self.v_max, out=velocity)

    def command(self, t: float, angles_rad: np.ndarray) -> np.ndarray:
        """Joint velocity targets [rad/s] at simulated time ``t`` for joint angles ``angles_rad``."""
        return self.velocity(self.targets([t])[0], angles_rad)
