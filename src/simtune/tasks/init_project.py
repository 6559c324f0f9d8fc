"""``simtune init``: a new project for a robot given as a URDF or an MJCF file, ready to run as written.

The project file names the robot file in place (never copied) with everything
:func:`~simtune.robot.load.load_robot` chose for it written out (driven joints, tracked link, held joints,
gripper links), so a user sees and edits those choices.  An MJCF's ``home`` keyframe, where it has one
(MuJoCo Menagerie's arms do), is the example task's start pose; its other keyframes are not read.  The
example task ``reach`` moves every driven joint a little within its limits and back, with no object.  The
folder is written beside its destination and renamed into place once the project loads, so an error leaves
nothing half-written.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import shutil
import tempfile
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from simtune.common.geometry import rpy_matrix
from simtune.data.formats import recording_kinds
from simtune.errors import ProjectError, RobotWarning
from simtune.robot.description import ZERO3, RobotDescription
from simtune.robot.inertia import DEFAULT_DENSITY
from simtune.robot.load import load_robot, robot_format
from simtune.robot.mjcf import home_pose
from simtune.robot.urdf import package_entry
from simtune.tasks.project import load_project

#: How far the example reach turns each joint [deg] (less where its limits leave less room).
REACH_DEG = 20.0
#: Lowest height [m] the tracked link may have at the reach's poses (above the floor, z = 0).
CLEARANCE_M = 0.05
#: Lowest height [m] of the arm's frames at the start pose before init looks for a higher one, and the angles
#: [deg] it tries per joint.
START_CLEARANCE_M = 0.1
START_CANDIDATES_DEG = (0.0, 30.0, -30.0, 60.0, -60.0, 90.0, -90.0, 120.0, -120.0)
#: How many driven joints (the first, from the root) that search turns; the others stay at 0 in their limits.
#: Every arm simtune knows has fewer (the joints that lift an arm off the floor are its first few); the cap
#: keeps the search linear in a long chain's length (a 1000-joint chain: about a second), where each joint it
#: turns costs a walk down the whole chain per candidate angle.
START_SEARCH_JOINTS = 12


def _toml(value) -> str:
    """A TOML value: strings and lists of numbers or strings (JSON writes both the way TOML reads them)."""
    if isinstance(value, float):
        if not math.isfinite(value):
            return json.dumps(value)
        short = f"{value:.6g}"
        return short if float(short) == value else repr(value)  # a locked joint's angle, say: every digit
    if isinstance(value, tuple | list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    # names as written (an emoji too): JSON's ASCII escapes write one as two surrogates, which TOML refuses
    return json.dumps(value, ensure_ascii=False)


def _deg(values, rooms: list[tuple[float, float]]) -> list[float]:
    """``values`` [deg] rounded to a thousandth inside their ``rooms``: inwards where rounding would leave one, and
    not at all where no thousandth lies inside (a locked joint, its lower limit equal to its upper)."""
    rounded = []
    for value, (low, high) in zip(values, rooms):
        r = round(float(value), 3)
        if r < low:
            r = math.ceil(low * 1000) / 1000
        if r > high:
            r = math.floor(high * 1000) / 1000
        rounded.append(r if low <= r <= high else float(value))
    return rounded


def _room(robot: RobotDescription, name: str) -> tuple[float, float]:
    """A driven joint's range less a tenth of it at each end [deg] (a continuous joint: +-180)."""
    joint = robot.joint_by_name[name]
    if joint.lower is None or joint.upper is None:
        return -180.0, 180.0
    lower, upper = math.degrees(joint.lower), math.degrees(joint.upper)
    margin = 0.1 * (upper - lower)
    return lower + margin, upper - margin


