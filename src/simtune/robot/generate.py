"""Generate engine model files (MJCF for MuJoCo, URDF for Bullet and others) from a robot description.

Collision filtering is the same everywhere: arm shapes touch the floor and the
object but not each other (the real arm's covers never collide with
themselves in these tasks, and overlapping primitive boxes at the joints would
otherwise push the links apart).  Meshes are referenced by their absolute paths.
"""

from __future__ import annotations

import functools
import hashlib
import math
import os
import re
import tempfile
from pathlib import Path
from typing import Protocol

import numpy as np

from simtune.common.geometry import matrix_quat_wxyz, rpy_matrix
from simtune.robot.description import Box, Cylinder, Joint, Link, Mesh, RobotDescription, Sphere
from simtune.robot.meshes import convex_hull_file
from simtune.robot.mjcf import home_pose as mjcf_home_pose


def quoteattr(text: str) -> str:
    """An XML attribute value, escaped and quoted as ``xml.sax.saxutils.quoteattr`` does it, character for character
    (``tests/test_startup_cache.py`` compares them): that module imports ``urllib.request``, and with it ``http``,
    ``email`` and ``ssl``, a tenth of a second of every start of simtune."""
    text = text.replace("&", "&amp;").replace(">", "&gt;").replace("<", "&lt;")
    text = text.replace("\n", "&#10;").replace("\r", "&#13;").replace("\t", "&#9;")
    if '"' not in text:
        return f'"{text}"'
    if "'" not in text:
        return f"'{text}'"
    return '"' + text.replace('"', "&quot;") + '"'


#: Gain of MuJoCo's joint velocity servos [N m s/rad].
SERVO_KV = 50.0
#: The largest step of a velocity command the controller makes [rad/s] (-40 to +40 deg/s: the top of the tuned
#: velocity clamps' range), for a task whose clamp is at most 40 deg/s (:func:`command_step`).
LARGEST_COMMAND_STEP = 1.4
#: How long a default velocity servo may lag its command [s]: the servo's time constant, inertia over gain.
SERVO_LAG_S = 0.01
#: A clipped servo force changes its joint's speed by up to (force limit x time step / inertia) per step of
#: MuJoCo's generic time step (:data:`GENERIC_TIMESTEP`); above this [rad/s] the clipping sets the link spinning.
SPIN_LIMIT = 1.0
#: MuJoCo's own default time step [s], which the generated scene keeps as its generic value.
GENERIC_TIMESTEP = 0.002
#: A joint's viscous damping d slows a velocity servo of gain kv to kv / (kv + d) of its command: the default gain
#: is at least this multiple of d (the speed within 2 % of the command, as the other engines' hard motors hold it).
DAMPING_MULTIPLE = 50.0
#: A joint's Coulomb friction f (an MJCF file's frictionloss) holds a servo's speed up to f / kv below its command:
#: the default gain keeps that under this [rad/s].
FRICTION_SLIP = 0.01
#: The fastest velocity command [rad/s] (40 deg/s): the gain raised for damping or friction stays under the joint's
#: force limit over this, since a servo force MuJoCo clips at a larger gain stalls the joint (measured: the xArm7's
#: shoulder, 50 N m, did not move at a gain of 120 and a 2 ms step).
FASTEST_COMMAND = 0.7
#: A clipped servo force acts undamped for a whole step.  Where the speed it gives its joint in one step (every driven
#: joint's force clipped at once, through the coupled mass matrix) exceeds this multiple of force limit over gain, the
#: next step's force clips the other way, and the servo chatters between its limits at every step: measured on the
#: KUKA KR 16-2, whose shoulder and elbow pitch together (mass matrix 11.9, 5.5, 2.7 kg m^2), the elbow ran at three
#: times its command, the shoulder at 1.5 times, each step's speed alternating, and MuJoCo's wrist 7 mm (100 mm at
#: worst) off the hard motors of the other engines.
CHATTER_BAND = 2.0


