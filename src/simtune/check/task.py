"""`simtune check`: before hours of tuning, what the recordings are like and what they can inform.

Three parts, per task and then for the tasks together:

- data quality: for each recording, the frames where the wrist marker was lost and the longest
  gap (the loader bridges gaps up to 0.25 s and leaves out a repeat with a longer one, with a
  warning the check lists); how well the repeats agree (each one's mean distance from the mean
  track, and the largest), with and without their clocks aligned (:mod:`simtune.data.clock`: each
  repeat's shift, an outlying one flagged); the floor: the fitness of the aligned mean against each
  repeat, what a simulation as good as the arm's own repeats scores; how far each repeat's first
  wrist sample lies from where the simulated arm's marker starts (a large distance: another start
  pose, or a misplaced base);
- the motion onset of each repeat (:func:`simtune.data.onset.motion_onset`) and of the generic
  simulation: their difference is the delay between pressing record and the first command;
- the rest poses: at the end of each phase the generic simulation rests where the phase's targets put
  the arm; the recorded wrist over that phase's last second (on the recordings' clock, the delay
  above added) is compared with it (:func:`rest_poses`).  Where one lies more than
  :data:`~simtune.objective.START_WARN_M` off (or, where the recordings give the wrist's orientation, is
  turned more than :data:`ORIENTATION_WARN_DEG`) while the others agree, that phase's targets are not
  what the real arm reached: a tuned calibration cannot take that up.  For such a rest (and a far start pose)
  the check proposes the targets that place it: inverse kinematics of the tracked link's position and
  orientation (:func:`propose_targets`; the orientation from a motion-capture body's rotation or from joint logs
  of every driven joint, :func:`_recorded_frames`), of its position alone where the recordings give no
  orientation;
- which parameters the tasks can inform: the Jacobian of the per-sample residuals at the
  generic point (:func:`simtune.uncertainty.jacobian`, one batch of rollouts), its rank and
  singular values, and for each active parameter whether the recordings could pin it: the
  Gauss-Newton analysis of :func:`simtune.uncertainty.analyse` with the noise the repeats'
  own scatter puts on their mean track (:func:`repeat_noise`), not the generic point's misfit.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np

from simtune.activity import active_space, inactive_parameters
from simtune.alignment import PROBE_DELAY_S
from simtune.data import TaskData, load_recording
from simtune.data.clock import outlying_shifts
from simtune.data.ingest import data_check_entries
from simtune.data.onset import motion_onset
from simtune.data.orientation import RecordedRotations
from simtune.engines import engine_class, make_engine
from simtune.engines.contact import generic_floor_touches
from simtune.errors import SimtuneError
from simtune.fitness import NOISE_UNIT_M, marker_positions, reference_floor, repeat_floor
from simtune.identifiability import identifiability
from simtune.objective import START_WARN_M, Objective, generic_values, load_references, recordings_folder
from simtune.params import get_space
from simtune.params.kinds import FIXED_BOUNDS
from simtune.tasks import TaskSpec
from simtune.tasks.spec import common_robot
from simtune.uncertainty import RCOND, Z95, analyse, correlation_time, jacobian

#: A repeat whose mean distance from the mean track exceeds this multiple of the median repeat's is flagged.
OUTLIER_FACTOR = 3.0


def _gaps(path: Path, body: str) -> tuple[int, float]:
    """Frames in which ``body`` was lost, and its longest gap [s], in one recording."""
    rec = load_recording(path)
    xyz = rec.positions.get(body)
    if xyz is None:
        return 0, 0.0
    lost = np.isnan(xyz).any(axis=1)
    if not lost.any():
        return 0, 0.0
    period = float(np.median(np.diff(rec.time)))
    longest, run = 0, 0
    for flag in lost:
        run = run + 1 if flag else 0
        longest = max(longest, run)
    return int(lost.sum()), longest * period


def _repeat_rows(task: TaskSpec, aligned: TaskData, plain_agreement: np.ndarray, sim_start: np.ndarray) -> list[dict]:
    """One row per repeat: its gaps, its distance from the mean track (aligned, and as recorded), its start,
    its motion onset on its own clock, its clock shift and the fitness floor it sets."""
    assert aligned.wrist_repeats is not None and aligned.wrist_mean is not None and aligned.alignment is not None
    agreement = np.linalg.norm(aligned.wrist_repeats - aligned.wrist_mean[None], axis=2).mean(axis=1)
    typical = float(np.median(agreement))
    shifts = aligned.alignment.shifts
    odd = set(outlying_shifts(shifts, 1.0 / aligned.rate))
    floor = repeat_floor(aligned)
    rows = []
    for i, source in enumerate(aligned.sources):
        lost, longest = _gaps(source, task.wrist_body)
        rows.append(
            {
                "file": Path(source).name,
                "lost_frames": lost,
                "longest_gap_s": longest,
                "distance_to_mean_m": float(agreement[i]),
                "distance_to_mean_unaligned_m": float(plain_agreement[i]),
                "outlier": bool(typical > 0 and agreement[i] > OUTLIER_FACTOR * typical),
                "start_distance_m": float(np.linalg.norm(aligned.wrist_repeats[i, 0] - sim_start)),
                "onset_s": aligned.alignment.onsets[i],
                "shift_s": float(shifts[i]),
                "shift_outlier": i in odd,
                "floor_fitness": float(floor[i]) if len(aligned.sources) > 1 else None,
            }
        )
    return rows


def onset_summary(rows: list[dict]) -> dict:
    """The repeats' motion onsets summed up so that one odd repeat does not carry them (probe 5: the real `single`'s
    Single0010's onset is read at 0.04 s, the others' at 1.0-1.45 s: it pulled the mean from 1.27 to 1.21 s, the
    std from 0.12 to 0.28 s and the command delay from 1.25 to 1.19 s): the median, and the mean and std of the
    onsets within :func:`~simtune.data.clock.outlier_limit` of it (the limit the clock shifts' outliers are found
    by, :data:`~simtune.data.clock.OUTLIER_MIN_REPEATS` repeats at the fewest).

    Args:
        rows: the repeats' rows (:func:`_repeat_rows`: each one's ``file`` and ``onset_s``, None where it never moves).
    Returns:
        ``onset_median_s`` (what the command delay is estimated from, as the tune's clock alignment does),
        ``onset_mean_s`` and ``onset_std_s`` (of the onsets kept; None where none, the std where fewer than two),
        and ``onset_outliers``: per onset left out, its ``file``, ``onset_s``, ``from_median_s`` and ``shift_s`` (its
        clock shift, which the alignment refines past the onset).
    """
    timed = [(r["file"], float(r["onset_s"]), r["shift_s"]) for r in rows if r["onset_s"] is not None]
    onsets = np.array([t for _, t, _ in timed])
    odd = set(outlying_shifts(onsets)) if len(onsets) else set()
    median = float(np.median(onsets)) if len(onsets) else None
    kept = np.array([t for i, t in enumerate(onsets) if i not in odd])
    return {
        "onset_median_s": median,
        "onset_mean_s": float(np.mean(kept)) if len(kept) else None,
        "onset_std_s": float(np.std(kept, ddof=1)) if len(kept) > 1 else None,
        "onset_outliers": [
            {"file": timed[i][0], "onset_s": timed[i][1], "from_median_s": timed[i][1] - median, "shift_s": timed[i][2]}
            for i in sorted(odd)
            if median is not None
        ],
    }


#: the stretch of each phase's end compared as its rest pose: from this long before the end ... [s]
REST_WINDOW_S = (1.0, 0.2)  # ... to this long before it (the arm has settled; the next command not yet arrived)

#: a far rest is put on one joint where that joint alone takes the rest to within this share of its distance
#: (a script edited on one joint, a controller limit on one joint: the common causes), else on every joint
SINGLE_JOINT_SHARE = 0.5
#: the weight [m per rad] that keeps joints the recorded rest does not ask for where they are, in the every-joint
#: fit: a millimetre of position is worth moving a joint by about 0.06 deg
STAY_WEIGHT_M_PER_RAD = 0.001
#: an orientation error weighs in the inverse kinematics as the position error it makes this far [m] from the
#: tracked link's origin, about a hand's length: a degree counts as 1.7 mm
ORIENTATION_LEVER_M = 0.1
#: an orientation left within this [deg] of the recorded one needs no further joint: the rests that lie near agree
#: with each other to 0.8-1.8 deg on the real MICO (qrg2019 `single` and `cube`)
ORIENTATION_TOL_DEG = 2.0
#: a rest turned more than this [deg] from the simulated one is far by its orientation, whatever its position: the rests
#: that lie near agree to 0.8-1.8 deg; the `cube`'s phase-2 joint 3 at its published 65 deg turns the wrist 10 deg
ORIENTATION_WARN_DEG = 5.0
#: a proposal that leaves more than this of a far rest's position [m] (and more than START_WARN_M and than
#: SINGLE_JOINT_SHARE of its gap) does not place it: no joint targets reach the recorded rest (probe 5 #14: a wrist
#: recorded 1.7 m off was 'proposed' six new targets that left 1.4 m), so nothing is proposed for it
UNREACHED_M = 0.1


def moved_joints(proposal: dict) -> str:
    """The joints a :func:`propose_targets` proposal moves, as words (``joint_3 65 -> 75.1 deg``); empty if none.

    Args:
        proposal: a proposal as the check returns it (its ``changed``: name -> [before, after] deg).
    Returns:
        One phrase per moved joint, joined by commas.
    """
    return ", ".join(f"{name} {a:g} -> {b:g} deg" for name, (a, b) in proposal["changed"].items())


def out_of_reach(proposal: dict) -> bool:
    """Whether a :func:`propose_targets` proposal leaves the far rest's position far: more than
    :data:`~simtune.objective.START_WARN_M` and more than the lesser of :data:`SINGLE_JOINT_SHARE` of its gap and
    :data:`UNREACHED_M`: no joint targets place that rest (it lies out of the arm's reach, or the recordings are in
    another frame or unit than the robot).

    Args:
        proposal: a proposal as :func:`propose_targets` returns it.
    Returns:
        True where the proposal does not place the rest.
    """
    left, gap = proposal["residual_after_m"], proposal["residual_before_m"]
    return bool(left > START_WARN_M and left > min(SINGLE_JOINT_SHARE * gap, UNREACHED_M))


def _joint_range(task: TaskSpec, index: int, around: float) -> tuple[float, float]:
    """Where driven joint ``index`` may be put [rad]: its limits, or half a turn either side of ``around``."""
    joint = task.robot.joint_by_name[task.joints[index]]
    if joint.lower is not None and joint.upper is not None:
        return float(joint.lower), float(joint.upper)
    return around - np.pi, around + np.pi


def angle_deg(rotation: np.ndarray) -> float:
    """The angle [deg] of a rotation matrix (3, 3): how far it turns, about whatever axis."""
    return float(np.degrees(np.arccos(np.clip((np.trace(rotation) - 1.0) / 2.0, -1.0, 1.0))))


def _pose_miss(task: TaskSpec, q0: np.ndarray, gap_m, turn: np.ndarray | None, offset: np.ndarray | None = None):
    """The marker's miss at joint angles q [rad] from the goal ``gap_m`` and ``turn`` set: its position [m] (the
    tracked link's origin, or the point ``offset`` from it in the link's frame), then (with ``turn``) its
    orientation as a rotation vector times :data:`ORIENTATION_LEVER_M` [m]."""
    from scipy.spatial.transform import Rotation

    robot, link = task.robot, task.tracked_link
    point = np.zeros(3) if offset is None else np.asarray(offset, dtype=float)
    origin, frame = robot.forward_kinematics(q0, link)
    goal = origin + frame @ point + np.asarray(gap_m, dtype=float)
    # the gap is kept in the link's frame: the simulated rest's own turn from the kinematic pose (the sag) stays
    goal_frame = None if turn is None else frame @ turn

    def miss(q: np.ndarray) -> np.ndarray:
        position, rotation = robot.forward_kinematics(q, link)
        position = position + rotation @ point
        if goal_frame is None:
            return position - goal
        twist = Rotation.from_matrix(goal_frame.T @ rotation).as_rotvec()
        return np.concatenate([position - goal, ORIENTATION_LEVER_M * twist])

    return miss


def _add_joint(task: TaskSpec, q0: np.ndarray, moving: list[int], miss) -> tuple[np.ndarray, int | None]:
    """The pose ``q0`` (whose joints ``moving`` are free) with one more joint free: for each other joint a grid over
    its range, then a bounded refinement of it with ``moving``; the best pose and its joint, or ``q0`` and None
    where no joint lowers the miss."""
    from scipy.optimize import least_squares

    best_q, best_joint, best_miss = q0, None, float(np.linalg.norm(miss(q0)))
    for j in (j for j in range(len(q0)) if j not in moving):
        free = [*moving, j]
        low, high = _joint_range(task, j, q0[j])
        grid = np.linspace(low, high, 721)
        trial = np.repeat(q0[None], len(grid), axis=0)
        trial[:, j] = grid
        start = q0.copy()
        start[j] = grid[int(np.argmin([np.linalg.norm(miss(q)) for q in trial]))]
        ranges = np.array([_joint_range(task, k, q0[k]) for k in free])

        def free_miss(x: np.ndarray, free: list[int] = free) -> np.ndarray:
            q = q0.copy()
            q[free] = x
            return miss(q)

        fit = least_squares(free_miss, np.clip(start[free], ranges[:, 0], ranges[:, 1]), bounds=ranges.T)
        q = q0.copy()
        q[free] = fit.x
        if np.linalg.norm(miss(q)) < best_miss:
            best_q, best_joint, best_miss = q, j, float(np.linalg.norm(miss(q)))
    return best_q, best_joint


def _placed(left: np.ndarray, before: np.ndarray) -> bool:
    """Whether a pose (its miss ``left``, against ``before``: :func:`_pose_miss`'s) places the rest: the position
    within :data:`SINGLE_JOINT_SHARE` of its gap (or of :data:`~simtune.objective.START_WARN_M`), and the orientation
    (where fitted) within that share of its turn or within :data:`ORIENTATION_TOL_DEG`: else the orientation asks
    for other joints."""
    # a rest far by its orientation alone may lie near: a position already within the far threshold asks no more
    if np.linalg.norm(left[:3]) > SINGLE_JOINT_SHARE * max(float(np.linalg.norm(before[:3])), START_WARN_M):
        return False
    tolerance = max(
        SINGLE_JOINT_SHARE * float(np.linalg.norm(before[3:])),
        ORIENTATION_LEVER_M * float(np.radians(ORIENTATION_TOL_DEG)),
    )
    return len(left) == 3 or bool(np.linalg.norm(left[3:]) <= tolerance)


def _fewest_joints(task: TaskSpec, q0: np.ndarray, miss, oriented: bool) -> np.ndarray:
    """The pose that places the rest (:func:`_placed`) moving the fewest joints: one joint alone where it does,
    else (with an orientation) one joint more at a time, the one that leaves the least; where that does not place
    it either, every joint, each weighed to stay where it is (:data:`STAY_WEIGHT_M_PER_RAD`), if that leaves less."""
    from scipy.optimize import least_squares

    before = miss(q0)
    best_q, moving = q0, list[int]()
    # a position alone asks for one joint or for all: its 3 numbers cannot tell which second joint it asks for
    while len(moving) < (len(q0) if oriented else 1) and not _placed(miss(best_q), before):
        q, joint = _add_joint(task, best_q, moving, miss)
        if joint is None:
            break
        best_q, moving = q, [*moving, joint]
    if _placed(miss(best_q), before):
        return best_q
    ranges = np.array([_joint_range(task, j, q0[j]) for j in range(len(q0))])
    fit = least_squares(
        lambda q: np.concatenate([miss(q), STAY_WEIGHT_M_PER_RAD * (q - q0)]),
        np.clip(q0, ranges[:, 0], ranges[:, 1]),
        bounds=(ranges[:, 0], ranges[:, 1]),
    )
    return fit.x if np.linalg.norm(miss(fit.x)) < np.linalg.norm(miss(best_q)) else best_q


def propose_targets(
    task: TaskSpec, targets_deg, gap_m, turn: np.ndarray | None = None, offset: np.ndarray | None = None
) -> dict:
    """The joint targets that put the tracked link's rest ``gap_m`` [m] (recorded minus simulated) and, where the
    recordings give the orientation, ``turn`` (the recorded rest's rotation in the simulated rest's link frame)
    from where ``targets_deg`` put it: inverse kinematics within the joint limits.

    The simulated rest's own offset from the kinematic pose at the targets (gravity's sag, the controller's steady
    error) is kept: the goal is the kinematic pose moved by the gap (and turned by ``turn``), its orientation
    weighed by :data:`ORIENTATION_LEVER_M`.  The fewest joints that place the rest move (:func:`_fewest_joints`):
    a joint the position and orientation do not ask for stays where it is.

    Args:
        task: the task (its robot, driven joints and tracked link).
        targets_deg: the phase's targets (or the start pose) [deg], one per driven joint.
        gap_m: the recorded rest minus the simulated one [m], (3,).
        turn: the simulated rest's link rotation to the recorded one, in the link's frame (3, 3); None where the
            recordings give the position only.
        offset: the marker's point in the link's frame [m] (:func:`marker_offset`), which ``gap_m`` was measured
            from; None: the link's origin.
    Returns:
        ``targets_deg`` (the proposal), ``changed`` (the joints it moves: name -> [before, after] deg),
        ``residual_before_m`` (the gap's length) and ``residual_after_m`` (what the kinematics leave of it),
        ``fit`` (``position and orientation`` or ``position only``), ``orientation_before_deg`` and
        ``orientation_after_deg`` (the turn's angle, and what is left of it; None for a position-only fit) and
        ``marker_offset_m`` (``offset``, or None).
    """
    q0 = np.radians(np.asarray(targets_deg, dtype=float))
    miss = _pose_miss(task, q0, gap_m, turn, offset)
    best_q = _fewest_joints(task, q0, miss, turn is not None)
    proposal = [round(float(v), 1) for v in np.degrees(best_q)]
    proposal = [float(t) if abs(p - t) < 0.05 else p for p, t in zip(proposal, targets_deg)]
    left = miss(np.radians(proposal))
    turned_deg = float(np.degrees(np.linalg.norm(left[3:]) / ORIENTATION_LEVER_M))  # 0 where it fits position only
    return {
        "targets_deg": proposal,
        "changed": {name: [float(t), p] for name, t, p in zip(task.joints, targets_deg, proposal) if p != float(t)},
        "residual_before_m": float(np.linalg.norm(gap_m)),
        "residual_after_m": float(np.linalg.norm(left[:3])),
        "fit": "position only" if turn is None else "position and orientation",
        "orientation_before_deg": None if turn is None else angle_deg(turn),
        "orientation_after_deg": None if turn is None else turned_deg,
        "marker_offset_m": None if offset is None else [float(v) for v in offset],
    }


def rest_poses(
    task: TaskSpec, reference: TaskData, simulated: tuple[np.ndarray, np.ndarray], delay: float
) -> list[dict]:
    """Per stretch of ``task``: where the generic simulation (``simulated``: its times and marker, no command delay)
    rests at the stretch's end, against the mean recorded wrist over the same last second on the recordings' clock
    (``delay`` [s] later; the recording's last second where that runs past it).  Each row names the two windows
    averaged (``simulated_window_s`` and ``recorded_window_s``); :func:`task_quality` adds the orientation and the
    proposals."""
    assert reference.wrist_mean is not None
    times, marker = simulated
    early, late = REST_WINDOW_S
    clock = reference.times
    rows = []
    for label, start, end in task.stretches():  # a stretch shorter than the window: from its start on
        sim_window = (max(start, end - early), end - late)
        recorded_end = min(end + delay, float(clock[-1]) + late)
        real_window = (max(start + delay, recorded_end - early), recorded_end - late)
        at_rest = (times >= sim_window[0]) & (times <= sim_window[1])
        recorded = (clock >= real_window[0]) & (clock <= real_window[1])
        if not at_rest.any() or not recorded.any():
            continue
        sim_pose, real_pose = marker[at_rest].mean(axis=0), reference.wrist_mean[recorded].mean(axis=0)
        distance = float(np.linalg.norm(sim_pose - real_pose))
        # "phase N" (the N-th phase, from 1), or the start pose held before a first phase that starts later
        phase = int(label.split()[-1]) - 1 if label.startswith("phase ") else -1
        targets = task.start_pose_deg if phase < 0 else task.phases[phase].targets_deg
        rows.append(
            {
                "stretch": label,
                "end_s": float(end),
                "simulated_m": [float(v) for v in sim_pose],
                "recorded_m": [float(v) for v in real_pose],
                "distance_m": distance,
                "far": distance > START_WARN_M,
                "phase": None if phase < 0 else phase,
                "targets_deg": [float(v) for v in targets],
                "simulated_window_s": [float(v) for v in sim_window],
                "recorded_window_s": [float(v) for v in real_window],
            }
        )
    return rows


def _recorded_frames(task: TaskSpec, reference: TaskData) -> tuple[dict, Callable | None]:
    """Where the recordings give the tracked link's orientation: ``orientation`` (its ``source``: ``joint logs``,
    ``wrist body`` or None, and a ``note`` saying what that means) and a function of a window on the recordings'
    clock [s] giving the recorded rotation there (3, 3), or None (position only)."""
    logged = reference.joint_names
    if reference.joint_mean is not None and set(task.joints) <= set(logged):
        columns = [logged.index(j) for j in task.joints]
        joint_mean = reference.joint_mean

        def from_joints(start: float, end: float) -> np.ndarray | None:
            at = (reference.times >= start) & (reference.times <= end)
            if not at.any():
                return None
            return task.robot.forward_kinematics(joint_mean[at][:, columns].mean(axis=0), task.tracked_link)[1]

        note = (
            "turned [deg]: the link's frame at the logged angles (every driven joint logged) against the simulated one"
        )
        return {"source": "joint logs", "note": note}, from_joints
    rotations = RecordedRotations(reference, task.wrist_body)
    if rotations.available:
        note = (
            f"turned [deg]: the rotation of motion-capture body {task.wrist_body!r} against the simulated link's, read "
            "in the link's frame through the body's fixed turn there (the mean over the rests that lie near; each of "
            "those against the others')"
        )
        return {"source": "wrist body", "note": note}, rotations.mean
    note = (
        f"turned: not measured: the recordings give the position of {task.wrist_body!r} only (no rotation, no joint "
        "log of every driven joint), so the proposals fit the position alone"
    )
    return {"source": None, "note": note}, None


def _against_near(raw: list, near: list[int]) -> list[np.ndarray | None]:
    """Each raw turn (simulated link frame to the recorded body's) read in the link's frame through the body's fixed
    turn there: the mean of the ``near`` rests' raw turns but its own; None where there is nothing to read it by."""
    from scipy.spatial.transform import Rotation

    turns: list[np.ndarray | None] = []
    for i, turn in enumerate(raw):
        others = [raw[k] for k in near if k != i]
        if turn is None or not others:
            turns.append(None)  # no near rest, or a lone near rest itself
        else:
            turns.append(turn @ Rotation.from_matrix(np.stack(others)).mean().as_matrix().T)
    return turns


def _orient(entries: list[dict], frames: list, orientation: dict) -> list[np.ndarray | None]:
    """Each rest's turn (the recorded link rotation in the simulated rest's link frame; None where unknown); each
    entry's ``orientation_deg`` (its angle) and, where that exceeds :data:`ORIENTATION_WARN_DEG`, ``orientation`` in
    its ``far_in`` (and it is ``far``).  ``frames``: per entry, the simulated and recorded rotation.

    A wrist body's rotation is read in the link's frame through its fixed turn there (where the rigid body's axes
    were put when it was defined): the mean over the rests that lie near, each of them measured against the others'
    mean.  Of three or more, the one the others disagree with most is left out while it lies more than
    :data:`ORIENTATION_WARN_DEG` off (far by its orientation); two that disagree cannot tell which one is turned."""
    raw = [None if real is None else sim.T @ real for sim, real in frames]
    turns, near = list(raw), list(range(len(entries)))
    if orientation["source"] == "wrist body":
        near = [i for i, e in enumerate(entries) if not e["far"] and raw[i] is not None]
        while True:
            turns = _against_near(raw, near)
            offs = {i: angle_deg(t) for i, t in zip(near, (turns[i] for i in near)) if t is not None}
            worst = max(offs, key=offs.__getitem__, default=None)
            if worst is None or offs[worst] <= ORIENTATION_WARN_DEG:
                break
            if len(near) < 3:
                orientation["note"] += (
                    f"; the two rests that lie near are turned {offs[worst]:.1f} deg from each other (which one is, "
                    "two cannot tell: neither is called far)"
                )
                break
            near.remove(worst)
        orientation["reference_rests"] = [entries[i]["stretch"] for i in near]
        if near:
            orientation["note"] += f"; the rests near: {', '.join(orientation['reference_rests'])}"
        else:
            orientation["note"] += "; every rest lies far, so none gives that turn: the proposals fit the position"
    for i, (entry, turn) in enumerate(zip(entries, turns)):
        entry["orientation_deg"] = None if turn is None else angle_deg(turn)
        entry["far_in"] = ["position"] if entry["far"] else []
        # a near rest of a wrist body that is still among the near ones is what the turn is read by: never far
        judged = orientation["source"] == "joint logs" or i not in near
        if judged and turn is not None and entry["orientation_deg"] > ORIENTATION_WARN_DEG:
            entry["far_in"].append("orientation")
            entry["far"] = True
    return turns


def marker_offset(entries: list[dict], frames: list, turns: list) -> np.ndarray | None:
    """Where the marker sits in the tracked link's frame [m] (3,), as the rests that lie near and whose orientation
    is known place it: the least-squares point whose turn with each simulated rest takes up their gaps, within the
    marker offset's range; None with fewer than two such rests (one would put its whole gap on the offset).

    The fit of a far rest's orientation turns the hand, and a marker off the link's origin moves with it: on the
    shipped reference (its marker 17 mm off) the proposal's joint 3 is 76.6 deg without the offset, 74.1 (the
    truth: 74) with it."""
    from scipy.optimize import lsq_linear

    near = [i for i, entry in enumerate(entries) if not entry["far"] and turns[i] is not None]
    if len(near) < 2:
        return None
    rotations = np.concatenate([frames[i][0] for i in near])
    gaps = np.concatenate([np.subtract(entries[i]["recorded_m"], entries[i]["simulated_m"]) for i in near])
    low, high = FIXED_BOUNDS["marker_offset"]
    return lsq_linear(rotations, gaps, bounds=(low, high)).x


def _rests(task: TaskSpec, reference: TaskData, rollout, marker: np.ndarray, delay: float) -> tuple[list, dict, dict]:
    """The rest poses (:func:`rest_poses`) and the start pose (the recorded rest at the start against the simulated
    arm's first sample), their orientation where the recordings give it, and targets proposed for those far off."""
    from scipy.spatial.transform import Rotation

    rows = rest_poses(task, reference, (rollout.times, marker), delay)
    start = None
    if reference.wrist_start_mean is not None:
        gap = reference.wrist_start_mean - marker[0]
        start = {
            "start_pose_deg": [float(v) for v in task.start_pose_deg],
            "recorded_m": [float(v) for v in reference.wrist_start_mean],
            "distance_m": float(np.linalg.norm(gap)),
            "far": bool(np.linalg.norm(gap) > START_WARN_M),
            "stretch": "start pose",
            "simulated_m": [float(v) for v in marker[0]],
            "simulated_window_s": [0.0, 0.0],
            "recorded_window_s": [0.0, reference.wrist_rest_end],
        }
    entries = rows + ([] if start is None else [start])
    orientation, recorded = _recorded_frames(task, reference)
    frames = []
    for entry in entries:
        low, high = entry["simulated_window_s"]
        at = (rollout.times >= low) & (rollout.times <= high)
        sim = Rotation.from_matrix(rollout.wrist_rot[at] if at.any() else rollout.wrist_rot[:1]).mean().as_matrix()
        frames.append((sim, None if recorded is None else recorded(*entry["recorded_window_s"])))
    turns = _orient(entries, frames, orientation)
    offset = marker_offset(entries, frames, turns)
    if offset is not None:
        orientation["marker_offset_m"] = [float(v) for v in offset]
    for entry, turn, (sim, _) in zip(entries, turns, frames):
        if not entry["far"]:
            continue
        targets = entry.get("targets_deg", task.start_pose_deg)
        gap = np.asarray(entry["recorded_m"]) - np.asarray(entry["simulated_m"])
        if turn is not None and offset is not None:  # measured from the marker's point, not the link's origin
            gap = gap - sim @ offset
        proposal = propose_targets(task, targets, gap, turn, None if turn is None else offset)
        if out_of_reach(proposal):  # said, never proposed nor written: no targets place it
            entry["out_of_reach"] = {k: proposal[k] for k in ("residual_before_m", "residual_after_m", "fit")}
        else:
            entry["proposal"] = proposal
    return rows, start or {}, orientation


def _floor_touches(sim) -> list[list[float]] | None:
    """:func:`~simtune.engines.contact.generic_floor_touches` of ``sim``, rounded for the check's JSON."""
    spans = generic_floor_touches(sim)
    return None if spans is None else [[round(a, 3), round(b, 3)] for a, b in spans]


def task_quality(
    engine: str,
    task: TaskSpec,
    root: Path | None,
    reference: str = "aligned",
    repeats: str = "all",
    keep: bool = False,
) -> tuple[dict, TaskData]:
    """The data-quality and onset part of the check for one task (its recordings under ``root``; None: in its own
    folder), and its loaded reference (``reference``: aligned or mean; ``repeats``: all, even or odd of the
    repeats).  The repeats are aligned either way, to report their clock shifts and their spread with and without
    alignment: the floor a tuned simulation should be compared with."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        aligned = load_references(root, [task], reference="aligned", repeats=repeats, keep_repeats=keep)[task.name]
        plain = load_references(root, [task], reference="mean", repeats=repeats, keep_repeats=keep)[task.name]
    if aligned.wrist_repeats is None or aligned.wrist_mean is None or plain.wrist_repeats is None:
        raise SimtuneError(
            f"check --task {task.name}: its recordings ({recordings_folder(root, task)}) hold joint angles and no "
            "wrist marker; this check reads the marker track (each repeat's onset and rest poses): `simtune check` "
            "on the project folder checks joint logs (the repeats' clock shifts and floor, their first angles "
            "against the start pose), and `simtune tune` warns at its start of parameters they hardly tell apart"
        )
    sim = make_engine(engine, task)
    try:
        rollout = sim.rollout({}, len(aligned.times))
        delayed = sim.rollout({"command_delay": PROBE_DELAY_S}, len(aligned.times))
        touches = _floor_touches(sim)
    finally:
        sim.close()
    sim_marker = marker_positions(rollout, {})
    # measured with the arm resting first, as a recording's onset is; the probe's delay taken off
    onset = motion_onset(delayed.times, marker_positions(delayed, {}))
    sim_onset = None if onset is None else onset - PROBE_DELAY_S
    assert plain.wrist_mean is not None
    plain_agreement = np.linalg.norm(plain.wrist_repeats - plain.wrist_mean[None], axis=2).mean(axis=1)
    rows = _repeat_rows(task, aligned, plain_agreement, sim_marker[0])
    chosen = aligned if reference == "aligned" else plain
    onsets = onset_summary(rows)
    median = onsets["onset_median_s"]
    delay = float(median - sim_onset) if median is not None and sim_onset is not None else None
    floor = reference_floor(aligned)
    summary = {
        "task": task.name,
        "reference": reference,
        "repeats": rows,
        # each warning once: both references are read, and each read warns alike
        "left_out": list(dict.fromkeys(str(w.message) for w in caught)),
        # the same warnings of named checks (the ingest's, the sanity stage's), each read into its parts
        "data_checks": data_check_entries([str(w.message) for w in caught]),
        "repeat_check_left_out": [Path(source).name for source in aligned.left_out],
        "repeat_spread_m": chosen.repeat_spread,
        "repeat_spread_aligned_m": floor.spread_aligned_m,
        "repeat_spread_unaligned_m": floor.spread_unaligned_m,
        "floor_fitness": floor.floor,
        "shift_range_s": [floor.shift_min_s, floor.shift_max_s],
        "shift_outliers": list(floor.outliers),
        "largest_distance_to_mean_m": max(
            r["distance_to_mean_m" if chosen is aligned else "distance_to_mean_unaligned_m"] for r in rows
        ),
        "start_distance_m": float(np.linalg.norm(chosen.wrist_mean[0] - sim_marker[0])),  # type: ignore[index]
        **onsets,
        "simulated_onset_s": sim_onset,
        "implied_command_delay_s": delay,
        "floor_touches_s": touches,
    }
    rests, start, orientation = _rests(task, chosen, rollout, sim_marker, max(delay or 0.0, 0.0))
    summary["rest_poses"], summary["orientation"] = rests, orientation
    if start:
        summary["start_pose"] = start
    if repeats != "all":  # which repeats the check used (the rows name them) and which it held out
        summary["repeat_selection"] = repeats
        summary["repeat_files"] = [row["file"] for row in rows]
        summary["held_out"] = [Path(source).name for source in aligned.held_out]
    return summary, chosen


def repeat_noise(references: list[TaskData], noise_weighted: bool = False) -> tuple[float, float]:
    """The variance of one wrist residual that the recordings' own scatter explains, and its correlation time.

    The mean track of R repeats is uncertain by the repeats' variance / R at each sample (per axis),
    in residual units (divided by the samples, as :func:`simtune.fitness.residuals` scales them);
    the repeats' deviations from their mean give the correlation time.  With ``noise_weighted`` residuals (each
    signal divided by its noise, in units of :data:`~simtune.fitness.NOISE_UNIT_M`) that variance is
    ``NOISE_UNIT_M**2 / R / samples`` whatever the scatter.
    """
    variances, deviations = [], []
    for reference in references:
        repeats, mean = reference.wrist_repeats, reference.wrist_mean
        if repeats is None or mean is None or len(repeats) < 2:
            continue
        n = len(reference.times)
        scatter = NOISE_UNIT_M**2 if noise_weighted else float(repeats.var(axis=0, ddof=1).mean())
        variances.append(scatter / len(repeats) / n)
        deviations.extend(list(repeats - mean[None]))
    if not variances:
        return 0.0, 1.0
    return float(np.mean(variances)), correlation_time(deviations)


def check(
    engine: str,
    tasks: list[TaskSpec],
    root: Path | None,
    space_name: str = "extended",
    workers: int = 1,
    *,
    reference: str = "aligned",
    repeats: str = "all",
    keep_repeats: bool = False,
    only: list[str] | None = None,
    at: dict[str, float] | None = None,
    at_name: str = "generic",
) -> dict:
    """Every part of the check for ``tasks`` on ``engine`` with the recordings under ``root`` (None: each task's own
    folder; the repeats ``repeats`` selects: all, even or odd; one far from the others left out unless
    ``keep_repeats``), the Jacobian's residuals against ``reference`` (aligned or mean), over the parameters of
    ``space_name`` (those of ``only`` alone, where given), at the generic point with the values of ``at`` in place
    (``at_name``: what the point is, in the result)."""
    cls = engine_class(engine)
    per_task, references = [], {}
    for task in tasks:
        summary, reference_data = task_quality(engine, task, root, reference, repeats, keep_repeats)
        per_task.append(summary)
        references[task.name] = reference_data
    robot = common_robot(tasks)
    full = get_space(space_name, cls.supported(robot), only, robot=robot)
    inactive = inactive_parameters(engine, tasks, full)
    space = active_space(full, inactive)
    # every signal weighed by its own noise, as new runs' least squares and intervals are (RunConfig.residuals)
    objective = Objective(engine, tasks, references, space, noise_weighted=True)
    every = {**generic_values(objective, sorted(cls.supported(robot))), **(at or {})}
    x = space.vector_within_bounds({n: every[n] for n in space.names if n in every})
    jac = jacobian(objective, x, workers)
    variance, inflation = repeat_noise(list(references.values()), noise_weighted=True)
    verdict = analyse(space, x, jac, inflation, inactive, variance)
    widths = np.array([p.high - p.low for p in space.parameters])
    # the weak combinations by the rule tune's start check warns by, with the noise the repeats put on their mean
    section = identifiability(
        space.names,
        jac.unit,
        x,
        widths,
        Z95 * float(np.sqrt(variance * inflation)),
        {**every, **dict(zip(space.names, x))},
    )
    s = np.asarray(verdict["singular_values"])
    parameters = []
    for i, (p, entry) in enumerate(zip(space.parameters, verdict["parameters"])):
        parameters.append(
            {
                "name": p.name,
                "value": float(x[i]),
                "informed": entry["identifiable"],
                "sensitivity": float(np.linalg.norm(jac.unit[:, i])),
            }
        )
    parameters += [
        {"name": n, "value": None, "informed": False, "sensitivity": 0.0, "inactive": why}
        for n, why in inactive.items()
    ]
    return {
        "engine": engine,
        "tasks": [t.name for t in tasks],
        "data": str(root) if root is not None else None,  # None: each task's own folder
        "space": space_name,
        "reference": reference,
        **({"repeats": repeats} if repeats != "all" else {}),
        "data_quality": per_task,
        "jacobian": {
            "point": at_name,
            "searched": len(space),
            "rank": verdict["rank"],
            "singular_values": [float(v) for v in s],
            "non_smooth": verdict["non_smooth"],
            "noise_m": float(np.sqrt(variance * np.mean([len(r.times) for r in references.values()]))),
            "cutoff": f"singular values below {RCOND:g} x the largest count as zero",
            "stable": jac.stable,
        },
        "parameters": parameters,
        "identifiability": {"point": at_name, **section},
    }
