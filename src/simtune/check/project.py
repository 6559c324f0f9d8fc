"""``simtune check DIR``: what a project still lacks before any tuning, one line per finding.

Problems stop a project from being tuned (it does not load, a recording lacks a named body or
joint); warnings are worth a look but do not (no recordings yet, the tracked link's start
position far from the first recorded marker position, an engine that cannot load the robot);
notes say what was found.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import time
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from simtune.common.spawn_guard import adopt_environment, check_main_guarded, sigint_blocked, worker_context
from simtune.data import TaskData
from simtune.data.ingest import data_check_entry
from simtune.engines import ENGINES, engine_class
from simtune.errors import EngineUnavailable, SimtuneError
from simtune.fitness import reference_floor
from simtune.objective import load_task_recordings, recordings_folder
from simtune.project import Project, load_project
from simtune.robot.generate import servo_shortfalls

#: A start position of the tracked link farther than this from the first recorded marker position
#: is worth a warning [m]: a wrong base pose, tracked link, start pose or unit.
START_DISTANCE_WARNING_M = 0.05
#: The same for the first logged joint angle against the task's start pose [deg].
START_ANGLE_WARNING_DEG = 5.0
LEVELS = ("problem", "warning", "note")


@dataclass(frozen=True)
class Finding:
    level: str  # one of LEVELS
    message: str
    #: what ``simtune check DIR --json`` adds to the line: a named data check's parts
    #: (:func:`simtune.data.ingest.data_check_entry`, ``data_check``), a task's ``floor_fitness`` (None: one repeat)
    fields: dict | None = field(default=None, compare=False)

    def __str__(self) -> str:
        return f"{self.level}: {self.message}"


def check_project(
    path: Path | str, engines: tuple[str, ...] | None = None, data: Path | str | None = None
) -> list[Finding]:
    """Everything ``simtune check`` reports on the project in ``path``: problems, warnings and notes.

    Args:
        path: the project folder or file.
        engines: the engines to load the robot in (default: every engine simtune knows).
        data: a data root (``DATA/<task>/``) to check the recordings in instead of the project's own (``--data``).
    Returns:
        The findings, each a problem, a warning or a note.
    """
    try:
        project = load_project(path)
    except SimtuneError as exc:
        return [Finding("problem", str(exc))]
    robot = next(iter(project.tasks.values())).robot
    findings = [
        Finding(
            "note",
            f"{project.file}: robot {robot.name} ({robot.source}): {len(robot.links)} links, driven joints "
            f"{', '.join(robot.arm_joints)}, tracked link {robot.tracked_link}",
        )
    ]
    findings += _check_masses(robot)
    root = None if data is None else Path(data)
    if root is None:
        # what validate() lists (recordings folders missing) does not stop a project: recordings come later
        findings += [Finding("warning", f"{lack} (no recordings yet)") for lack in project.validate()]
    elif not root.is_dir():
        findings.append(Finding("problem", f"--data {root}: no such folder"))
        root = None
    for name in project.tasks:
        if root is not None and not (root / name).is_dir():
            findings.append(Finding("warning", f"--data {root}: no folder {name}/ of task {name!r}'s recordings"))
            continue
        findings += _check_recordings(project, name, root)
    findings += _check_engines(project, engines or tuple(ENGINES))
    return findings


def findings_json(findings: list[Finding]) -> dict:
    """``simtune check DIR --json``: the findings, each with its level, message and fields, and what they say per
    task.

    Args:
        findings: :func:`check_project`'s.
    Returns:
        ``findings`` (each ``level``, ``message`` and its fields), ``problems`` (how many), ``data_checks`` (each
        warning of a named data check: its ``task``, ``check``, ``source``, ``episode``, ``channel`` and
        ``message``) and ``floors`` (per task with recordings: its ``repeats`` and ``floor_fitness``, None where one
        repeat gives no floor).
    """
    fields = [f.fields or {} for f in findings]
    return {
        "findings": [{"level": f.level, "message": f.message, **x} for f, x in zip(findings, fields)],
        "problems": sum(f.level == "problem" for f in findings),
        "data_checks": [{"task": x["task"], **x["data_check"]} for x in fields if "data_check" in x],
        "floors": {
            x["task"]: {"repeats": x["repeats"], "floor_fitness": x["floor_fitness"]} for x in fields if "repeats" in x
        },
    }


def _check_masses(robot) -> list[Finding]:
    """What the robot's file does not give of its masses: links estimated from their geometry (a note), links
    with a placeholder (a warning; a problem where no moving link has a mass of its own)."""
    findings = []
    if robot.estimated_masses:
        total = sum(robot.link_by_name[n].mass for n in robot.estimated_masses)
        findings.append(
            Finding(
                "note",
                f"robot {robot.name}: masses of link {', '.join(robot.estimated_masses)} estimated from their geometry "
                f"(no <inertial>; {total:.3g} kg together); a driven link's mass_link_<n> is tuned over [0.25, 2] x "
                "its estimate",
            )
        )
    if robot.placeholder_masses:
        placeholders = set(robot.placeholder_masses)
        moving = [link for link in robot.links if any(j.moves for j in robot.chain(link.name))]
        real = [link.name for link in moving if link.mass > 0 and link.name not in placeholders]
        findings.append(
            Finding(
                "warning" if real else "problem",
                f"robot {robot.name}: the robot cannot be simulated as described: link "
                f"{', '.join(robot.placeholder_masses)} moves with no mass and no geometry to estimate one from (a "
                f"placeholder of {robot.link_by_name[robot.placeholder_masses[0]].mass:g} kg); add an <inertial> "
                f"or a <collision> to it in {robot.source}",
            )
        )
    return findings


def _check_recordings(project: Project, name: str, root: Path | None = None) -> list[Finding]:
    """The task's recordings (under ``root``, else the project's) hold its bodies or joints; the tracked link at the
    start pose against the first recorded marker position."""
    task = project.tasks[name]
    try:
        folder = recordings_folder(root, task)
    except SimtuneError:
        return []  # validate() said so
    if not folder.is_dir():
        return []
    where = project.task_files[name]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            data = load_task_recordings(folder, task, reference="aligned")
        except SimtuneError as exc:
            return [Finding("problem", f"{where}: recordings: {exc}")]
    findings = [
        Finding("warning", f"{where}: recordings: {w.message}", _check_fields(name, str(w.message))) for w in caught
    ]
    holds = []
    if data.wrist_repeats is not None:
        holds.append(f"marker body {task.wrist_body!r}")
    if data.object_final is not None and task.object is not None:
        holds.append(f"object {task.object.mocap_body!r}")
    if data.joint_names:
        holds.append(f"{len(data.joint_names)} joint angles")
    findings.append(Finding("note", f"task {name}: {len(data.sources)} recordings in {folder} ({', '.join(holds)})"))
    floor = reference_floor(data).floor
    findings.append(
        Finding("note", _floor_line(name, data), {"task": name, "repeats": len(data.sources), "floor_fitness": floor})
    )
    if data.wrist_repeats is not None:
        start, _ = task.robot.forward_kinematics(np.radians(task.start_pose_deg))
        first = data.wrist_repeats[0, 0]
        distance = float(np.linalg.norm(first - start))
        line = (
            f"task {name}: at the start pose the tracked link {task.tracked_link} is {distance * 100:.1f} cm from "
            f"the first recorded position of {task.wrist_body!r} ({_xyz(start)} vs {_xyz(first)} m)"
        )
        if distance > START_DISTANCE_WARNING_M:
            line += f": more than {START_DISTANCE_WARNING_M * 100:g} cm (base pose, tracked link, start pose, units?)"
            findings.append(Finding("warning", f"{where}: {line}"))
        else:
            findings.append(Finding("note", line))
    if data.joint_repeats is not None and data.joint_names:
        # joint logs: the first logged angles against the start pose (the joints the logs and the task share)
        start_by_joint = dict(zip(task.joints, np.radians(task.start_pose_deg)))
        first = dict(zip(data.joint_names, data.joint_repeats[0, 0]))
        shared = [j for j in data.joint_names if j in start_by_joint]
        if shared:
            worst = max(shared, key=lambda j: abs(first[j] - start_by_joint[j]))
            degrees = float(np.degrees(abs(first[worst] - start_by_joint[worst])))
            line = f"task {name}: the first logged joint angles are within {degrees:.2f} deg of the start pose"
            if degrees > START_ANGLE_WARNING_DEG:
                findings.append(Finding("warning", f"{where}: {line} ({worst}: more than {START_ANGLE_WARNING_DEG:g})"))
            else:
                findings.append(Finding("note", line))
    return findings


def _check_fields(task: str, message: str) -> dict | None:
    """A recording warning's fields for the JSON: its task and, where a named check raised it, that check's parts."""
    entry = data_check_entry(message)
    return {"task": task} if entry is None else {"task": task, "data_check": entry}


def _floor_line(name: str, data: TaskData) -> str:
    """The repeats' spread with and without their clocks aligned, their shifts and the floor of the fitness."""
    floor = reference_floor(data)
    spread = ""
    if floor.spread_unaligned_m is not None and floor.spread_aligned_m is not None:
        spread = (
            f"wrist spread {floor.spread_unaligned_m * 1000:.1f} mm as recorded, "
            f"{floor.spread_aligned_m * 1000:.1f} mm with the clocks aligned; "
        )
    shifts = f"clock shifts {floor.shift_min_s:+.3f} to {floor.shift_max_s:+.3f} s"
    return f"task {name}: {spread}{shifts}; {floor_words(floor.floor)}"