def _largest_inertias(robot: RobotDescription) -> np.ndarray:
    """Each driven joint's inertia at the zero pose or, where larger, at an MJCF's home keyframe (a Menagerie Panda
    stands upright at zero, where its first joint turns a tenth of what it turns from home)."""
    inertias = robot.joint_inertias()
    if robot.mjcf is None:
        return inertias
    home = _home_pose(robot.mjcf, robot.arm_joints)
    return inertias if home is None else np.maximum(inertias, robot.joint_inertias(np.asarray(home)))


@functools.lru_cache(maxsize=16)
def _home_pose(mjcf: str, joints: tuple[str, ...]) -> tuple[float, ...] | None:
    """:func:`simtune.robot.mjcf.home_pose`, compiled once per process and file (each engine asks)."""
    home = mjcf_home_pose(mjcf, joints)
    return None if home is None else tuple(home)


def command_step(max_velocity_deg: float) -> float:
    """The largest step of a velocity command [rad/s] for a task whose velocity clamp is ``max_velocity_deg``: a
    reversal from one clamp to the other, at least :data:`LARGEST_COMMAND_STEP` (the tuned clamps reach 40 deg/s).

    Args:
        max_velocity_deg: the task's velocity clamp [deg/s].

    Returns:
        The step [rad/s].
    """
    return max(LARGEST_COMMAND_STEP, 2.0 * math.radians(max_velocity_deg))


@functools.lru_cache(maxsize=32)  # per robot and step: each joint's range (params.kinds) and each engine ask
def servo_gains(robot: RobotDescription, step: float = LARGEST_COMMAND_STEP) -> tuple[float, ...]:
    """The gain of MuJoCo's velocity servo on each driven joint [N m s/rad]: the robot's ``servo_gain``
    where it sets one, else :data:`SERVO_KV`, raised where the joint's inertia (at the zero pose, or an MJCF's home
    keyframe where larger) would make
    the servo lag its command by more than :data:`SERVO_LAG_S` (a heavy arm's shoulder), and lowered to keep
    the largest command step's force within the joint's generic force limit where a clipped force would
    spin the link (:data:`SPIN_LIMIT`): a clipped servo force is not damped by the implicit integrator
    (the MICO's light wrist in seed-2; a SO-101, whose URDF allows 10 N m, at every step with 50), for a command
    step of ``step`` (:func:`command_step`: a task faster than 40 deg/s steps further, a light link's gain is lower).
    The inertia counts the joint's armature (an MJCF file's rotor inertia: 4 kg m^2 on dm_control's Jaco), and
    the gain is raised as well where the joint's damping or Coulomb friction would hold its speed below the
    command (:data:`DAMPING_MULTIPLE`, :data:`FRICTION_SLIP`, up to :data:`FASTEST_COMMAND`'s force limit): the
    other engines' hard motors hold the commanded speed against both, and a servo they slow lags them by
    centimetres.  Where joints clip together at force limits simtune made up, a gain is lowered below the band
    in which their coupled clipped forces chatter (:func:`_without_chatter`).  For the MICO the gain stays 50.

    Args:
        robot: the robot.
        step: the largest step of a velocity command [rad/s].

    Returns:
        One gain per driven joint [N m s/rad].
    """
    if robot.servo_gain is not None:
        return (robot.servo_gain,) * robot.n_joints
    gains = []
    for index, inertia in enumerate(_largest_inertias(robot)):
        effort = robot.generic_effort(index)
        joint = robot.joint_by_name[robot.arm_joints[index]]
        inertia = float(inertia) + joint.armature
        held_back = min(max(DAMPING_MULTIPLE * joint.damping, joint.friction / FRICTION_SLIP), effort / FASTEST_COMMAND)
        gain = max(SERVO_KV, inertia / SERVO_LAG_S, held_back)
        clipped = gain * step > effort
        if clipped and effort * GENERIC_TIMESTEP > SPIN_LIMIT * inertia:
            gain = effort / step
        gains.append(gain)
    return _without_chatter(robot, gains, step)


