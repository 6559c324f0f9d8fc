"""A robot from an MJCF file, for the MuJoCo-family engines only.

MuJoCo compiles the file (includes, defaults, mesh folders resolved its own way); the
description is read from the compiled model: one link per body below the world, its
inertia, and the joint that moves it (a hinge or a slide at the body's origin; a body
without one is welded).  The MuJoCo engine builds the robot from the file itself
(:attr:`RobotDescription.mjcf`), keeping its geoms; the other engines refuse such a robot
in one line (they need a URDF).

simtune owns the control and the contacts, so the file's actuators, sensors, tendons,
equality constraints, contact pairs and keyframes are dropped when the scene is built,
and joints that are not driven are removed (their bodies welded at the joint's zero: a
gripper's fingers held at 0).  Driven joints default to the hinges from the root body
down to the tracked link, and the tracked link to where the root's chain first branches
or ends.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np

from simtune.errors import RobotError
from simtune.robot.description import Joint, Link, RobotDescription, Vec3


def _vec(values) -> Vec3:
    x, y, z = (float(v) for v in values)
    return (x, y, z)


def _rpy(quat_wxyz) -> Vec3:
    from scipy.spatial.transform import Rotation

    w, x, y, z = (float(v) for v in quat_wxyz)
    return _vec(Rotation.from_quat([x, y, z, w]).as_euler("xyz"))


def _compile(path: Path):
    """MuJoCo's model of the MJCF at ``path``."""
    try:
        import mujoco
    except ImportError:  # pragma: no cover - mujoco is a core dependency
        raise RobotError(f"{path}: reading an MJCF needs mujoco") from None
    path = Path(path).expanduser().resolve()
    if not path.is_file():
        raise RobotError(f"{path}: no such MJCF file")
    try:
        return mujoco.MjModel.from_xml_path(str(path))
    except ValueError as exc:
        first = str(exc).strip().splitlines()
        raise RobotError(f"{path}: MuJoCo cannot compile it ({' '.join(first[:2])})") from None


def _hinge() -> int:
    import mujoco

    return int(mujoco.mjtJoint.mjJNT_HINGE)


def _moving_bodies(model, path: Path, root) -> dict[int, int]:
    """Each body that a joint moves -> that joint: one hinge or slide at the body's origin, named; the root fixed."""
    import mujoco

    moving: dict[int, int] = {}  # body -> its joint
    for j in range(model.njnt):
        jnt = model.joint(j)
        body = int(jnt.bodyid[0])
        where = f"joint {jnt.name or j!r}"
        if body == root.id:
            raise RobotError(f"{path}: {where} moves the root body {root.name!r}: the base must be fixed")
        if body in moving:
            raise RobotError(f"{path}: body {model.body(body).name!r} has several joints (one per body supported)")
        if int(jnt.type[0]) not in (_hinge(), int(mujoco.mjtJoint.mjJNT_SLIDE)):
            raise RobotError(f"{path}: {where} is a ball or free joint (hinges and slides supported)")
        if np.any(np.abs(jnt.pos) > 1e-12):
            raise RobotError(f"{path}: {where} is off its body's origin (joints at body origins supported)")
        if not jnt.name:
            raise RobotError(f"{path}: joint {j} of body {model.body(body).name!r} has no name")
        moving[body] = j
    return moving


def _below(root: int, children: dict[int, list[int]]) -> list[int]:
    """The bodies below ``root``, parents first (breadth first)."""
    order: list[int] = []
    queue = [root]
    while queue:
        for child in children.get(queue.pop(0), []):
            order.append(child)
            queue.append(child)
    return order


def _driven(model, path: Path, root: int, tracked: int, moving: dict[int, int], arm_joints) -> list[str]:
    """The driven joints: ``arm_joints``, or by default the hinges from the root down to the tracked body."""
    hinge = _hinge()
    if arm_joints is None:
        chain = []
        b = tracked
        while b != root:
            chain.append(b)
            b = int(model.body(b).parentid[0])
        driven = [
            model.joint(moving[b]).name
            for b in reversed(chain)
            if b in moving and int(model.joint(moving[b]).type[0]) == hinge
        ]
    else:
        driven = list(arm_joints)
    joint_names = {model.joint(j).name: j for j in range(model.njnt)}
    for joint_name in driven:
        if joint_name not in joint_names:
            raise RobotError(f"{path}: joint {joint_name!r} is not a joint of the MJCF")
        if int(model.joint(joint_names[joint_name]).type[0]) != hinge:
            raise RobotError(f"{path}: joint {joint_name!r} is a slide: simtune drives hinge joints only")
    if not driven:
        raise RobotError(f"{path}: no hinge joint to drive up to body {model.body(tracked).name!r}")
    return driven


