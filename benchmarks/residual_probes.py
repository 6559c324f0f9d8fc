"""What might explain a tuned run's remaining marker error: four candidate effects, each measured on top of the run.

The run's best parameters stay fixed; each probe adds one effect the parameter spaces do not have and
reports the mean wrist (marker) error with it, against the run's own:

- ``translation``: the whole recording shifted by one constant vector (a motion-capture frame offset),
  the best such vector (Nelder-Mead on the mean 3-D error);
- ``link lengths``: the joint origins of the kinematic chain lengthened or shortened (the main axis of
  each of joints 1-6, within +-2 cm), fitted by least squares on the marker residual.  The simulated
  joint angles stay as simulated; only the marker is moved by the difference of the two chains'
  forward kinematics (a geometry error of this size barely changes the dynamics);
- ``feedback lag``: the controller reads its encoders 0.5-3 control periods late (interpolated), the
  run simulated anew for each;
- ``lag + dead band``: as well, the velocity command dropped to zero below 2, 5 or 10 deg/s (a
  joint that stops once the P law asks for less than its static friction lets it);
- ``backlash``: each joint's link lags its motor by half a play ``b_j`` against its last direction of
  motion (above 0.5 deg/s), ``b_j`` fitted by least squares on the marker (kinematic, as link lengths);
- ``encoder scale``: each joint's encoder reads ``(1 + s_j)`` times its angle (a gear-ratio error) besides
  an offset ``o_j``, both fitted so; beside it the offsets alone refitted, its baseline.

Last, **what each rest pose asks of the joints**: the recordings also hold the wrist body's orientation
(which the fitness does not use).  At the end of each stretch of the schedule (its last second, where the
arm rests), the recorded position and orientation (mean over the repeats, each on the aligned clock) against
the simulated link frame; the marker body's fixed rotation in that frame taken from the best-placed rest
pose; then, per rest pose, the small joint changes (least squares, 1 deg weighed as 5 mm, a light pull to
zero) that would place the simulated wrist there.  One calibration explains the rest poses only if they ask
for the same changes.

Also printed: the marker error every 0.25 s with the simulated and recorded wrist, whether the arm
touches the object then (from the engine's contact list), and (MuJoCo) the simulated wrist when the
fingers pass through the object: where the error sits, and whether a contact holds the arm.

    python benchmarks/residual_probes.py RUN_DIR [--data ROOT] [--reference aligned|mean]
"""

from __future__ import annotations

import dataclasses
import sys
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from common import add_data_option, load_best, make_parser
from scipy.optimize import least_squares, minimize

from simtune.data.clock import REFERENCES
from simtune.engines import engine_class
from simtune.engines.controller import JointController
from simtune.fitness import marker_positions
from simtune.objective import Objective, load_references
from simtune.runs import read_run_record

#: the main axis of each joint origin of the MICO's chain that a length error would change (joint, axis)
CHAIN_LENGTHS = (
    ("joint_1", 2),
    ("joint_2", 2),
    ("joint_3", 1),
    ("joint_4", 1),
    ("joint_4", 2),
    ("joint_5", 1),
    ("joint_5", 2),
    ("joint_6", 1),
    ("joint_6", 2),
)


@contextmanager
def controller_variant(lag_periods: float, dead_band_deg_s: float):
    """Every JointController made inside reads its encoders ``lag_periods`` control periods late and sends no
    velocity below ``dead_band_deg_s``."""
    original_init, original_velocity = JointController.__init__, JointController.velocity

    def init(self, *args, **kwargs):
        original_init(self, *args, **kwargs)
        self.history = []

    def velocity(self, target, angles):
        self.history.append(np.array(angles))
        whole, part = int(np.floor(lag_periods)), lag_periods - np.floor(lag_periods)
        newer = self.history[max(0, len(self.history) - 1 - whole)]
        older = self.history[max(0, len(self.history) - 2 - whole)]
        command = original_velocity(self, target, (1 - part) * newer + part * older)
        return np.where(np.abs(command) < np.radians(dead_band_deg_s), 0.0, command)

    JointController.__init__, JointController.velocity = init, velocity  # type: ignore[method-assign]
    try:
        yield
    finally:
        JointController.__init__, JointController.velocity = original_init, original_velocity  # type: ignore[method-assign]