class _ChainHeights:
    """The heights of the link frames on the chain from the root to the tracked link, all of them in one walk
    down it, for :func:`clearance` and the start pose's search.

    ``forward_kinematics`` per link walked the chain again for every link, and the search asks for every
    joint and every candidate angle: cubic in the joint count (a 100-joint chain kept ``init`` silent for
    three minutes).  Here a walk is linear, each joint's turn is made once, and the search walks on from the
    joint it varies, the frames above it kept.  Each step is ``forward_kinematics``' own arithmetic in its
    order, so the heights, and the pose chosen, are the same to the last bit.
    """

    def __init__(self, robot: RobotDescription) -> None:
        self.joints = robot.chain(robot.tracked_link)
        names = [j.name for j in self.joints]
        second = robot.arm_joints[1] if robot.n_joints > 1 else robot.arm_joints[0]
        last = len(self.joints) - 1
        # the links that the driven joints can raise or lower: those below the second driven joint (else the
        # tracked link alone)
        counted = range(names.index(second) + 1, last + 1) if second in names else range(last, last + 1)
        self.counted = set(counted) or {last}
        self.chain_index = {name: k for k, name in enumerate(names)}
        self.arm_joints = robot.arm_joints
        arm_index = {name: i for i, name in enumerate(robot.arm_joints)}
        # per joint, what a step needs (looked up once: the search takes hundreds of thousands of steps)
        self.steps = [
            (
                j,
                np.asarray(j.xyz, dtype=float),
                rpy_matrix(j.rpy),
                j.moves,
                j.kind == "prismatic",
                arm_index.get(j.name),
                k in self.counted,
            )
            for k, j in enumerate(self.joints)
        ]
        self.base = np.array(robot.base_position, dtype=float)
        self.base_rot = rpy_matrix(robot.base_rpy) if robot.base_rpy != ZERO3 else np.eye(3)
        self._motions: dict[tuple[int, float], tuple[np.ndarray, np.ndarray]] = {}

    def _walk(self, q: np.ndarray, first: int, end: int, pos, rot, lowest: float):
        """(position, rotation, lowest counted height) after the chain's joints ``first`` to ``end - 1``, from
        the frame ``pos``/``rot`` above joint ``first``; ``q``: the driven joints' positions [rad]."""
        motions = self._motions
        for k in range(first, end):
            joint, offset, turn, moves, prismatic, index, counted = self.steps[k]
            pos = pos + rot @ offset
            rot = rot @ turn
            if moves:
                value = q[index] if index is not None else 0.0
                key = (k, float(value))
                motion = motions.get(key)
                if motion is None:
                    motion = motions[key] = joint.motion(value)
                if prismatic:
                    pos = pos + rot @ motion[0]
                else:
                    rot = rot @ motion[1]
            if counted:
                height = float(pos[2])
                lowest = min(lowest, height)
        return pos, rot, lowest

    def lowest(self, q_deg) -> float:
        """The height [m] of the lowest counted link frame at driven joint positions ``q_deg`` [deg]."""
        q = np.radians(np.asarray(q_deg, dtype=float))
        return self._walk(q, 0, len(self.joints), self.base, self.base_rot, math.inf)[2]

    def highest_choice(self, q_deg: list[float], i: int, options: list[float]) -> float:
        """Of ``options`` [deg] for driven joint ``i`` (the others at ``q_deg``), the first that leaves the
        lowest counted link frame highest, as ``max(options, key=clearance)`` picks it."""
        k = self.chain_index.get(self.arm_joints[i])
        if k is None:  # off the chain: no option moves a counted frame, so all tie and the first is picked
            return options[0]
        q = np.radians(np.asarray(q_deg, dtype=float))
        pos, rot, lowest = self._walk(q, 0, k, self.base, self.base_rot, math.inf)  # the frames above it stay
        best, best_height = options[0], -math.inf
        for angle in options:
            q = np.radians(np.asarray([*q_deg[:i], angle, *q_deg[i + 1 :]], dtype=float))
            height = self._walk(q, k, len(self.joints), pos, rot, lowest)[2]
            if height > best_height:
                best, best_height = angle, height
        return best


def clearance(robot: RobotDescription, q_deg) -> float:
    """The height [m] of the lowest link frame that the driven joints can raise or lower (those below the second
    driven joint, up to the tracked link) at ``q_deg``."""
    return _ChainHeights(robot).lowest(q_deg)


def _start_pose(robot: RobotDescription) -> list[float]:
    """An MJCF's ``home`` keyframe (each joint kept inside its limits); else each joint at 0 moved inside its
    limits; where that leaves the arm within ``START_CLEARANCE_M`` of the floor (a UR lies stretched out at its
    zeros), each joint in turn (the first ``START_SEARCH_JOINTS``) set to the angle of ``START_CANDIDATES_DEG``
    that lifts the arm's lowest frame highest."""
    rooms = [_room(robot, name) for name in robot.arm_joints]
    home = None if robot.mjcf is None else home_pose(robot.mjcf, robot.arm_joints)
    if home is not None:
        return [min(max(math.degrees(q), low), high) for q, (low, high) in zip(home, rooms)]
    start = [min(max(0.0, low), high) for low, high in rooms]
    heights = _ChainHeights(robot)
    if heights.lowest(start) >= START_CLEARANCE_M:
        return start
    for _ in range(2):
        for i, (low, high) in enumerate(rooms[:START_SEARCH_JOINTS]):
            options = sorted({min(max(c, low), high) for c in START_CANDIDATES_DEG}, key=abs)
            start[i] = heights.highest_choice(start, i, options)
    return start