def _without_chatter(robot: RobotDescription, gains: list[float], step: float) -> tuple[float, ...]:
    """``gains`` lowered where a clipped servo would chatter (:data:`CHATTER_BAND`).  The joints whose servo clips at
    the largest command step accelerate one another through the mass matrix (armature on its diagonal); the others'
    servos, unclipped, hold them (the implicit integrator damps them), so the speed one step of clipped forces gives
    a clipped joint is the time step times the inverse of the clipped joints' block against their force limits, signs
    the worst.  A robot none of whose servos clip (the MICO) keeps its gains.  Only a force limit simtune made up
    (the description gives none: :meth:`RobotDescription.generic_effort`) lowers a gain: the worst signs overstate
    what a described arm meets (the xArm7's first and third joints, in line at the zero pose, would get a gain of 6
    where, measured, its servos never chattered), and the arms with their own limits keep their measured agreement."""
    efforts = np.array([robot.generic_effort(i) for i in range(robot.n_joints)])
    # a gain SPIN_LIMIT's rule set to force limit over command step does not clip (rounding aside)
    clipped = [i for i, gain in enumerate(gains) if gain * step > efforts[i] * (1 + 1e-9)]
    if len(clipped) < 2:  # one joint alone: SPIN_LIMIT's rule covers it
        return tuple(gains)
    armature = np.array([robot.joint_by_name[name].armature for name in robot.arm_joints])
    home = None if robot.mjcf is None else _home_pose(robot.mjcf, robot.arm_joints)
    # the pose the arm starts from: an MJCF's home keyframe, else the zero pose
    matrix = robot.mass_matrix(None if home is None else np.asarray(home))
    block = (matrix + np.diag(armature))[np.ix_(clipped, clipped)]
    jump = GENERIC_TIMESTEP * np.abs(np.linalg.pinv(block)) @ efforts[clipped]
    out = list(gains)
    for index, speed in zip(clipped, jump):
        if speed > 0 and robot.joint_by_name[robot.arm_joints[index]].effort is None:
            out[index] = min(out[index], CHATTER_BAND * efforts[index] / speed)
    return tuple(out)


#: Below this fraction of its command a servo's speed is held back (by damping) enough to warn of.
SHORTFALL_WARNING = 0.9


def servo_shortfalls(robot: RobotDescription) -> dict[str, str]:
    """The driven joints whose damping or Coulomb friction MuJoCo's velocity servo (:func:`servo_gains`) cannot
    outweigh (the gain held at the joint's force limit): joint -> what holds it back.  PyBullet's, ODE's and
    DART's hard motors hold the commanded speed against both, so their motion of such a joint differs from
    MuJoCo's (and Drake's, whose servo is MuJoCo's): what ``simtune check`` warns of.

    Args:
        robot: the robot.

    Returns:
        Joint name -> the cause in words; empty where every servo holds its command.
    """
    out = {}
    for index, gain in enumerate(servo_gains(robot)):
        joint = robot.joint_by_name[robot.arm_joints[index]]
        speed = gain / (gain + joint.damping)
        slip = joint.friction / gain
        if speed < SHORTFALL_WARNING:
            out[joint.name] = (
                f"damping {joint.damping:g} N m s/rad and friction {joint.friction:g} N m against a servo gain of "
                f"{gain:.3g}: {100 * speed:.0f} % of the commanded speed, {slip:.2g} rad/s slip"
            )
    return out


#: Name of the MuJoCo/URDF body that carries the task's object.
OBJECT_BODY = "object"
FLOOR = "floor"


class SceneObject(Protocol):
    """What the model files need of a task's object (:class:`simtune.tasks.spec.ObjectSpec` is one).

    Declared here, below the tasks, so that the robot's model generator does not depend on them.
    """

    @property
    def shape(self) -> str: ...  # "cube", "cuboid", "cylinder" or "cone"
    @property
    def size(self) -> tuple[float, ...]: ...
    @property
    def mass(self) -> float: ...
    @property
    def rotation(self) -> np.ndarray: ...
    @property
    def start_position(self) -> tuple[float, float, float]: ...
    def cone_vertices(self, segments: int = 24) -> np.ndarray: ...