def main() -> int:
    parser = make_parser(__doc__.split("\n\n")[0])
    parser.add_argument("run", type=Path)
    add_data_option(parser, default=None, help="the recordings' root (default: the tasks' own)")
    parser.add_argument("--reference", choices=REFERENCES, help="what to score against (default: the run's own)")
    args = parser.parse_args()
    best, task = load_best(args.run)
    params = dict(best["params"])
    reference = args.reference or read_run_record(args.run).settings.reference
    ref = load_references(args.data, [task], reference=reference)[task.name]
    assert ref.wrist_mean is not None, "a wrist-tracking task"
    objective = Objective(best["engine"], [task], {task.name: ref})
    rollout = objective.rollouts(params)[task.name]
    marker = marker_positions(rollout, params)
    diff = marker - ref.wrist_mean
    wrist = float(np.linalg.norm(diff, axis=1).mean())
    setting = f"{best['engine']} {task.name} {best['space']}, {reference} reference"
    print(f"\n#### Residual probes on {args.run} ({setting})\n")

    # where the error sits, with the arm's contacts with the object
    engine = engine_class(best["engine"])(task)
    touching: set[int] = set()
    clock = {"t": 0.0}

    def after_step() -> None:
        clock["t"] += engine.timestep
        if engine.arm_object_contact():
            touching.add(int(clock["t"] * 4))

    engine.rollout(params, len(ref.times), after_step=after_step)
    through = None
    if best["engine"] == "mujoco":  # the same run with the fingers passing through the object
        import mujoco

        model = engine.model  # type: ignore[attr-defined]
        fingers = [
            g
            for g in range(model.ngeom)
            if "finger" in (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, model.geom_bodyid[g]) or "")
        ]
        model.geom_contype[fingers] = model.geom_conaffinity[fingers] = 0
        through = marker_positions(engine.rollout(params, len(ref.times)), params)
    engine.close()
    print(
        "| t [s] | simulated wrist [mm] | recorded [mm] | error [mm] | arm touches object | fingers through it [mm] |"
    )
    print("|---:|---|---|---:|---|---|")
    for k in range(0, len(ref.times), 5):
        t = float(ref.times[k])
        sim, real = (" ".join(f"{v * 1000:.0f}" for v in p) for p in (marker[k], ref.wrist_mean[k]))
        touch = "yes" if int(t * 4) in touching else ""
        free = "" if through is None else " ".join(f"{v * 1000:.0f}" for v in through[k])
        print(f"| {t:.2f} | {sim} | {real} | {np.linalg.norm(diff[k]) * 1000:.1f} | {touch} | {free} |")

    rows = [("the run", wrist)]
    shift = minimize(lambda v: np.linalg.norm(diff - v, axis=1).mean(), diff.mean(axis=0), method="Nelder-Mead")
    rows.append((f"translation {np.round(shift.x * 1000, 1).tolist()} mm", float(shift.fun)))

    robot = task.robot
    controller = JointController(task, params)
    true_angles = np.array([controller.true_angles(q) for q in rollout.joint_angles])
    offset = np.array([params.get(f"marker_offset_{a}", 0.0) for a in "xyz"])
    names = [j.name for j in robot.joints]

    def markers_at(chain, angles: np.ndarray) -> np.ndarray:
        """The marker of ``chain`` (a robot description) at each row of joint ``angles``."""
        out = []
        for q in angles:
            pos, rot = chain.forward_kinematics(q)
            out.append(pos + rot @ offset)
        return np.array(out)

    def chain_markers(deltas: np.ndarray) -> np.ndarray:
        joints = list(robot.joints)
        for (name, axis), delta in zip(CHAIN_LENGTHS, deltas):
            i = names.index(name)
            xyz = list(joints[i].xyz)
            xyz[axis] += delta
            joints[i] = dataclasses.replace(joints[i], xyz=tuple(xyz))
        return markers_at(dataclasses.replace(robot, joints=tuple(joints)), true_angles)

    nominal = chain_markers(np.zeros(len(CHAIN_LENGTHS)))
    n = len(ref.times)

    def kinematic_fit(markers_of, size: int, bound: float) -> tuple[np.ndarray, float]:
        """Fit ``size`` values (within +-``bound``) of an effect that moves the marker to ``markers_of(values)``
        (the run's marker moved by the difference of forward kinematics); the values and the wrist error."""
        fit = least_squares(
            lambda v: ((marker + markers_of(v) - nominal - ref.wrist_mean) / np.sqrt(n)).ravel(),
            np.zeros(size),
            bounds=(-bound, bound),
            diff_step=1e-3,
        )
        moved = marker + markers_of(fit.x) - nominal
        return fit.x, float(np.linalg.norm(moved - ref.wrist_mean, axis=1).mean())

    deltas, error = kinematic_fit(chain_markers, len(CHAIN_LENGTHS), 0.02)
    lengths = ", ".join(f"{j} {'xyz'[a]} {d * 1000:+.1f}" for (j, a), d in zip(CHAIN_LENGTHS, deltas))
    rows.append((f"link lengths ({lengths} mm)", error))

    joints = true_angles.shape[1]
    speed = np.gradient(true_angles, ref.times[: len(true_angles)], axis=0)
    direction = np.zeros_like(true_angles)  # the last direction each joint moved in faster than 0.5 deg/s
    last = np.zeros(joints)
    for k, v in enumerate(speed):
        last = np.where(np.abs(v) > np.radians(0.5), np.sign(v), last)
        direction[k] = last
    play, error = kinematic_fit(lambda b: markers_at(robot, true_angles - 0.5 * b * direction), joints, 0.15)
    rows.append((f"backlash (play {np.round(np.degrees(play), 2).tolist()} deg)", error))
    offsets, error = kinematic_fit(lambda o: markers_at(robot, true_angles + o), joints, 0.1)
    rows.append((f"joint offsets refitted ({np.round(np.degrees(offsets), 2).tolist()} deg)", error))
    both, error = kinematic_fit(
        lambda p: markers_at(robot, true_angles + p[:joints] + p[joints:] * true_angles), 2 * joints, 0.2
    )
    rows.append(
        (
            f"encoder scale {np.round(both[joints:], 3).tolist()} + offsets "
            f"{np.round(np.degrees(both[:joints]), 2).tolist()} deg",
            error,
        )
    )

    for lag, band in [(lag, 0.0) for lag in (0.5, 1, 2, 3)] + [(1, band) for band in (2, 5, 10)]:
        with controller_variant(lag, band):
            score = objective.score(params)
        label = f"feedback lag {lag:g} periods" + (f" + dead band {band:g} deg/s" if band else "")
        rows.append((f"{label} (object {score.object_error or 0.0:.4f} m)", score.wrist_error or 0.0))
    objective.close()

    print("\n| with | wrist error [m] |")
    print("|---|---:|")
    for label, value in rows:
        print(f"| {label} | {value:.4f} |")
    rest_pose_changes(task, ref, params, true_angles)
    return 0