def reach_poses(robot: RobotDescription) -> tuple[list[float], list[float]]:
    """(start, target) of the example reach [deg]: the start pose of :func:`_start_pose`, then each joint
    turned by up to ``REACH_DEG`` towards its wider side; the turn halved while the tracked link, or a frame it
    carries (a gripper's fingertip frame), would come nearer the floor than ``CLEARANCE_M``."""
    start = _start_pose(robot)
    turn = []
    for name, angle in zip(robot.arm_joints, start):
        low, high = _room(robot, name)
        room_up, room_down = high - angle, angle - low
        turn.append(min(REACH_DEG, room_up) if room_up >= room_down else -min(REACH_DEG, room_down))
    heights = _ChainHeights(robot)
    # no frame the joints move may go lower on the way than the floor's clearance (or the start's, where the start
    # pose itself is lower): a long chain whose end stays clear may swing its middle links through the floor
    floor = min(CLEARANCE_M, heights.lowest(start))

    def clear(target: list[float]) -> bool:
        return (
            _lowest_carried(robot, np.radians(target)) >= CLEARANCE_M
            and _lowest_on_the_way(heights, start, target) >= floor - 1e-9
        )

    scale = 1.0
    for _ in range(4):
        target = [a + scale * t for a, t in zip(start, turn)]
        if clear(target):
            break
        scale /= 2
    else:
        # every joint turned at once still reaches the floor (a long chain): turn the joints nearest the tip one
        # by one, each kept where the way stays clear
        kept = list(start)
        for i in reversed(range(len(turn))[-START_SEARCH_JOINTS:]):
            trial = [*kept[:i], start[i] + turn[i], *kept[i + 1 :]]
            if clear(trial):
                kept = trial
        if kept != start:
            target = kept
    rooms = [_room(robot, name) for name in robot.arm_joints]
    return _deg(start, rooms), _deg(target, rooms)


#: How many poses of the way from the reach's start to its target are checked against the floor.
WAY_POSES = 8


def _lowest_on_the_way(heights: _ChainHeights, start: list[float], target: list[float]) -> float:
    """The height [m] of the lowest moving link frame on the way from ``start`` to ``target`` [deg]: the joints
    turned as the velocity clamp turns them, each at the same speed until it reaches its target."""
    turns = [b - a for a, b in zip(start, target)]
    largest = max((abs(t) for t in turns), default=0.0)
    if largest == 0.0:
        return heights.lowest(start)
    lowest = math.inf
    for k in range(1, WAY_POSES + 1):
        moved = largest * k / WAY_POSES
        pose = [a + math.copysign(min(abs(t), moved), t) for a, t in zip(start, turns)]
        lowest = min(lowest, heights.lowest(pose))
    return lowest


def _lowest_carried(robot: RobotDescription, q: np.ndarray) -> float:
    """The height [m] of the lowest of the tracked link's frame and the frames of the links below it, at driven joint
    positions ``q`` [rad].  The tracked link's origin alone let the SO-101's reach press its fingertip frame, 9 cm
    beyond the origin, 1 cm into the floor from 0.6 s to 4 s: contact each engine resolves its own way (DART 9 mm
    from MuJoCo)."""
    carried = {robot.tracked_link}
    for joint in robot.joints:  # parents before children
        if joint.parent in carried:
            carried.add(joint.child)
    return min(float(robot.forward_kinematics(q, link)[0][2]) for link in carried)