def floor_words(floor: float | None) -> str:
    """The floor of a fitness in words: its value, or why there is none (one repeat: nothing to compare it with)."""
    if floor is None:
        return (
            "no floor: one repeat, which scores 0 against itself (record two or more to know what a tuned "
            "simulation compares with)"
        )
    return f"floor (the aligned mean scored against each repeat, what a tuned simulation compares with) {floor:.4f}"


def _xyz(v) -> str:
    return "(" + ", ".join(f"{float(x):.3f}" for x in v) + ")"


@contextlib.contextmanager
def _engine_chatter_silenced() -> Iterator[None]:
    """The engines' own C++ loaders print to the process's stdout and stderr (DART one line per mesh
    material file it looks for): while they load, both go to /dev/null, so the check's lines stay readable."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    try:
        with open(os.devnull, "w") as devnull:
            os.dup2(devnull.fileno(), 1)
            os.dup2(devnull.fileno(), 2)
            yield
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in saved:
            os.close(fd)


#: How long [s] one engine may take to load the robot in its child process before it counts as hung.
ENGINE_LOAD_TIMEOUT_S = 300.0


def _load_robot(name: str, task) -> tuple[str, object]:
    """Load ``task``'s robot in engine ``name``, the engines' own chatter silenced: ``("loaded", the tracked link's
    position)``, ``("unavailable", why)`` or ``("failed", the first line of the error)``."""
    try:
        with _engine_chatter_silenced():  # importing pybullet prints its build time
            cls = engine_class(name)
    except EngineUnavailable as exc:
        return "unavailable", str(exc)
    try:
        with _engine_chatter_silenced():
            sim = cls(task)
            try:
                sim.reset({})
                got, _ = sim.wrist_pose()
            finally:
                sim.close()
    except Exception as exc:  # an engine failing on a robot is a finding, not the end of the check
        return "failed", str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return "loaded", tuple(float(v) for v in got)


def _load_robot_child(name: str, task, environ: dict[str, str], conn) -> None:
    """A child process's :func:`_load_robot`, its answer sent through ``conn``."""
    adopt_environment(environ)
    conn.send(_load_robot(name, task))
    conn.close()


