"""Generate engine model files (MJCF for MuJoCo, URDF for Bullet and others) from :mod:`mico`.

Collision filtering is the same everywhere: arm shapes touch the floor and the
object but not each other (the real arm's covers never collide with
themselves in these tasks, and overlapping primitive boxes at the joints would
otherwise push the links apart).
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path
from typing import Protocol
from xml.sax.saxutils import quoteattr

import numpy as np

from simtune.geometry import matrix_quat_wxyz, rpy_matrix
from simtune.robot.mico import ARM_JOINTS, BASE_POSITION, JOINTS, LINKS, Joint, Link, children

#: Gain of MuJoCo's joint velocity servos [N m s/rad].
SERVO_KV = 50.0

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


def _mjcf_link(link: Link, joint: Joint | None, indent: str) -> list[str]:
    lines = []
    attrs = f"name={quoteattr(link.name)}"
    if joint is None:
        attrs += f' pos="{_f(BASE_POSITION)}"'
    else:
        # The arm's own controller compensates gravity; the velocity servo then only
        # has to overcome inertia, as the real arm's does.
        attrs += f' gravcomp="1" pos="{_f(joint.xyz)}" quat="{_f(matrix_quat_wxyz(rpy_matrix(joint.rpy)))}"'
    lines.append(f"{indent}<body {attrs}>")
    inner = indent + "  "
    lines.append(f'{inner}<inertial pos="{_f(link.com)}" mass="{link.mass:.9g}" diaginertia="{_f(link.inertia)}"/>')
    if joint is not None and joint.kind != "fixed":
        limit = f' range="{-joint.limit:.9g} {joint.limit:.9g}"' if joint.limit is not None else ""
        lines.append(f'{inner}<joint name="{joint.name}" type="hinge" axis="0 0 1"{limit}/>')
    for i, box in enumerate(link.boxes):
        lines.append(
            f'{inner}<geom name="{geom_name(link.name, i)}" class="arm" type="box" '
            f'pos="{_f(box.center)}" size="{_f(box.half)}"/>'
        )
    for child_joint in children(link.name):
        child = next(x for x in LINKS if x.name == child_joint.child)
        lines += _mjcf_link(child, child_joint, inner)
    lines.append(f"{indent}</body>")
    return lines


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


def scene_mjcf(obj: SceneObject | None = None) -> str:
    """MJCF of the arm on the floor with velocity actuators on its six joints, plus ``obj``.

    Timestep, masses, frictions, gains and limits are MuJoCo's defaults or the
    description's values; parameters are applied to the compiled model later.
    """
    assets, object_body = _mjcf_object(obj) if obj is not None else ([], [])
    base = next(x for x in LINKS if x.name == "link_base")
    arm = _mjcf_link(base, None, "    ")
    actuators = [
        # A velocity servo; its force limit (max torque) is set per evaluation.  kv is chosen so
        # that the largest command step (-40 to +40 deg/s) asks for 70 N m, below the smallest
        # limit of the search range (100): a clipped servo force on the light wrist links is
        # not damped by the implicit integrator and sets them spinning (seen in seed-2).
        f'    <velocity name="{j}" joint="{j}" kv="{SERVO_KV:g}" forcerange="-100 100"/>'
        for j in ARM_JOINTS
    ]
    return "\n".join(
        [
            '<mujoco model="kinova_mico_scene">',
            '  <compiler angle="radian" autolimits="true"/>',
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


def _urdf_link(link: Link) -> list[str]:
    lines = [f"  <link name={quoteattr(link.name)}>"]
    ixx, iyy, izz = link.inertia
    lines += [
        "    <inertial>",
        f'      <origin xyz="{_f(link.com)}" rpy="0 0 0"/>',
        f'      <mass value="{link.mass:.9g}"/>',
        f'      <inertia ixx="{ixx:.9g}" ixy="0" ixz="0" iyy="{iyy:.9g}" iyz="0" izz="{izz:.9g}"/>',
        "    </inertial>",
    ]
    for box in link.boxes:
        lines += [
            "    <collision>",
            f'      <origin xyz="{_f(box.center)}" rpy="0 0 0"/>',
            f'      <geometry><box size="{_f(2 * np.asarray(box.half))}"/></geometry>',
            "    </collision>",
        ]
    lines.append("  </link>")
    return lines


def _urdf_joint(joint: Joint) -> list[str]:
    kind = "fixed" if joint.kind == "fixed" else ("revolute" if joint.limit is not None else "continuous")
    lines = [
        f'  <joint name="{joint.name}" type="{kind}">',
        f'    <parent link="{joint.parent}"/>',
        f'    <child link="{joint.child}"/>',
        f'    <origin xyz="{_f(joint.xyz)}" rpy="{_f(joint.rpy)}"/>',
    ]
    if kind != "fixed":
        lines.append('    <axis xyz="0 0 1"/>')
    if kind == "revolute" and joint.limit is not None:
        # effort/velocity here are placeholders: the controller sets both every update
        lines.append(f'    <limit lower="{-joint.limit:.9g}" upper="{joint.limit:.9g}" effort="9000" velocity="10"/>')
    lines.append("  </joint>")
    return lines


def robot_urdf() -> str:
    """URDF of the arm alone (its base frame at the origin; place it at BASE_POSITION)."""
    lines = ['<?xml version="1.0"?>', '<robot name="kinova_mico">']
    for link in LINKS:
        lines += _urdf_link(link)
    for joint in JOINTS:
        lines += _urdf_joint(joint)
    lines.append("</robot>")
    return "\n".join(lines)


def robot_urdf_file() -> str:
    """Path of the generated URDF on disk, for engines whose loaders read files; written once per content."""
    text = robot_urdf()
    digest = hashlib.sha1(text.encode()).hexdigest()[:12]
    path = Path(tempfile.gettempdir()) / f"simtune-mico-{digest}.urdf"
    if not path.exists():
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(text)
        os.replace(tmp, path)  # atomic: parallel workers never see half a file
    return str(path)