def project_text(
    robot: RobotDescription, urdf: Path, package_path: Sequence[str | Path] = (), tasks: Sequence[str] = ("reach",)
) -> str:
    """The commented ``simtune.toml`` of a new project.

    Args:
        robot: the robot as loaded from ``urdf``.
        urdf: the robot's file (a URDF, or an MJCF when ``robot.mjcf`` is set), named in place.
        package_path: folders for a URDF's ``package://`` names.
        tasks: the names of the task files in ``tasks/`` it lists.

    Returns:
        The file's text.
    """
    gripper = [link.name for link in robot.links if link.material == "gripper"]
    mjcf = robot.mjcf is not None
    lines = [
        f"# A simtune project for the robot of {urdf.name} (schema: docs/task-files.md).",
        "# Check it with `simtune check <this folder>`; list its parameters with `simtune params --project <folder>`.",
        f"name = {_toml(robot.name)}",
        f'description = "{robot.name}, from {urdf.name}"',
        "# task files, relative to this folder; add one per motion you recorded",
        f"tasks = {_toml([f'tasks/{name}.toml' for name in tasks])}",
        "# the data root: recordings/<task name>/ holds each task's recordings (motion capture: "
        f"{recording_kinds('markers')};",
        f"# joint logs: {recording_kinds('joints')}).",
        "# Without recordings yet: `simtune synth --project <folder> ...`",
        'data = "recordings"',
        "",
        "[robot]",
        *(
            [
                "# the robot's MJCF, used in place: relative to this folder, or absolute (MuJoCo resolves its includes",
                "# and meshdir); MuJoCo builds the robot from it, the other engines from a URDF of its collision geoms",
                f"mjcf = {_toml(str(urdf))}",
            ]
            if mjcf
            else [
                "# the robot's URDF, used in place: relative to this folder, or absolute (meshes are found beside it)",
                f"urdf = {_toml(str(urdf))}",
            ]
        ),
        "# the joints the controller drives, in the order of every target list of the task files",
        f"joints = {_toml(list(robot.arm_joints))}",
        "# the link whose origin the motion capture's wrist body follows (the engines report its pose)",
        f"tracked_link = {_toml(robot.tracked_link)}",
        "# where the robot's root link stands [m] and how it is turned [rad]; the floor is the plane z = 0",
        "# (added to the file's own placement of its base: a URDF's fixed joint from a link named `world`, or the",
        "# pos and quat of an MJCF's root body)",
        "base_position = [0.0, 0.0, 0.0]",
        "base_rpy = [0.0, 0.0, 0.0]",
        "# links with the gripper's contact parameters (friction, restitution ...); the other links are 'arm'",
        f"gripper_links = {_toml(gripper)}",
        "# the gain of MuJoCo's and Drake's joint velocity servos [N m s/rad]; such a servo lags its command by about",
        "# the joint's inertia over the gain (default: MuJoCo 50, Drake 100, set for the MICO's light links):",
        "# a heavier arm follows its commands as a real velocity loop does with a stiffer one (the Panda: 300)",
        "# servo_gain = 300.0",
    ]
    if package_path:
        lines += [
            "# folders where the URDF's package:// names are found (a package folder, or a folder of packages)",
            f"package_path = {_toml([str(p) for p in package_path])}",
        ]
    if robot.held and mjcf:
        lines += [
            "# the MJCF's joints that are not driven (a gripper's fingers) are welded at 0: "
            + ", ".join(name for name, _ in robot.held)
        ]
    elif robot.held:
        lines += [
            "",
            "# movable joints that are not driven (a gripper's fingers), held at these positions [rad or m]",
            "[robot.held]",
            *(f"{_toml(name)} = {_toml(position)}" for name, position in robot.held),
        ]
    return "\n".join(lines) + "\n"


def reach_text(robot: RobotDescription) -> str:
    start, target = reach_poses(robot)
    return "\n".join(
        [
            "# The example task: every driven joint turns a little and back, no object (schema: docs/task-files.md).",
            "# Replace the schedule with what your robot was commanded while you recorded it.",
            'name = "reach"',
            'description = "every driven joint turns and back (no contact)"',
            "duration = 8.0  # [s] simulated and compared with the recordings",
            f"joints = {_toml(list(robot.arm_joints))}",
            f"start_pose_deg = {_toml(start)}",
            "",
            "[controller]",
            'law = "clamped-p-velocity"  # at 20 Hz: joint velocity = clamp(gain * (target - angle), +-max)',
            "gain = 10.0  # [1/s]",
            "max_velocity_deg = 30.0  # [deg/s]",
            "",
            "[mocap]",
            f"link = {_toml(robot.tracked_link)}  # the link the wrist marker sits on",
            'body = "hand"  # the marker\'s rigid-body name in the recordings',
            "# base_body = \"base\"  # optional: the body on the robot's base, for the recordings' checks",
            "",
            "# an object for the hand to push (then name it in the recordings as mocap_body):",
            "# [object]",
            '# shape = "cube"  # cube, cuboid, cylinder or cone',
            '# material = "plastic"  # contact group: plastic or wood',
            "# mass = 0.1  # [kg]",
            "# size = [0.06, 0.06, 0.06]  # [m]",
            "# xy = [0.5, 0.0]  # [m] where it rests on the floor",
            '# mocap_body = "box"',
            "",
            "[[phases]]",
            "start = 0.0  # [s]",
            f"targets_deg = {_toml(target)}",
            "",
            "[[phases]]",
            "start = 4.0",
            f"targets_deg = {_toml(start)}",
            "",
        ]
    )


