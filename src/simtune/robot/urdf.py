"""A robot from a URDF file: parsed with ``yourdfpy``, turned into a :class:`RobotDescription`.

The driven joints default to the revolute joints from the root down to the tracked link,
and the tracked link to where the root's chain first branches or ends (a hand with its
fingers: the hand).  Every other movable joint is held at a fixed pose (a gripper's
fingers): at the position the caller gives, else at 0 clamped into its limits, a mimic
joint at its multiplier and offset from the joint it follows.  A driven joint may not be
a mimic joint (simtune has no coupled joints).  Mesh file names may be relative to the
URDF's folder, ``file://`` or ``package://NAME/...`` (NAME looked for beside the URDF and
in its parent folders, the way pybullet_data's models use it); the description keeps
their absolute paths.  The links' collision elements are kept, their visual ones ignored.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np

from simtune.errors import RobotError
from simtune.geometry import rpy_matrix
from simtune.robot.description import (
    Box,
    Cylinder,
    Joint,
    Link,
    Mesh,
    RobotDescription,
    Shape,
    Sphere,
    Vec3,
    axis_angle_matrix,
)

_MOVABLE = ("revolute", "continuous", "prismatic")


def _vec(values) -> Vec3:
    x, y, z = (float(v) for v in values)
    return (x, y, z)


def _rpy(rotation: np.ndarray) -> Vec3:
    """URDF roll-pitch-yaw of a rotation matrix (R = Rz(yaw) Ry(pitch) Rx(roll): SciPy's extrinsic xyz)."""
    from scipy.spatial.transform import Rotation

    return _vec(Rotation.from_matrix(rotation).as_euler("xyz"))


def _origin(matrix) -> tuple[Vec3, Vec3]:
    if matrix is None:
        return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    m = np.asarray(matrix, dtype=float)
    return _vec(m[:3, 3]), _rpy(m[:3, :3])


def resolve_mesh(filename: str, urdf: Path) -> Path | None:
    """The mesh file a URDF names, or None if it is not found."""
    folder = urdf.parent
    if filename.startswith("file://"):
        candidates = [Path(filename[len("file://") :])]
    elif filename.startswith("package://"):
        package, _, rest = filename[len("package://") :].partition("/")
        ancestors = [folder, *folder.parents]
        candidates = [folder / package / rest]
        candidates += [a / rest for a in ancestors if a.name == package]
        candidates += [a / package / rest for a in ancestors[1:]]
        candidates.append(folder / rest)
    else:
        path = Path(filename)
        candidates = [path if path.is_absolute() else folder / path]
    return next((c.resolve() for c in candidates if c.is_file()), None)


def _shape(geometry, origin, urdf: Path, where: str) -> Shape:
    xyz, rpy = _origin(origin)
    if geometry.box is not None:
        half = _vec(np.asarray(geometry.box.size, dtype=float) / 2)
        return Box(xyz, half, rpy)
    if geometry.sphere is not None:
        return Sphere(xyz, float(geometry.sphere.radius), rpy)
    if geometry.cylinder is not None:
        return Cylinder(xyz, float(geometry.cylinder.radius), float(geometry.cylinder.length), rpy)
    if geometry.mesh is not None:
        name = geometry.mesh.filename
        path = resolve_mesh(name, urdf)
        if path is None:
            raise RobotError(f"{urdf}: {where}: mesh file {name!r} not found")
        scale = geometry.mesh.scale
        scale3 = (1.0, 1.0, 1.0) if scale is None else _vec(np.broadcast_to(np.asarray(scale, dtype=float), 3))
        return Mesh(str(path), scale3, xyz, rpy)
    raise RobotError(f"{urdf}: {where}: a collision element without a geometry simtune knows")


def _link(link, urdf: Path, material: str) -> Link:
    inertial = link.inertial
    if inertial is None or inertial.mass is None:
        mass, com, inertia_rpy = 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        moments = np.zeros((3, 3))
    else:
        mass = float(inertial.mass)
        com, inertia_rpy = _origin(inertial.origin)
        moments = np.asarray(inertial.inertia if inertial.inertia is not None else np.zeros((3, 3)), dtype=float)
    shapes = tuple(
        _shape(c.geometry, c.origin, urdf, f"link {link.name!r} collision {k + 1}")
        for k, c in enumerate(link.collisions)
    )
    return Link(
        name=link.name,
        mass=mass,
        com=com,
        inertia=(float(moments[0, 0]), float(moments[1, 1]), float(moments[2, 2])),
        shapes=shapes,
        material=material,
        products=(float(moments[0, 1]), float(moments[0, 2]), float(moments[1, 2])),
        inertia_rpy=inertia_rpy,
    )


def _held_position(joint, held: Mapping[str, float], positions: dict[str, float]) -> float:
    if joint.name in held:
        return float(held[joint.name])
    if joint.mimic is not None:
        multiplier = 1.0 if joint.mimic.multiplier is None else float(joint.mimic.multiplier)
        offset = 0.0 if joint.mimic.offset is None else float(joint.mimic.offset)
        return multiplier * positions.get(joint.mimic.joint, 0.0) + offset
    limit = joint.limit
    lower = -np.inf if limit is None or limit.lower is None else float(limit.lower)
    upper = np.inf if limit is None or limit.upper is None else float(limit.upper)
    return float(np.clip(0.0, lower, upper)) if joint.type != "continuous" else 0.0


def _joint(joint, driven: bool, position: float) -> Joint:
    xyz, rpy = _origin(joint.origin)
    axis = _vec(joint.axis) if joint.axis is not None else (1.0, 0.0, 0.0)  # URDF's default axis
    if joint.type == "fixed":
        return Joint(joint.name, "fixed", joint.parent, joint.child, xyz, rpy)
    if not driven:  # held at ``position``: a fixed joint at that pose
        turn = rpy_matrix(rpy)
        a = np.asarray(axis, dtype=float)
        if joint.type == "prismatic":
            xyz = _vec(np.asarray(xyz) + turn @ (a / np.linalg.norm(a) * position))
        else:
            rpy = _rpy(turn @ axis_angle_matrix(a, position))
        return Joint(joint.name, "fixed", joint.parent, joint.child, xyz, rpy)
    limit = joint.limit
    kind = joint.type
    lower = upper = None
    if kind == "revolute" and limit is not None and limit.lower is not None and limit.upper is not None:
        lower, upper = float(limit.lower), float(limit.upper)
    elif kind == "revolute":
        kind = "continuous"
    dynamics = joint.dynamics
    return Joint(
        joint.name,
        kind,
        joint.parent,
        joint.child,
        xyz,
        rpy,
        axis=axis,
        lower=lower,
        upper=upper,
        effort=None if limit is None or limit.effort is None else float(limit.effort),
        velocity=None if limit is None or limit.velocity is None else float(limit.velocity),
        damping=0.0 if dynamics is None or dynamics.damping is None else float(dynamics.damping),
    )


def _parse(path: Path):
    try:
        import yourdfpy
        from lxml import etree
    except ImportError:
        raise RobotError(f"{path}: reading a URDF needs yourdfpy: pip install 'simtune[urdf]'") from None

    if not path.is_file():
        raise RobotError(f"{path}: no such URDF file")
    try:  # strictly first: yourdfpy would recover from broken XML and read what is left
        etree.parse(str(path))
    except etree.XMLSyntaxError as exc:
        raise RobotError(f"{path} line {exc.lineno}: not valid XML ({exc.msg})") from None
    try:
        return yourdfpy.URDF.load(
            str(path),
            load_meshes=False,
            build_scene_graph=False,
            build_collision_scene_graph=False,
            load_collision_meshes=False,
        ).robot
    except (ValueError, KeyError, AttributeError, TypeError) as exc:
        raise RobotError(f"{path}: not a URDF simtune can read ({exc})") from None


def load_urdf(
    path: str | Path,
    *,
    arm_joints: Iterable[str] | None = None,
    tracked_link: str | None = None,
    base_position: Vec3 = (0.0, 0.0, 0.0),
    base_rpy: Vec3 = (0.0, 0.0, 0.0),
    held: Mapping[str, float] | None = None,
    gripper_links: Iterable[str] | None = None,
    name: str | None = None,
) -> RobotDescription:
    """The robot of the URDF at ``path``; ``RobotError`` (one line naming the file and element) if it
    cannot be used.

    ``arm_joints``: the driven joints in order (default: the revolute and continuous joints from the
    root to the tracked link); ``tracked_link``: the link the motion capture follows (default: where the root's
    chain first branches or ends); ``held``: positions of joints held at a fixed pose (default 0,
    clamped into the joint's limits); ``gripper_links``: the links with the gripper's contact
    parameters (default: the tracked link and every link below it).
    """
    path = Path(path).expanduser().resolve()
    robot = _parse(path)
    held = dict(held or {})
    joints_by_name = {j.name: j for j in robot.joints}
    link_names = [link.name for link in robot.links]
    for j in robot.joints:
        if j.type not in (*_MOVABLE, "fixed"):
            raise RobotError(
                f"{path}: joint {j.name!r}: type {j.type!r} is not supported (revolute, continuous, prismatic or fixed)"
            )
    children = {j.child for j in robot.joints}
    roots = [n for n in link_names if n not in children]
    if len(roots) != 1:
        raise RobotError(f"{path}: expected one root link, found {len(roots)} ({', '.join(roots[:3])})")
    below: dict[str, list] = {}
    for j in robot.joints:
        below.setdefault(j.parent, []).append(j)
    order: list = []  # joints, parents before children
    queue = [roots[0]]
    while queue:
        link = queue.pop(0)
        for j in below.get(link, []):
            order.append(j)
            queue.append(j.child)
    parent_joint = {j.child: j for j in order}

    def chain(link: str) -> list:
        out = []
        while link in parent_joint:
            out.append(parent_joint[link])
            link = parent_joint[link].parent
        return out[::-1]

    if tracked_link is None:
        tracked_link = roots[0]
        while len(below.get(tracked_link, [])) == 1:
            tracked_link = below[tracked_link][0].child
    elif tracked_link not in link_names:
        raise RobotError(f"{path}: tracked link {tracked_link!r} is not a link of the URDF")
    if arm_joints is None:
        driven = [j.name for j in chain(tracked_link) if j.type in ("revolute", "continuous")]
    else:
        driven = list(arm_joints)
    if not driven:
        raise RobotError(f"{path}: no movable joint to drive up to link {tracked_link!r}")
    for name_ in driven:
        j = joints_by_name.get(name_)
        if j is None:
            raise RobotError(f"{path}: joint {name_!r} is not a joint of the URDF")
        if j.type not in _MOVABLE:
            raise RobotError(f"{path}: joint {name_!r} is {j.type}: only movable joints can be driven")
        if j.mimic is not None:
            raise RobotError(
                f"{path}: joint {name_!r} mimics {j.mimic.joint!r}: mimic joints are not supported "
                "(drive the joint it follows, or hold both at a pose)"
            )
        if j.type == "prismatic":
            raise RobotError(f"{path}: joint {name_!r} is prismatic: simtune drives revolute joints only")
    if len(set(driven)) != len(driven):
        raise RobotError(f"{path}: a driven joint is named twice")
    for name_ in held:
        if name_ not in joints_by_name:
            raise RobotError(f"{path}: held joint {name_!r} is not a joint of the URDF")

    if gripper_links is None:
        gripper = {tracked_link}
        for j in order:
            if j.parent in gripper:
                gripper.add(j.child)
    else:
        gripper = set(gripper_links)
        for g in gripper:
            if g not in link_names:
                raise RobotError(f"{path}: gripper link {g!r} is not a link of the URDF")

    positions: dict[str, float] = {}
    held_at: list[tuple[str, float]] = []
    joints = []
    for j in order:
        is_driven = j.name in driven
        position = 0.0
        if j.type in _MOVABLE and not is_driven:
            position = _held_position(j, held, positions)
            positions[j.name] = position
            held_at.append((j.name, position))
        joints.append(_joint(j, is_driven, position))
    links_by_name = {link.name: link for link in robot.links}
    ordered_links = [roots[0], *(j.child for j in order)]
    links = tuple(_link(links_by_name[n], path, "gripper" if n in gripper else "arm") for n in ordered_links)
    description = RobotDescription(
        name=name or robot.name or path.stem,
        links=links,
        joints=tuple(joints),
        arm_joints=tuple(driven),
        tracked_link=tracked_link,
        base_position=_vec(base_position),
        base_rpy=_vec(base_rpy),
        held=tuple(held_at),
        source=str(path),
    )
    try:
        description.check()
    except ValueError as exc:
        raise RobotError(f"{path}: {exc}") from None
    return description