def _f(values) -> str:
    return " ".join(f"{float(v):.9g}" for v in values)


def geom_name(link: str, index: int) -> str:
    return f"{link}_box{index}"


# --------------------------------------------------------------------------- MJCF


def mesh_asset_name(link: str, index: int) -> str:
    return f"{link}_mesh{index}"


def _mjcf_placement(shape) -> str:
    pos = f'pos="{_f(shape.center)}"'
    if shape.rpy == (0.0, 0.0, 0.0):
        return pos
    return f'{pos} quat="{_f(matrix_quat_wxyz(rpy_matrix(shape.rpy)))}"'


def _mjcf_geom(link: Link, index: int, shape) -> str:
    name = f'name={quoteattr(geom_name(link.name, index))} class="arm"'
    where = _mjcf_placement(shape)
    if isinstance(shape, Box):
        return f'<geom {name} type="box" {where} size="{_f(shape.half)}"/>'
    if isinstance(shape, Sphere):
        return f'<geom {name} type="sphere" {where} size="{shape.radius:.9g}"/>'
    if isinstance(shape, Cylinder):
        return f'<geom {name} type="cylinder" {where} size="{shape.radius:.9g} {shape.length / 2:.9g}"/>'
    # MuJoCo collides with a mesh's convex hull
    return f'<geom {name} type="mesh" mesh="{mesh_asset_name(link.name, index)}" {where}/>'


def _mjcf_inertial(link: Link) -> str:
    if link.mass <= 0:  # a massless frame (a tool point): MuJoCo takes no inertial element without mass
        return ""
    if link.diagonal_inertia:
        inertia = f'diaginertia="{_f(link.inertia)}"'
    else:
        i = link.inertia_matrix()
        inertia = f'fullinertia="{_f((i[0, 0], i[1, 1], i[2, 2], i[0, 1], i[0, 2], i[1, 2]))}"'
    return f'<inertial pos="{_f(link.com)}" mass="{link.mass:.9g}" {inertia}/>'


def _mjcf_link(robot: RobotDescription, link: Link, joint: Joint | None, indent: str) -> list[str]:
    lines = []
    attrs = f"name={quoteattr(link.name)}"
    if joint is None:
        attrs += f' pos="{_f(robot.base_position)}"'
        if robot.base_rpy != (0.0, 0.0, 0.0):
            attrs += f' quat="{_f(matrix_quat_wxyz(rpy_matrix(robot.base_rpy)))}"'
    else:
        # The arm's own controller compensates gravity; the velocity servo then only
        # has to overcome inertia, as the real arm's does.
        attrs += f' gravcomp="1" pos="{_f(joint.xyz)}" quat="{_f(matrix_quat_wxyz(rpy_matrix(joint.rpy)))}"'
    lines.append(f"{indent}<body {attrs}>")
    inner = indent + "  "
    inertial = _mjcf_inertial(link)
    if inertial:
        lines.append(f"{inner}{inertial}")
    if joint is not None and joint.moves:
        kind = "slide" if joint.kind == "prismatic" else "hinge"
        limit = f' range="{joint.lower:.9g} {joint.upper:.9g}"' if joint.limited else ""
        damping = f' damping="{joint.damping:.9g}"' if joint.damping else ""
        name = quoteattr(joint.name)  # a URDF's names may hold quotes, < and &
        lines.append(f'{inner}<joint name={name} type="{kind}" axis="{_f(joint.axis)}"{limit}{damping}/>')
    for i, shape in enumerate(link.shapes):
        lines.append(f"{inner}{_mjcf_geom(link, i, shape)}")
    for child_joint in robot.children(link.name):
        child = robot.link_by_name[child_joint.child]
        lines += _mjcf_link(robot, child, child_joint, inner)
    lines.append(f"{indent}</body>")
    return lines


def _mjcf_meshes(robot: RobotDescription) -> list[str]:
    return [
        f"    <mesh name={quoteattr(mesh_asset_name(link.name, i))} file={quoteattr(shape.path)} "
        f'scale="{_f(shape.scale)}"/>'
        for link in robot.links
        for i, shape in enumerate(link.shapes)
        if isinstance(shape, Mesh)
    ]