def _died(exitcode: int | None) -> str:
    """How a child that sent no answer ended: ``crashed (signal 11, SIGSEGV)`` or ``exited with status 3``."""
    if exitcode is not None and exitcode < 0:
        try:
            named = f", {signal.Signals(-exitcode).name}"
        except ValueError:
            named = ""
        return f"crashed (signal {-exitcode}{named})"
    return f"exited with status {exitcode} without an answer"


def _load_robot_isolated(engines: tuple[str, ...], task, timeout_s: float) -> dict[str, tuple[str, object]]:
    """:func:`_load_robot` for each engine in a child process of its own, all at once: an engine that crashes
    the process (a native abort or segfault) or hangs is ``("failed", "crashed (signal 6, SIGABRT)")`` or
    ``("failed", "did not load within ... s")``, and the other engines are still reported.  Where a script's
    ``__main__`` is not guarded (a child would run it again), each loads in this process as before."""
    try:
        check_main_guarded("loading the robot in each engine")
    except SimtuneError:
        return {name: _load_robot(name, task) for name in engines}
    context = worker_context()
    children = {}
    with sigint_blocked():
        for name in engines:
            receive, send = context.Pipe(duplex=False)
            child = context.Process(  # type: ignore[attr-defined]
                target=_load_robot_child, args=(name, task, dict(os.environ), send), daemon=True
            )
            child.start()
            send.close()
            children[name] = (child, receive)
    results: dict[str, tuple[str, object]] = {}
    deadline = time.monotonic() + timeout_s
    for name, (child, receive) in children.items():
        answer = None
        if receive.poll(max(deadline - time.monotonic(), 0.0)):
            try:
                answer = receive.recv()
            except EOFError:  # the child died before it answered
                pass
        child.join(1.0 if answer is not None else 5.0)
        if child.is_alive():
            child.kill()
            child.join()
            answer = answer or ("failed", f"did not load within {timeout_s:g} s (killed)")
        results[name] = answer or ("failed", _died(child.exitcode))
        receive.close()
    return results