def rest_pose_changes(task, ref, params: dict, true_angles: np.ndarray) -> None:
    """Print, per rest pose at the end of each stretch of ``task``, the joint changes that would place the simulated
    wrist where the recordings (position and orientation, mean over the aligned repeats) put it."""
    from scipy.spatial.transform import Rotation

    from simtune.check.task import REST_WINDOW_S
    from simtune.data.loaders import load_recording
    from simtune.engines.controller import JointController

    shifts = ref.alignment.shifts if ref.alignment is not None else np.zeros(len(ref.sources))
    recordings = [load_recording(source) for source in ref.sources]
    robot, offset = task.robot, np.array([params.get(f"marker_offset_{a}", 0.0) for a in "xyz"])
    poses = []
    for label, _, end in task.stretches(JointController(task, params).delay):
        window = (end - REST_WINDOW_S[0], end - REST_WINDOW_S[1])  # at rest, whatever its repeat's jitter
        positions, rotations = [], []
        for rec, shift in zip(recordings, shifts):
            at = (rec.time + shift >= window[0]) & (rec.time + shift <= window[1])
            rot = rec.rotations[task.wrist_body][at]
            keep = np.isfinite(rot).all(axis=(1, 2))
            if keep.any():
                positions.append(np.nanmean(rec.positions[task.wrist_body][at], axis=0))
                rotations.append(Rotation.from_matrix(rot[keep]).mean())
        if not rotations:
            continue
        sample = min(int(round(np.mean(window) * ref.rate)), len(true_angles) - 1)
        real_rot = Rotation.from_quat(np.array([r.as_quat() for r in rotations])).mean().as_matrix()
        poses.append((label, true_angles[sample], np.mean(positions, axis=0), real_rot))

    def frame(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        pos, rot = robot.forward_kinematics(q)
        return pos + rot @ offset, rot

    errors = [np.linalg.norm(frame(q)[0] - real) for _, q, real, _ in poses]
    anchor = int(np.argmin(errors))
    in_link = frame(poses[anchor][1])[1].T @ poses[anchor][3]  # the marker body's rotation in the link frame

    def residual(change: np.ndarray, q: np.ndarray, real_pos: np.ndarray, real_rot: np.ndarray) -> np.ndarray:
        pos, rot = frame(q + change)
        turn = Rotation.from_matrix(rot.T @ real_rot @ in_link.T).as_rotvec()
        return np.r_[1000 * (pos - real_pos), 5 * np.degrees(turn), 0.2 * np.degrees(change)]

    print(
        "\n| rest pose (last second of) | simulated joints [deg] | position off [mm] | orientation off [deg] | "
        "joint changes that place it [deg] | left [mm] |"
    )
    print("|---|---|---:|---:|---|---:|")
    for label, q, real_pos, real_rot in poses:
        before = residual(np.zeros(len(q)), q, real_pos, real_rot)
        fit = least_squares(residual, np.zeros(len(q)), args=(q, real_pos, real_rot))
        left = residual(fit.x, q, real_pos, real_rot)
        mark = " (orientation reference)" if label == poses[anchor][0] else ""
        print(
            f"| {label}{mark} | {' '.join(f'{v:.1f}' for v in np.degrees(q))} | {np.linalg.norm(before[:3]):.1f} | "
            f"{np.linalg.norm(before[3:6]) / 5:.1f} | {' '.join(f'{v:+.1f}' for v in np.degrees(fit.x))} | "
            f"{np.linalg.norm(left[:3]):.1f} |"
        )


if __name__ == "__main__":
    sys.exit(main())