def _mjcf_object(obj: SceneObject) -> tuple[list[str], list[str]]:
    """(asset lines, worldbody lines) for the task's object."""
    quat = _f(matrix_quat_wxyz(obj.rotation))
    pos = _f(obj.start_position)
    assets: list[str] = []
    if obj.shape in ("cube", "cuboid"):
        geom = f'type="box" size="{_f(np.asarray(obj.size) / 2)}"'
    elif obj.shape == "cylinder":
        radius, length = obj.size
        geom = f'type="cylinder" size="{radius:.9g} {length / 2:.9g}"'
    else:
        assets.append(f'    <mesh name="cone" vertex="{_f(obj.cone_vertices().ravel())}"/>')
        geom = 'type="mesh" mesh="cone"'
    body = [
        f'    <body name="{OBJECT_BODY}" pos="{pos}" quat="{quat}">',
        f'      <freejoint name="{OBJECT_BODY}"/>',
        f'      <geom name="{OBJECT_BODY}" class="object" {geom} mass="{obj.mass:.9g}"/>',
        "    </body>",
    ]
    return assets, body


def scene_mjcf(robot: RobotDescription, obj: SceneObject | None = None) -> str:
    """MJCF of ``robot`` on the floor with velocity actuators on its driven joints, plus ``obj`` (for a
    robot from an MJCF file, the scene without the robot and its actuators).

    Timestep, masses, frictions, gains and limits are MuJoCo's defaults or the
    description's values; parameters are applied to the compiled model later.
    """
    assets, object_body = _mjcf_object(obj) if obj is not None else ([], [])
    if robot.mjcf is not None:  # the MuJoCo engine adds the robot and its servos from the MJCF itself
        arm: list[str] = []
    else:
        assets = _mjcf_meshes(robot) + assets
        arm = _mjcf_link(robot, robot.links[0], None, "    ")
    gains = servo_gains(robot) if robot.mjcf is None else ()
    actuators = [
        # A velocity servo; its force limit (max torque) is set per evaluation.  Its gain (servo_gains) keeps
        # the largest command step's force within the generic limit: for the MICO, 70 N m below 100.
        f'    <velocity name={quoteattr(j)} joint={quoteattr(j)} kv="{gains[i]:.9g}" '
        f'forcerange="{-robot.generic_effort(i):.9g} {robot.generic_effort(i):.9g}"/>'
        for i, j in enumerate(robot.arm_joints)
        if robot.mjcf is None
    ]
    return "\n".join(
        [
            f"<mujoco model={quoteattr(robot.name + '_scene')}>",
            '  <compiler angle="radian" autolimits="true" balanceinertia="true"/>',
            # implicitfast integrates the velocity servos' damping-like forces stably at large steps
            '  <option integrator="implicitfast" gravity="0 0 -9.81"/>',
            "  <default>",
            # contype/conaffinity: arm (2) hits world (1); world hits everything; arm never hits arm
            '    <default class="arm"><geom contype="2" conaffinity="1" condim="3"/></default>',
            '    <default class="object"><geom contype="1" conaffinity="3" condim="6"/></default>',
            "  </default>",
            "  <asset>",
            *assets,
            "  </asset>",
            "  <worldbody>",
            f'    <geom name="{FLOOR}" type="plane" size="0 0 1" contype="1" conaffinity="3" condim="3"/>',
            *arm,
            *object_body,
            "  </worldbody>",
            "  <actuator>",
            *actuators,
            "  </actuator>",
            "</mujoco>",
        ]
    )


# --------------------------------------------------------------------------- URDF


def _urdf_origin(shape) -> str:
    return f'<origin xyz="{_f(shape.center)}" rpy="{_f(shape.rpy)}"/>'


