"""Issue "probe 4's defects", items 3-5: URDFs that ``simtune init`` accepted and an engine then killed the
process on (PyBullet's segfault on a joint name used twice or empty, ODE's abort on a negative box side, Drake's
on a negative velocity limit or a zero box side), link graphs that are not trees (``init`` never returned), a
long chain (``init`` silent for minutes), and numbers that are not finite (a ``LinAlgError`` traceback).

Each now stops at load (``load_urdf``, so ``init``, ``check`` and every command that loads the project) with one
line naming the URDF, the link or joint and the field; ``simtune init`` says it and exits 2.  Cases that hung
run under a deadline, so a regression fails instead of hanging.
"""

from __future__ import annotations

import contextlib
import math
import signal
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as hs

from simtune.errors import RobotError, RobotWarning
from simtune.robot.urdf import load_urdf
from simtune.tasks.init_project import (
    START_CANDIDATES_DEG,
    START_CLEARANCE_M,
    START_SEARCH_JOINTS,
    _room,
    _start_pose,
    clearance,
    init_project,
)

pytest.importorskip("yourdfpy")

INERTIAL = '<inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>'
BOX = '<collision><geometry><box size="0.05 0.05 0.3"/></geometry></collision>'


def arm(
    *,
    shoulder: str = "shoulder",
    elbow: str = "elbow",
    upper: str = "upper",
    origin: str = '<origin xyz="0 0 0.3"/>',
    axis: str = "0 1 0",
    limit: str = 'lower="-1.5" upper="1.5" effort="50" velocity="1"',
    inertial: str = INERTIAL,
    geometry: str = '<box size="0.05 0.05 0.3"/>',
    extra: str = "",
    elbow_parent: str = "upper",
) -> str:
    """A two-joint arm on a base with one fault put in."""
    return f"""<robot name="arm">
  <link name="base">{INERTIAL}{BOX}</link>
  <link name={quoteattr(upper)}>{inertial}<collision><geometry>{geometry}</geometry></collision></link>
  <link name="fore">{INERTIAL}{BOX}</link>
  <joint name={quoteattr(shoulder)} type="revolute">
    <parent link="base"/><child link={quoteattr(upper)}/>{origin}<axis xyz="{axis}"/>
    <limit {limit}/>
  </joint>
  <joint name={quoteattr(elbow)} type="revolute">
    <parent link={quoteattr(elbow_parent)}/><child link="fore"/><origin xyz="0 0 0.3"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="1.5" effort="50" velocity="1"/>
  </joint>
  {extra}
</robot>
"""


def joint(name: str, parent: str, child: str) -> str:
    return (
        f'<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
        '<origin xyz="0 0 0.1"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="5" velocity="1"/></joint>'
    )


def link(name: str) -> str:
    return f'<link name="{name}">{INERTIAL}{BOX}</link>'


#: three links in a ring: each has one parent, so there is no root, and the loader walked it for ever
RING = f'<robot name="ring">{link("a")}{link("b")}{link("c")}{joint("ab", "a", "b")}{joint("bc", "b", "c")}' + (
    f"{joint('ca', 'c', 'a')}</robot>"
)

#: a joint from a link to itself: init walked it for ever
SELF_LOOP = arm(extra=joint("twist", "fore", "fore"))