def _check_engines(project: Project, engines: tuple[str, ...]) -> list[Finding]:
    """Which engines build the robot (each in a child process of its own: :func:`_load_robot_isolated`): each
    one's tracked link at the first task's start pose, against the robot's own forward kinematics."""
    task = next(iter(project.tasks.values()))
    want, _ = task.robot.forward_kinematics(np.radians(task.start_pose_deg))
    loaded, findings = [], []
    for name, (outcome, value) in _load_robot_isolated(engines, task, ENGINE_LOAD_TIMEOUT_S).items():
        if outcome == "unavailable":
            findings.append(Finding("note", str(value)))
            continue
        if outcome == "failed":
            findings.append(Finding("warning", f"engine {name} cannot load robot {task.robot.name}: {value}"))
            continue
        error = float(np.linalg.norm(np.asarray(value) - want))
        if error > 1e-4:
            findings.append(
                Finding(
                    "warning",
                    f"engine {name}: the tracked link is {error * 1000:.2f} mm from the robot's own kinematics",
                )
            )
        loaded.append(name)
    findings.append(Finding("note", f"engines that load the robot: {', '.join(loaded) or 'none'}"))
    findings += _floor_findings(project, loaded)
    findings += _servo_findings(task.robot, loaded)
    findings += _bullet_damping_findings(task.robot, loaded)
    if task.robot.mjcf is not None:
        findings.append(Finding("note", _mjcf_engines_line(task.robot.mjcf, loaded)))
    return findings


#: the engine whose generic simulation the project check runs for floor touches (the default engine)
FLOOR_ENGINE = "mujoco"


def _floor_findings(project: Project, loaded: list[str]) -> list[Finding]:
    """A warning per task without an object whose generic simulation in :data:`FLOOR_ENGINE` lays the arm on the
    floor (an example reach of a long chain, a sagging arm): such a task is tuned as if it never touched it."""
    from simtune.engines.contact import FLOOR_TOUCH_CONSEQUENCE, generic_floor_touches, touch_spans_text

    if FLOOR_ENGINE not in loaded:
        return []
    findings = []
    for name, task in project.tasks.items():
        if task.object is not None:  # none asked (generic_floor_touches): no engine loaded for it
            continue
        try:
            with _engine_chatter_silenced():
                sim = engine_class(FLOOR_ENGINE)(task)
                try:
                    spans = generic_floor_touches(sim)
                finally:
                    sim.close()
        except Exception as exc:  # the engine's load was checked above; a task it cannot run is the task check's
            findings.append(Finding("note", f"task {name}: floor contact not checked ({exc})"))
            continue
        if spans is None:
            findings.append(Finding("note", f"task {name}: floor contact not checked ({FLOOR_ENGINE} cannot tell)"))
        elif spans:
            findings.append(
                Finding(
                    "warning",
                    f"task {name}: the generic {FLOOR_ENGINE} simulation's arm touches the floor "
                    f"({touch_spans_text(spans, most=3)}): {FLOOR_TOUCH_CONSEQUENCE}",
                )
            )
    return findings