#: what ``init`` writes into a project's ``.gitignore``: the folders the README's and docs' commands write their
#: output to inside a project (runs, reports, exported models), so that a project kept in git shows its own files
GITIGNORE = """# simtune's output folders: tune --out runs/..., report --out report, export --out exported/...
runs/
report/
exported/
"""


def init_project(
    urdf: Path | str,
    out: Path | str,
    *,
    tracked_link: str | None = None,
    driven_joints: list[str] | None = None,
    package_path: Sequence[str | Path] = (),
    loaded: list[RobotDescription] | None = None,
    density: float | None = None,
    total_mass: float | None = None,
    dataset: Path | str | None = None,
    made: list | None = None,
) -> Path:
    """Write a project for the robot of ``urdf`` (a URDF or an MJCF file) into the new (or empty) folder ``out``.

    Args:
        urdf: the robot file, named in place by the project (never copied); an MJCF is told by its root element.
        out: the new project folder (absent, or empty).
        tracked_link: overrides the loader's choice of the tracked link.
        driven_joints: override the loader's choice of the driven joints.
        package_path: folders for a URDF's ``package://`` names, or ``NAME=DIR`` (package NAME is folder DIR)
            (written into the project).
        loaded: a list that receives the robot as loaded (its :attr:`~RobotDescription.choices` say what was
            chosen and why).
        density: [kg/m^3] of the links without an ``<inertial>``, whose masses come from their geometry
            (default aluminium's); written into the project where a link is so estimated.
        total_mass: [kg] spread over those links by volume instead (not with ``density``).
        dataset: a LeRobot dataset folder: the project's task is then every episode of it, each its own task
            (:func:`simtune.tasks.dataset_task.dataset_task`: joints mapped by name, the unit checked), instead of
            the example ``reach``.
        made: a list that receives the dataset's :class:`~simtune.tasks.dataset_task.DatasetTask`.

    Returns:
        The project file.

    Raises:
        ProjectError: if ``out`` holds anything; RobotError: if the robot file cannot be used (one line each;
            then nothing is written).
    """
    urdf = Path(urdf).expanduser().resolve()
    out = Path(out).expanduser().absolute()
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise ProjectError(f"{out}: exists and is not an empty folder: choose a new --out (nothing was written)")
    _check_driven_joints(driven_joints)
    package_path = tuple(_package_entry(p) for p in package_path)
    if package_path and robot_format(urdf) == "mjcf":
        # refused, not dropped: a user who gives the option means the robot's meshes to be found through it
        raise ProjectError(
            f"--package-path: {urdf} is an MJCF, whose meshes MuJoCo finds (its compiler's meshdir): package "
            "folders are for a URDF's package:// names; leave the option out (nothing was written)"
        )
    _check_mass_options(density, total_mass)
    robot = load_robot(
        urdf,
        tracked_link=tracked_link,
        arm_joints=driven_joints,
        package_path=package_path,
        density=density,
        total_mass=total_mass,
    )
    if loaded is not None:
        loaded.append(robot)
    parent = out.resolve().parent
    if not parent.is_dir():
        raise ProjectError(f"{out}: its folder {parent} does not exist")
    if dataset is None:
        tasks = {"reach": reach_text(robot)}
    else:
        from simtune.tasks.dataset_task import dataset_task

        found = dataset_task(robot, Path(dataset), out.resolve() / "tasks", out.resolve())
        if made is not None:
            made.append(found)
        tasks = {found.name: found.text}
    texts = {
        "simtune.toml": _with_mass_keys(
            project_text(robot, urdf, package_path, list(tasks)), robot, density, total_mass
        ),
        **{f"tasks/{name}.toml": text for name, text in tasks.items()},
        ".gitignore": GITIGNORE,
    }
    where = out if out.is_dir() else parent
    if not os.access(where, os.W_OK | os.X_OK):  # one line, not a traceback from a temporary folder's mkdir
        raise ProjectError(f"{out}: cannot write the project there ({where} is not writable): choose another --out")
    if out.is_dir():  # empty: written in place (it may be the working folder, which cannot be replaced)
        try:
            _write_project(out, texts, remove_on_error=False)
        except OSError as exc:
            raise ProjectError(f"{out}: cannot write the project there ({exc.strerror or exc})") from None
        return out / "simtune.toml"
    try:
        staging = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=parent))
    except OSError as exc:
        raise ProjectError(f"{out}: cannot write the project there ({exc.strerror or exc})") from None
    try:
        umask = os.umask(0)
        os.umask(umask)
        staging.chmod(0o777 & ~umask)  # mkdtemp's folder is private; a project folder is an ordinary one
        _write_project(staging, texts, remove_on_error=True)
        os.replace(staging, out)  # a new folder appears whole
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return out / "simtune.toml"