# (id, URDF text, fragments the one line holds besides the file's path)
DEFECTS = [
    # item 3: PyBullet segfaulted (rc 139), ODE aborted (rc 134), Drake stopped at joint.h:435
    ("empty-joint-name", arm(shoulder=""), ["line 5", "<joint> has an empty name"]),
    ("duplicate-joint-name", arm(elbow="shoulder"), ["joint 'shoulder' is defined twice", "first on line 5"]),
    ("empty-link-name", arm(upper=""), ["line 3", "<link> has an empty name"]),
    ("negative-box-side", arm(geometry='<box size="0.1 -0.1 0.3"/>'), ["link 'upper' collision 1", "box size"]),
    ("zero-box-side", arm(geometry='<box size="0.1 0 0.3"/>'), ["link 'upper' collision 1", "box size", "> 0"]),
    ("zero-cylinder", arm(geometry='<cylinder radius="0.05" length="0"/>'), ["link 'upper'", "cylinder length 0"]),
    ("zero-sphere", arm(geometry='<sphere radius="0"/>'), ["link 'upper'", "sphere radius 0"]),
    (
        "negative-effort",
        arm(limit='lower="-1" upper="1" effort="-5" velocity="1"'),
        ["joint 'shoulder'", "limit effort -5 is negative"],
    ),
    (
        "negative-velocity",
        arm(limit='lower="-1" upper="1" effort="5" velocity="-1"'),
        ["joint 'shoulder'", "limit velocity -1 is negative"],
    ),
    (
        "negative-damping",
        arm().replace('<axis xyz="0 1 0"/>', '<axis xyz="0 1 0"/><dynamics damping="-1"/>', 1),
        ["joint 'shoulder'", "dynamics damping -1 is negative"],
    ),
    # item 4: links that do not form a tree (init never returned), a joint naming a link the file lacks
    (
        "two-parents",
        arm(extra=link("hand") + joint("wrist", "fore", "hand") + joint("strut", "base", "hand")),
        ["link 'hand' is the child of two joints, 'wrist' and 'strut'"],
    ),
    ("self-loop", SELF_LOOP, ["joint 'twist'", "link 'fore' is both its parent"]),
    (
        "loop-below-the-root",  # init walked it for ever
        arm(extra=link("hand") + joint("wrist", "fore", "hand") + joint("back", "hand", "fore")),
        ["link 'fore' is the child of two joints, 'elbow' and 'back'"],
    ),
    ("loop", RING, ["joints 'ab', 'bc', 'ca' form a loop ('a' -> 'b' -> 'c' -> 'a')"]),
    (
        "loop-beside-the-arm",
        arm(extra=link("p") + link("q") + joint("pq", "p", "q") + joint("qp", "q", "p")),
        ["'pq'", "'qp'", "form a loop"],
    ),
    ("duplicate-link-name", arm(extra=link("fore")), ["link 'fore' is defined twice"]),
    ("missing-link", arm(elbow_parent="nowhere"), ["joint 'elbow'", "parent link 'nowhere' is not a link"]),
    # item 5: numbers that are not finite (a LinAlgError traceback) or not numbers
    ("origin-xyz-inf", arm(origin='<origin xyz="0 0 inf"/>'), ["line 6", "joint 'shoulder'", "origin xyz '0 0 inf'"]),
    ("origin-xyz-nan", arm(origin='<origin xyz="0 nan 0.3"/>'), ["joint 'shoulder'", "origin xyz", "not finite"]),
    ("origin-rpy-nan", arm(origin='<origin rpy="nan 0 0"/>'), ["joint 'shoulder'", "origin rpy", "not finite"]),
    ("axis-nan", arm(axis="0 nan 0"), ["joint 'shoulder'", "axis xyz '0 nan 0' is not finite"]),
    ("limit-nan", arm(limit='lower="nan" upper="1" effort="5" velocity="1"'), ["joint 'shoulder'", "limit lower nan"]),
    ("effort-nan", arm(limit='lower="-1" upper="1" effort="nan" velocity="1"'), ["joint 'shoulder'", "effort nan"]),
    ("velocity-inf", arm(limit='lower="-1" upper="1" effort="5" velocity="inf"'), ["limit velocity inf is not finite"]),
    ("mass-nan", arm(inertial=INERTIAL.replace('value="1"', 'value="nan"')), ["link 'upper' inertial", "mass nan"]),
    ("inertia-nan", arm(inertial=INERTIAL.replace('iyy="0.01"', 'iyy="nan"')), ["link 'upper'", "inertia iyy nan"]),
    (
        "inertial-origin-inf",
        arm(inertial=INERTIAL.replace("<mass", '<origin xyz="inf 0 0"/><mass')),
        ["link 'upper' inertial", "origin xyz 'inf 0 0'"],
    ),
    ("box-size-nan", arm(geometry='<box size="0.1 nan 0.3"/>'), ["link 'upper' collision 1", "box size", "not finite"]),
    ("radius-inf", arm(geometry='<cylinder radius="inf" length="1"/>'), ["link 'upper' collision 1", "radius inf"]),
    (
        "mimic-nan",
        arm(
            extra=link("jaw")
            + joint("gripper", "fore", "jaw").replace("</joint>", "")
            + '<mimic joint="elbow" multiplier="nan"/></joint>'
        ),
        ["joint 'gripper'", "mimic multiplier nan"],
    ),
    ("two-numbers", arm(origin='<origin xyz="0 0.3"/>'), ["joint 'shoulder'", "origin xyz '0 0.3' is not 3 numbers"]),
    (
        "not-a-number",
        arm(limit='lower="-1" upper="one" effort="5" velocity="1"'),
        ["limit upper 'one' is not a number"],
    ),
]
IDS = [d[0] for d in DEFECTS]