def _servo_findings(robot, loaded: list[str]) -> list[Finding]:
    """A warning per hard-motor engine that loads ``robot`` where a joint's damping or friction holds MuJoCo's
    servo below its command (:func:`simtune.robot.generate.servo_shortfalls`): their motion differs."""
    held = servo_shortfalls(robot)
    if not held or "mujoco" not in loaded:
        return []
    causes = "; ".join(f"{joint}: {why}" for joint, why in held.items())
    return [
        Finding(
            "warning",
            f"engine {name} and mujoco may disagree on robot {robot.name}: {name}'s hard motors hold the commanded "
            f"speed where MuJoCo's velocity servo, limited by the joint's force limit, is held back ({causes}); "
            "docs/robots.md, 'The engines agree'",
        )
        for name in loaded
        if name in ENGINES and ENGINES[name].hard_motor  # a velocity constraint up to the force limit, not a gain
    ]


#: Above this share of a joint's force limit, the torque Bullet's own link damping opposes the joint with at the
#: fastest command (:func:`simtune.engines.pybullet.mapping.link_damping_torques`) holds PyBullet's arm back where no
#: other engine's is: measured, the ABB IRB 140 (105 % on joint_1) and KUKA KR 210 L150 (73 %) were 108 and 151 mm
#: from MuJoCo in PyBullet alone; every other corpus arm stays under 4 % (the MICO 0.02 %).  Only a robot loaded as
#: the paper did has that damping (``--loading paper``, ``--paper-exact``): loaded as its description says (the
#: default), its links have none and both arms agree within 5 mm.
BULLET_DAMPING_SHARE = 0.1


def _bullet_damping_findings(robot, loaded: list[str]) -> list[Finding]:
    """One note where PyBullet loads ``robot`` and Bullet's link damping, loaded as the paper did, takes more than
    :data:`BULLET_DAMPING_SHARE` of a joint's force limit: a heavy arm's paper-exact PyBullet motion lags the other
    engines' (loaded as its description says, the default, it has no such damping)."""
    from simtune.engines.pybullet.mapping import BULLET_LINK_DAMPING, link_damping_torques
    from simtune.robot.generate import FASTEST_COMMAND

    if "pybullet" not in loaded:
        return []
    torques = link_damping_torques(robot, FASTEST_COMMAND)
    shares = [(torques[i] / robot.generic_effort(i), i) for i in range(robot.n_joints)]
    share, index = max(shares)
    if share <= BULLET_DAMPING_SHARE:
        return []
    return [
        Finding(
            "note",
            f"with --paper-exact (--loading paper) engine pybullet and mujoco may disagree on robot {robot.name}: "
            f"loaded as the paper did, Bullet damps every link by {BULLET_LINK_DAMPING:g} of its momentum (linear "
            f"and quadratic in speed; no other engine does), {torques[index]:.3g} N m on {robot.arm_joints[index]} "
            f"at {np.degrees(FASTEST_COMMAND):.0f} deg/s, {100 * share:.0f} % of its force limit, and takes link "
            "inertias from the collision shapes; docs/robots.md, 'The engines agree'",
        )
    ]


def _mjcf_engines_line(mjcf: str, loaded: list[str]) -> str:
    """How each engine that loaded a robot from an MJCF built it: MuJoCo from the file, the others from a URDF."""
    from_urdf = [name for name in loaded if not engine_class(name).reads_mjcf]
    from_file = [name for name in loaded if engine_class(name).reads_mjcf]
    line = f"robot from the MJCF {Path(mjcf).name}: built from the file in {', '.join(from_file) or 'no engine'}"
    if from_urdf:
        line += (
            f"; from the URDF of its collision geoms and inertias in {', '.join(from_urdf)} (without the file's "
            "armature, joint friction and springs: their motion may differ from MuJoCo's)"
        )
    return line