def _package_entry(entry: str | Path) -> str:
    """A ``--package-path`` entry as the project writes it: its folder absolute; ``NAME=DIR``'s folder must exist."""
    name, folder = package_entry(entry)
    folder = folder.resolve()
    if name is None:
        return str(folder)
    if not folder.is_dir():
        raise ProjectError(f"--package-path {entry}: no folder {folder} for package {name!r}")
    return f"{name}={folder}"


def _check_driven_joints(driven_joints: Sequence[str] | None) -> None:
    """One line for ``--driven-joints`` naming a joint twice (the task file written would refuse it, naming init's
    temporary folder)."""
    if not isinstance(driven_joints, list | tuple):
        return  # none given (or not a list of names, which the loader names)
    given = ",".join(map(str, driven_joints))
    twice = sorted({name for name in driven_joints if driven_joints.count(name) > 1}, key=driven_joints.index)
    if twice:
        raise ProjectError(
            f"--driven-joints {given}: joint {', '.join(map(repr, twice))} named twice (each driven joint once; "
            "nothing was written)"
        )


def _check_mass_options(density: float | None, total_mass: float | None) -> None:
    """One line for ``--density`` and ``--total-mass`` together, or either not above 0."""
    if density is not None and total_mass is not None:
        raise ProjectError("--density and --total-mass: give one (a total mass sets the density)")
    for option, value, unit in (("--density", density, "kg/m^3"), ("--total-mass", total_mass, "kg")):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise ProjectError(f"{option} {value:g}: not possible (a {unit} value above 0)")


def _with_mass_keys(text: str, robot: RobotDescription, density: float | None, total_mass: float | None) -> str:
    """The project file ``text`` with the ``[robot]`` keys that make the project load the robot's estimated
    masses as init did, after its ``gripper_links`` (``text`` as it is where the URDF gives every mass and no
    option was given)."""
    if not robot.estimated_masses and density is None and total_mass is None:
        return text
    listed = ", ".join(robot.estimated_masses) or "none"
    lines = [
        f"# links without an <inertial>: {listed}",
        "# their mass and inertia: their collision (else visual) geometry taken as",
    ]
    if total_mass is not None:
        lines += ["# solids sharing this mass [kg] by volume (or density = [kg/m^3] instead)"]
        lines += [f"total_mass = {_toml(float(total_mass))}"]
    else:
        lines += ["# solids of this density [kg/m^3] (2700: aluminium; or total_mass = [kg] shared by volume)"]
        lines += [f"density = {_toml(float(DEFAULT_DENSITY if density is None else density))}"]
    before, key, after = text.partition("\ngripper_links = ")
    line, _, rest = after.partition("\n")
    return before + key + line + "\n" + "\n".join(lines) + "\n" + rest


def _write_project(folder: Path, texts: dict[str, str], remove_on_error: bool) -> None:
    """Write ``texts`` (relative path -> text) into ``folder`` and load the project as written; on an error,
    the files written here are removed again (and ``folder`` itself when ``remove_on_error``)."""
    written: list[Path] = []
    try:
        (folder / "tasks").mkdir(exist_ok=True)
        for name, text in texts.items():
            (folder / name).write_text(text, encoding="utf-8")
            written.append(folder / name)
        # what init writes must load as written: the same robot file with the same options, whose warnings the
        # first load gave (loading it twice printed each of them twice)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RobotWarning)
            load_project(folder)
    except BaseException:
        if not remove_on_error:
            for file in written:
                file.unlink(missing_ok=True)
            with contextlib.suppress(OSError):  # its own clean-up never hides the cause
                (folder / "tasks").rmdir()
        raise