@contextlib.contextmanager
def deadline(seconds: float):
    """Fail, not hang: SIGALRM interrupts whatever Python loop still runs after ``seconds`` (the loader walked a
    loop of links for ever)."""

    def expire(signum, frame):
        raise TimeoutError(f"still running after {seconds} s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def cli(*args: str, capsys) -> tuple[int, str]:
    """The CLI in this process, under a deadline: exit status and stderr."""
    from simtune.cli import main

    argv = sys.argv
    sys.argv = ["simtune", *map(str, args)]
    try:
        with deadline(20), pytest.raises(SystemExit) as info:
            main()
    finally:
        sys.argv = argv
    return int(info.value.code or 0), capsys.readouterr().err


def write(folder: Path, text: str, name: str = "arm.urdf") -> Path:
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize(("case", "text", "fragments"), DEFECTS, ids=IDS)
def test_each_defect_stops_load_urdf_with_one_line(tmp_path, case, text, fragments):
    urdf = write(tmp_path, text)
    with deadline(10), warnings.catch_warnings():
        warnings.simplefilter("error")  # no NumPy warning on the way either
        with pytest.raises(RobotError) as info:
            load_urdf(urdf)
    message = str(info.value)
    assert "\n" not in message and message.startswith(str(urdf)), message
    for fragment in fragments:
        assert fragment in message, message


@pytest.mark.parametrize(("case", "text", "fragments"), DEFECTS, ids=IDS)
def test_each_defect_stops_init_with_one_line_and_exit_2(tmp_path, capsys, case, text, fragments):
    urdf = write(tmp_path, text)
    code, err = cli("init", "--robot", urdf, "--out", tmp_path / "project", capsys=capsys)
    assert code == 2, err
    assert err.startswith("error: ") and err.count("\n") == 1 and "Traceback" not in err, err
    assert str(urdf) in err and all(f in err for f in fragments), err
    assert not (tmp_path / "project").exists()


def test_a_self_loop_stops_the_real_command_in_a_subprocess(tmp_path):
    """The command as a user runs it, in its own process with a time-out: a joint from a link to itself hung it."""
    urdf = write(tmp_path, SELF_LOOP)
    result = subprocess.run(
        [sys.executable, "-m", "simtune.cli", "init", "--robot", str(urdf), "--out", str(tmp_path / "p")],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2, result.stderr
    assert result.stderr.count("\n") == 1 and "is both its parent and its child" in result.stderr, result.stderr


def test_check_of_a_project_whose_urdf_gained_a_duplicate_joint_is_one_line_not_a_segfault(tmp_path):
    """``simtune check`` loads the robot in every engine: PyBullet segfaulted (exit 139, no line) on a joint name
    used twice.  Run as its own process, so a regression cannot take the test run with it."""
    urdf = write(tmp_path, arm())
    init_project(urdf, tmp_path / "project")
    write(tmp_path, arm(elbow="shoulder"))
    result = subprocess.run(
        [sys.executable, "-m", "simtune.cli", "check", str(tmp_path / "project")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 2, result.stderr
    assert "joint 'shoulder' is defined twice" in result.stderr and "Traceback" not in result.stderr


@pytest.mark.parametrize(
    "text",
    [
        arm(limit='lower="-1" upper="1" effort="0" velocity="0"'),  # ROS-Industrial's "not given"
        arm(limit='lower="-1" upper="1"'),  # none given
    ],
    ids=["zero-effort-and-velocity", "no-effort-or-velocity"],
)
def test_zero_or_absent_effort_and_velocity_still_load(tmp_path, text):
    robot = load_urdf(write(tmp_path, text))
    assert robot.arm_joints == ("shoulder", "elbow")
    # 0 reads as not given, as an absent limit does: every engine then applies the same generic limits
    shoulder = robot.joint_by_name["shoulder"]  # the joint the limit is written on
    assert shoulder.effort is None and shoulder.velocity is None


def test_zero_effort_is_said_once_and_reaches_no_engine_as_zero(tmp_path):
    """ROS-Industrial's effort="0": Drake refused the robot, and the engines that loaded it disagreed (one read no
    torque, another no limit)."""
    from simtune.robot.generate import robot_urdf

    path = write(tmp_path, arm(limit='lower="-1" upper="1" effort="0" velocity="0"'))
    with pytest.warns(RobotWarning, match=r"effort or velocity 0 on shoulder: read as not given") as caught:
        robot = load_urdf(path)
    assert len([w for w in caught if issubclass(w.category, RobotWarning)]) == 1
    assert 'effort="0"' not in robot_urdf(robot)


def test_a_mirrored_mesh_loads_but_a_flat_one_does_not(tmp_path):
    """A negative scale mirrors a mesh (every engine reads it); a zero one flattens it (MuJoCo, ODE and Drake
    refuse it)."""
    write(tmp_path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n", "tetra.obj")
    mirrored = load_urdf(write(tmp_path, arm(geometry='<mesh filename="tetra.obj" scale="0.1 -0.1 0.1"/>')))
    assert mirrored.link_by_name["upper"].shapes[0].scale == (0.1, -0.1, 0.1)
    with pytest.raises(RobotError, match=r"link 'upper' collision 1: mesh scale \(0.1, 0.0, 0.1\) flattens"):
        load_urdf(write(tmp_path, arm(geometry='<mesh filename="tetra.obj" scale="0.1 0 0.1"/>')))


# --------------------------------------------------------------------------- a long chain


def chain(n: int) -> str:
    """``n`` revolute joints lying along x at z = 0: the start pose's search turns them to lift the chain."""
    links = "".join(link(f"l{i}") for i in range(n + 1))
    joints = "".join(joint(f"j{i}", f"l{i}", f"l{i + 1}").replace('xyz="0 0 0.1"', 'xyz="0.05 0 0"') for i in range(n))
    return f'<robot name="chain">{links}{joints}</robot>'


def test_a_200_joint_chain_inits_in_seconds(tmp_path):
    """The start pose's search walked the chain once per link per candidate angle (about cubic: minutes, with no
    output); it walks it once per candidate now, over the first ``START_SEARCH_JOINTS`` joints."""
    urdf = write(tmp_path, chain(200))
    began = time.perf_counter()
    with deadline(30):
        init_project(urdf, tmp_path / "project")
    assert time.perf_counter() - began < 10
    assert (tmp_path / "project" / "tasks" / "reach.toml").is_file()


def reference_start_pose(robot) -> list[float]:
    """The search as it was written, one forward-kinematics walk per link (slow): the fast one must pick the same
    angles, to the bit."""

    def slow_clearance(q_deg) -> float:
        q = np.radians(np.asarray(q_deg, dtype=float))
        links = [j.child for j in robot.chain(robot.tracked_link)]
        names = [robot.parent_joint[name].name for name in links]
        second = robot.arm_joints[1] if robot.n_joints > 1 else robot.arm_joints[0]
        moved = links[names.index(second) + 1 :] if second in names else links[-1:]
        return min(float(robot.forward_kinematics(q, name)[0][2]) for name in moved or links[-1:])

    rooms = [_room(robot, name) for name in robot.arm_joints]
    start = [min(max(0.0, low), high) for low, high in rooms]
    if slow_clearance(start) >= START_CLEARANCE_M:
        return start
    for _ in range(2):
        for i, (low, high) in enumerate(rooms[:START_SEARCH_JOINTS]):
            options = sorted({min(max(c, low), high) for c in START_CANDIDATES_DEG}, key=abs)
            start[i] = max(options, key=lambda a: slow_clearance([*start[:i], a, *start[i + 1 :]]))
    return start


def test_the_fast_start_pose_search_picks_what_the_slow_one_did(tmp_path):
    """Chains longer than the search's cap (limited, and continuous: every candidate angle open), and an arm on a
    turned base (a ``world`` link) with turned joint frames, a tilted axis and a fixed flange; each lying low
    enough for the search to run."""
    world = (
        '<link name="world"/><joint name="fix" type="fixed"><parent link="world"/><child link="base"/>'
        '<origin xyz="0.3 -0.2 0.02" rpy="0 0 0.7"/></joint>'
    )
    turned = arm(origin='<origin xyz="0.2 0 0.05" rpy="0.3 1.2 -0.4"/>', axis="0.3 1 0.2", extra=world).replace(
        '<joint name="elbow"',
        f'{link("flange")}<joint name="mount" type="fixed"><parent link="fore"/><child link="flange"/>'
        '<origin xyz="0.1 0 0" rpy="0 1.5707963 0"/></joint><joint name="elbow"',
    )
    continuous = chain(14).replace('type="revolute"', 'type="continuous"')
    for text in (chain(16), continuous, turned):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RobotWarning)
            robot = load_urdf(write(tmp_path, text))
        assert clearance(robot, [0.0] * robot.n_joints) < START_CLEARANCE_M  # the search runs
        assert _start_pose(robot) == reference_start_pose(robot)


# --------------------------------------------------------------------------- random descriptions

BAD_NUMBERS = hs.sampled_from([0.0, -1.0, -0.05, 1e-12, math.nan, math.inf, -math.inf])
NAMES = hs.one_of(
    hs.sampled_from(["", "a", "b", "link", "j 1", "ü", "链节", 'q"t', "<&>", " ", "world"]),
    hs.text(hs.characters(blacklist_categories=("Cs",)), max_size=4),
)


class Faults:
    """How often a drawn value is wrong in one example: never, now and then, or often (most examples have few
    faults, so that many load and go on to MuJoCo)."""

    def __init__(self, draw) -> None:
        self.draw = draw
        self.odds = draw(hs.sampled_from([0, 0, 12, 3]))  # a fault one time in ``odds`` (0: never)

    def wrong(self) -> bool:
        return self.odds > 0 and self.draw(hs.integers(0, self.odds - 1)) == 0

    def numbers(self, good: list[float]) -> str:
        """``good`` as an attribute's text, or now and then with one of them wrong, one too few, or a word."""
        values = [self.draw(BAD_NUMBERS) if self.wrong() else v for v in good]
        text = " ".join(repr(float(v)) for v in values)  # inf, -inf and nan as a URDF would write them
        if self.wrong():
            return self.draw(hs.sampled_from([text.rpartition(" ")[0] or "x", "one", ""]))
        return text

    def attribute(self, name: str, good: list[float]) -> str:
        """`` name="..."``, or now and then nothing (the reader's default)."""
        return "" if self.wrong() else f" {name}={quoteattr(self.numbers(good))}"

    def name(self, plain: str) -> str:
        return self.draw(NAMES) if self.wrong() else plain


def _floats(draw, n: int, low: float, high: float) -> list[float]:
    return [draw(hs.floats(low, high)) for _ in range(n)]


@hs.composite
def descriptions(draw, mesh: str) -> str:
    """A small robot: a tree of up to five links with boxes, spheres, cylinders and a mesh; with faults drawn in
    (names empty, repeated or odd; a joint from anywhere, making two parents, a link its own parent or a loop, or
    to a link the file lacks; numbers negative, zero, NaN, infinite, too few or not numbers)."""
    faults = Faults(draw)
    n = draw(hs.integers(1, 5))
    link_names = [faults.name(f"l{i}") for i in range(n)]
    joint_names = [faults.name(f"j{i}") for i in range(1, n)]

    def origin() -> str:
        xyz = faults.attribute("xyz", _floats(draw, 3, -0.5, 0.5))
        return f"<origin{xyz}{faults.attribute('rpy', _floats(draw, 3, -3.2, 3.2))}/>" if draw(hs.booleans()) else ""

    def geometry() -> str:
        kind = draw(hs.sampled_from(["box", "sphere", "cylinder", "mesh"]))
        if kind == "box":
            return f"<box{faults.attribute('size', _floats(draw, 3, 0.01, 0.3))}/>"
        if kind == "sphere":
            return f"<sphere{faults.attribute('radius', _floats(draw, 1, 0.01, 0.2))}/>"
        if kind == "cylinder":
            sizes = faults.attribute("radius", _floats(draw, 1, 0.01, 0.2))
            return f"<cylinder{sizes}{faults.attribute('length', _floats(draw, 1, 0.01, 0.5))}/>"
        scale = _floats(draw, draw(hs.sampled_from([1, 3])), -2.0, 2.0)
        return f"<mesh filename={quoteattr(mesh)}{faults.attribute('scale', scale)}/>"

    links = []
    for name in link_names:
        body = ""
        if draw(hs.integers(0, 3)):
            moments = "".join(faults.attribute(i, _floats(draw, 1, 0.001, 0.1)) for i in ("ixx", "iyy", "izz"))
            moments += "".join(faults.attribute(i, _floats(draw, 1, -0.0005, 0.0005)) for i in ("ixy", "ixz", "iyz"))
            mass = faults.attribute("value", _floats(draw, 1, 0.0, 5.0))
            body += f"<inertial>{origin()}<mass{mass}/><inertia{moments}/></inertial>"
        for _ in range(draw(hs.integers(0, 2))):
            body += f"<collision>{origin()}<geometry>{geometry()}</geometry></collision>"
        links.append(f"<link name={quoteattr(name)}>{body}</link>")

    joints = []
    for i, name in enumerate(joint_names, start=1):
        parent = link_names[draw(hs.integers(0, n - 1) if faults.wrong() else hs.integers(0, i - 1))]
        child = "missing" if faults.wrong() else link_names[i]
        kind = draw(hs.sampled_from(["revolute", "revolute", "revolute", "continuous", "prismatic", "fixed"]))
        body = f"<parent link={quoteattr(parent)}/><child link={quoteattr(child)}/>{origin()}"
        if draw(hs.integers(0, 3)):
            body += f"<axis{faults.attribute('xyz', _floats(draw, 3, -1.0, 1.0))}/>"
        if draw(hs.integers(0, 5)):
            lower = draw(hs.floats(-3.0, 0.0))
            limits = faults.attribute("lower", [lower]) + faults.attribute("upper", [lower + draw(hs.floats(0, 3))])
            limits += faults.attribute("effort", _floats(draw, 1, 0.0, 100.0))
            limits += faults.attribute("velocity", _floats(draw, 1, 0.0, 5.0))
            body += f"<limit{limits}/>"
        if draw(hs.integers(0, 3)) == 0:
            body += f"<dynamics{faults.attribute('damping', _floats(draw, 1, 0.0, 2.0))}/>"
        if draw(hs.integers(0, 5)) == 0:
            followed = draw(hs.sampled_from(joint_names))
            body += f"<mimic joint={quoteattr(followed)}{faults.attribute('multiplier', _floats(draw, 1, -2, 2))}/>"
        joints.append(f"<joint name={quoteattr(name)} type={quoteattr(kind)}>{body}</joint>")
    return f"<robot name={quoteattr(faults.name('random'))}>{''.join(links + joints)}</robot>"


@pytest.fixture(scope="module")
def mesh_folder():
    with tempfile.TemporaryDirectory() as folder:
        (Path(folder) / "tetra.obj").write_text(
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
        )
        yield Path(folder)


def build_in_mujoco(robot) -> None:
    """What ``init`` computes for the example task, then the robot built and stepped in MuJoCo (in this process:
    MuJoCo reports a model it cannot build, where PyBullet, ODE and Drake may end the process)."""
    from simtune.engines import engine_class
    from simtune.tasks.init_project import reach_poses
    from simtune.tasks.spec import Phase, TaskSpec

    start, target = reach_poses(robot)
    assert all(math.isfinite(v) for v in [*start, *target])
    task = TaskSpec(
        "pose", "random", 1.0, (Phase(0.0, tuple(target)),), kp=1.0, start_pose_deg=tuple(start), robot=robot
    )
    sim = engine_class("mujoco")(task)
    try:
        sim.reset({})
        sim.step(5)
    finally:
        sim.close()


@settings(max_examples=150, deadline=2000, suppress_health_check=[HealthCheck.too_slow])
@given(data=hs.data())
def test_random_descriptions_load_or_stop_with_one_line(mesh_folder, data):
    """Any small URDF either loads (and builds in MuJoCo) or stops with one RobotError line: never another
    exception, never a hang."""
    text = data.draw(descriptions(str(mesh_folder / "tetra.obj")))
    urdf = mesh_folder / "random.urdf"
    urdf.write_text(text, encoding="utf-8")
    with deadline(5), warnings.catch_warnings():
        warnings.simplefilter("ignore", RobotWarning)
        try:
            robot = load_urdf(urdf)
        except RobotError as exc:
            assert "\n" not in str(exc) and str(urdf) in str(exc), str(exc)
            return
        try:
            build_in_mujoco(robot)
        except RobotError as exc:  # an engine's refusal, in one line
            assert "\n" not in str(exc), str(exc)


@pytest.mark.slow  # each example that inits loads the robot in five engines, each in a child process (about 40 s)
@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture]
)
@given(data=hs.data())
def test_random_descriptions_through_init_and_check_in_every_engine(mesh_folder, tmp_path, data):
    """Issue 50's Done-when: random URDF trees (names, limits, sizes, inertias, faults drawn in) through ``init`` and
    ``check`` in all five engines - ``init`` stops with one SimtuneError line or writes a project, and ``check``
    reports it in lines (an engine that crashes in its child process is one of them): no crash of the command, no
    hang, no traceback."""
    from simtune.check.project import check_project
    from simtune.errors import SimtuneError
    from simtune.tasks.init_project import init_project

    text = data.draw(descriptions(str(mesh_folder / "tetra.obj")))
    folder = Path(tempfile.mkdtemp(dir=tmp_path))
    urdf = folder / "random.urdf"
    urdf.write_text(text, encoding="utf-8")
    with deadline(600), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            project = init_project(urdf, folder / "project")
        except SimtuneError as exc:
            assert "\n" not in str(exc), str(exc)
            event("init refused it")
            return
        findings = check_project(project.parent if project.is_file() else project)
    event("checked")
    lines = [str(f) for f in findings]
    assert lines and all("\n" not in line and "Traceback" not in line for line in lines), lines
    assert any("engines that load the robot" in line or "cannot load" in line for line in lines), lines