def _urdf_geometry(shape, hulls: bool = False) -> str:
    if isinstance(shape, Box):
        return f'<box size="{_f(2 * np.asarray(shape.half))}"/>'
    if isinstance(shape, Sphere):
        return f'<sphere radius="{shape.radius:.9g}"/>'
    if isinstance(shape, Cylinder):
        return f'<cylinder radius="{shape.radius:.9g}" length="{shape.length:.9g}"/>'
    path = str(convex_hull_file(shape.path)) if hulls else shape.path
    return f'<mesh filename={quoteattr(path)} scale="{_f(shape.scale)}"/>'


def _urdf_link(link: Link, hulls: bool = False) -> list[str]:
    lines = [f"  <link name={quoteattr(link.name)}>"]
    ixx, iyy, izz = link.inertia
    ixy, ixz, iyz = link.products
    lines += [
        "    <inertial>",
        f'      <origin xyz="{_f(link.com)}" rpy="{_f(link.inertia_rpy)}"/>',
        f'      <mass value="{link.mass:.9g}"/>',
        f'      <inertia ixx="{ixx:.9g}" ixy="{ixy:.9g}" ixz="{ixz:.9g}" iyy="{iyy:.9g}" iyz="{iyz:.9g}" '
        f'izz="{izz:.9g}"/>',
        "    </inertial>",
    ]
    for shape in link.shapes:
        lines += [
            "    <collision>",
            f"      {_urdf_origin(shape)}",
            f"      <geometry>{_urdf_geometry(shape, hulls)}</geometry>",
            "    </collision>",
        ]
    lines.append("  </link>")
    return lines


def _urdf_joint(joint: Joint) -> list[str]:
    if joint.kind == "fixed":
        kind = "fixed"
    elif joint.kind == "prismatic":
        kind = "prismatic"
    else:
        kind = "revolute" if joint.limited else "continuous"
    lines = [
        f'  <joint name={quoteattr(joint.name)} type="{kind}">',  # names may hold quotes, < and &
        f"    <parent link={quoteattr(joint.parent)}/>",
        f"    <child link={quoteattr(joint.child)}/>",
        f'    <origin xyz="{_f(joint.xyz)}" rpy="{_f(joint.rpy)}"/>',
    ]
    if kind != "fixed":
        lines.append(f'    <axis xyz="{_f(joint.axis)}"/>')
    if kind in ("revolute", "prismatic") and joint.limited:
        # without the source's effort and velocity, placeholders: the controller sets both every update
        effort = 9000 if joint.effort is None else joint.effort
        velocity = 10 if joint.velocity is None else joint.velocity
        lines.append(
            f'    <limit lower="{joint.lower:.9g}" upper="{joint.upper:.9g}" '
            f'effort="{effort:.9g}" velocity="{velocity:.9g}"/>'
        )
    if kind != "fixed" and joint.damping:
        lines.append(f'    <dynamics damping="{joint.damping:.9g}"/>')
    lines.append("  </joint>")
    return lines


def robot_urdf(robot: RobotDescription, hulls: bool = False) -> str:
    """URDF of the robot alone (its base frame at the origin; place it at its base pose); ``hulls``: each mesh
    as its convex hull (the shape an engine that collides with hulls makes of it, fewer vertices to read)."""
    lines = ['<?xml version="1.0"?>', f"<robot name={quoteattr(robot.name)}>"]
    for link in robot.links:
        lines += _urdf_link(link, hulls)
    for joint in robot.joints:
        lines += _urdf_joint(joint)
    lines.append("</robot>")
    return "\n".join(lines)


def robot_urdf_file(robot: RobotDescription, hulls: bool = False) -> str:
    """Path of the generated URDF on disk, for engines whose loaders read files; written once per content."""
    text = robot_urdf(robot, hulls)
    digest = hashlib.sha1(text.encode()).hexdigest()[:12]
    stem = re.sub(r"[^\w.-]", "_", robot.name)[:40]  # a URDF's robot name may hold "/" or be empty
    path = Path(tempfile.gettempdir()) / f"simtune-{stem}-{digest}.urdf"
    if not path.exists():
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(text)
        os.replace(tmp, path)  # atomic: parallel workers never see half a file
    return str(path)