def _gripper(model, path: Path, tracked_link: str, order: list[int], ids: dict[str, int], gripper_links) -> set[str]:
    """The gripper's links: ``gripper_links``, or by default the tracked link and every body below it."""
    if gripper_links is None:
        gripper = {tracked_link}
        for b in order:
            if model.body(int(model.body(b).parentid[0])).name in gripper:
                gripper.add(model.body(b).name)
        return gripper
    gripper = set(gripper_links)
    for g in gripper:
        if g not in ids:
            raise RobotError(f"{path}: gripper link {g!r} is not a body of the MJCF")
    return gripper


def _link(model, b: int, gripper: set[str]) -> Link:
    body = model.body(b)
    return Link(
        name=body.name,
        mass=float(body.mass[0]),
        com=_vec(body.ipos),
        inertia=_vec(body.inertia),
        material="gripper" if body.name in gripper else "arm",
        inertia_rpy=_rpy(body.iquat),
    )


def _joints(
    model, order: list[int], moving: dict[int, int], driven: list[str]
) -> tuple[list[Joint], list[tuple[str, float]]]:
    """The joint into each body below the root (driven ones revolute or continuous, the others fixed) and the
    joints held at 0 (those of the file that are not driven)."""
    joints = []
    held = []
    for b in order:
        body = model.body(b)
        parent = model.body(int(body.parentid[0])).name
        xyz, rpy = _vec(body.pos), _rpy(body.quat)
        jid = moving.get(b)
        if jid is None or model.joint(jid).name not in driven:
            if jid is not None:
                held.append((model.joint(jid).name, 0.0))
            weld = f"{body.name}_weld" if jid is None else model.joint(jid).name
            joints.append(Joint(weld, "fixed", parent, body.name, xyz, rpy))
            continue
        jnt = model.joint(jid)
        limited = bool(jnt.limited[0])
        joints.append(
            Joint(
                jnt.name,
                "revolute" if limited else "continuous",
                parent,
                body.name,
                xyz,
                rpy,
                axis=_vec(jnt.axis),
                lower=float(jnt.range[0]) if limited else None,
                upper=float(jnt.range[1]) if limited else None,
                damping=float(model.dof_damping[int(jnt.dofadr[0])]),
            )
        )
    return joints, held


def load_mjcf(
    path: str | Path,
    *,
    arm_joints: Iterable[str] | None = None,
    tracked_link: str | None = None,
    gripper_links: Iterable[str] | None = None,
    name: str | None = None,
) -> RobotDescription:
    """The robot of the MJCF at ``path`` (one robot: one body tree below the world); ``RobotError``
    (one line naming the file and element) if it cannot be used."""
    model = _compile(Path(path))
    path = Path(path).expanduser().resolve()
    bodies = [model.body(i) for i in range(model.nbody)]
    roots = [b for b in bodies[1:] if b.parentid[0] == 0]
    if len(roots) != 1:
        raise RobotError(f"{path}: expected one robot (one body below the world), found {len(roots)}")
    root = roots[0]
    children: dict[int, list[int]] = {}
    for b in bodies[2:]:
        children.setdefault(int(b.parentid[0]), []).append(b.id)
    moving = _moving_bodies(model, path, root)
    for b in bodies[1:]:
        if not b.name:
            raise RobotError(f"{path}: body {b.id} has no name (every link needs one)")
    order = _below(root.id, children)
    ids = {b.name: b.id for b in bodies[1:]}
    if tracked_link is None:
        tracked = root.id
        while len(children.get(tracked, [])) == 1:
            tracked = children[tracked][0]
        tracked_link = model.body(tracked).name
    elif tracked_link not in ids:
        raise RobotError(f"{path}: tracked link {tracked_link!r} is not a body of the MJCF")
    driven = _driven(model, path, root.id, ids[tracked_link], moving, arm_joints)
    gripper = _gripper(model, path, tracked_link, order, ids, gripper_links)
    joints, held = _joints(model, order, moving, driven)
    description = RobotDescription(
        name=name or model.names[: model.names.index(b"\0")].decode() or path.stem,
        links=(_link(model, root.id, gripper), *(_link(model, b, gripper) for b in order)),
        joints=tuple(joints),
        arm_joints=tuple(driven),
        tracked_link=tracked_link,
        base_position=_vec(root.pos),
        base_rpy=_rpy(root.quat),
        held=tuple(held),
        source=str(path),
        mjcf=str(path),
    )
    try:
        description.check()
    except ValueError as exc:
        raise RobotError(f"{path}: {exc}") from None
    return description
