"""A robot from an MJCF file (MuJoCo's format, as MuJoCo Menagerie and robosuite publish arms).

MuJoCo compiles the file (includes, defaults, mesh folders resolved its own way); the
description is read from the compiled model: one link per body below the world, its
inertia, the joint that moves it (a hinge or a slide at the body's origin; a body
without one is welded), and its collision geoms (those whose ``contype`` or ``conaffinity``
is set: a Menagerie file's visual class collides with nothing) as shapes: boxes, spheres and
cylinders as they are, a capsule as a cylinder and two spheres, a mesh or an ellipsoid as the
convex hull MuJoCo collides with (an OBJ in the mesh cache; :func:`~simtune.robot.meshes.hull_of_points`);
planes, height fields and SDFs are left out (a note says so).  The MuJoCo engine builds the
robot from the file itself (:attr:`RobotDescription.mjcf`), keeping its geoms; the other
engines build it from the URDF the description generates (docs/robots.md, "MJCF robots", says
what that leaves out: springs; the file's armature and friction loss are the description's joints' own, for the
engines that have those parameters and for MuJoCo's servo gains).

simtune owns the control and the contacts, so the file's actuators, sensors, tendons,
equality constraints, contact pairs and keyframes are dropped when the scene is built (a
warning names the equality constraints and tendons: they couple joints that then move on
their own), and joints that are not driven are removed (their bodies welded as drawn: a
gripper's fingers held at 0).  Driven joints default to the hinges from the root body
down to the tracked link, and the tracked link to where the root's chain first branches
or ends.

A joint's position is MuJoCo's ``qpos``: a hinge with a ``ref`` stands as drawn at ``qpos = ref``, so the
description's joint frame is the body's turned by ``-ref`` about the axis, and every engine puts the arm where
MuJoCo does at the same angles (its ranges and keyframes are in those coordinates too).  A NaN or an infinity in
a number of the robot's bodies, joints, geoms, inertials, meshes, defaults or keyframes is refused before MuJoCo
compiles the file (MuJoCo takes most of them, and a mass it replaces from the geometry).
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from simtune.common.geometry import rpy_matrix
from simtune.errors import RobotError, RobotWarning
from simtune.robot.description import Box as BoxShape
from simtune.robot.description import (
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

#: The keyframe whose driven joint positions ``simtune init`` takes as the example task's start pose.
HOME_KEYFRAME = "home"


def _vec(values) -> Vec3:
    x, y, z = (float(v) for v in values)
    return (x, y, z)


def _rpy(quat_wxyz) -> Vec3:
    from scipy.spatial.transform import Rotation

    w, x, y, z = (float(v) for v in quat_wxyz)
    with warnings.catch_warnings():  # a gimbal lock still gives a valid roll-pitch-yaw (the third angle 0)
        warnings.simplefilter("ignore")
        return _vec(Rotation.from_quat([x, y, z, w]).as_euler("xyz"))


def _matrix_rpy(matrix) -> Vec3:
    from scipy.spatial.transform import Rotation

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return _vec(Rotation.from_matrix(np.asarray(matrix, dtype=float)).as_euler("xyz"))


#: The MJCF elements whose numbers make the robot simtune reads (in the file and in its default classes): its
#: bodies and their placement, joints, geoms, inertials, meshes, keyframes and the compiler's mass settings.  The
#: actuators, sensors, tendons and equality constraints are dropped, so their numbers are not checked.
CHECKED_ELEMENTS = frozenset({"body", "frame", "joint", "freejoint", "geom", "inertial", "mesh", "key", "compiler"})
#: Attributes that hold names or paths (a body may be called "inf"): never read as numbers.
NAME_ATTRIBUTES = frozenset(
    {
        "name", "class", "childclass", "file", "mesh", "material", "texture", "hfield", "joint", "body", "site",
        "target", "prefix", "meshdir", "texturedir", "assetdir", "content_type",
    }
)  # fmt: skip
#: What the refusal of an attribute adds, where the usual intent is known.
NON_FINITE_HINTS = {
    "range": ' (for an unlimited joint leave range out, or write limited="false")',
    "mass": " (a mass in kg, above 0)",
}


def _non_finite(value: str) -> bool:
    """Whether ``value`` is a list of numbers of which one is a NaN or an infinity (a value that is not all
    numbers, a name, is not)."""
    try:
        numbers = [float(token) for token in value.split()]
    except ValueError:
        return False
    return any(not np.isfinite(number) for number in numbers)


def _element_words(element) -> str:
    """``<joint name='j2'>``, or for an unnamed element where it is: ``<geom> of body 'link3'``, ``<joint> of
    default class 'arm'``."""
    name = element.get("name")
    if name is not None:
        return f"<{element.tag} name={name!r}>"
    parent = element.getparent()
    while parent is not None and parent.get("name") is None and parent.tag != "default":
        parent = parent.getparent()
    if parent is None:
        return f"<{element.tag}>"
    if parent.tag == "default":  # the top <default> is MuJoCo's class "main"
        return f"<{element.tag}> of default class {parent.get('class', 'main')!r}"
    return f"<{element.tag}> of {parent.tag} {parent.get('name')!r}"


def _refuse_non_finite(path: Path, main_folder: Path, seen: set[Path] | None = None) -> None:
    """Refuse the MJCF at ``path`` (and the files it includes) where a number of :data:`CHECKED_ELEMENTS` is a NaN
    or an infinity: one line naming the file, its line, the element and the attribute.  A file that does not
    parse, or an include that is not found, is left to MuJoCo's compiler to name."""
    from lxml import etree

    seen = set() if seen is None else seen
    if path in seen:
        return
    seen.add(path)
    try:
        root = etree.parse(str(path), etree.XMLParser(resolve_entities=False, no_network=True)).getroot()
    except (OSError, etree.XMLSyntaxError):
        return
    for element in root.iter():
        if not isinstance(element.tag, str):
            continue  # a comment or a processing instruction
        if element.tag == "include" and element.get("file"):
            # MuJoCo resolves an include against the main file's folder (a nested one, in some versions, its own)
            for folder in (path.parent, main_folder):
                included = (folder / element.get("file")).resolve()
                if included.is_file():
                    _refuse_non_finite(included, main_folder, seen)
                    break
            continue
        if element.tag not in CHECKED_ELEMENTS:
            continue
        for attribute, value in element.attrib.items():
            if attribute not in NAME_ATTRIBUTES and _non_finite(value):
                raise RobotError(
                    f"{path} line {element.sourceline}: {_element_words(element)} {attribute}={value!r} is not a "
                    f"finite number{NON_FINITE_HINTS.get(attribute, ' (a NaN or an infinity)')}"
                )


def _compile(path: Path):
    """MuJoCo's model of the MJCF at ``path``, its numbers checked first (:func:`_refuse_non_finite`)."""
    try:
        import mujoco
    except ImportError:  # pragma: no cover - mujoco is a core dependency
        raise RobotError(f"{path}: reading an MJCF needs mujoco") from None
    path = Path(path).expanduser().resolve()
    if not path.is_file():
        raise RobotError(f"{path}: no such MJCF file")
    _refuse_non_finite(path, path.parent)
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


def _collides(model, b: int) -> bool:
    """Whether body ``b`` has a collision geom (contype or conaffinity set)."""
    mine = model.geom_bodyid == b
    return bool(np.any(mine & ((model.geom_contype != 0) | (model.geom_conaffinity != 0))))


def _gripper(model, path: Path, tracked_link: str, order: list[int], ids: dict[str, int], gripper_links) -> set[str]:
    """The gripper's links: ``gripper_links``, or by default the tracked link and every body below it, and where
    none of them has a collision geom, the links above it up to the first that has one."""
    if gripper_links is None:
        gripper = {tracked_link}
        for b in order:
            if model.body(int(model.body(b).parentid[0])).name in gripper:
                gripper.add(model.body(b).name)
        carrier = ids[tracked_link]
        while not any(_collides(model, ids[g]) for g in gripper) and int(model.body(carrier).parentid[0]) != 0:
            # no collision geom at the hand (an arm published without its gripper): the link that carries it
            carrier = int(model.body(carrier).parentid[0])
            gripper.add(model.body(carrier).name)
        return gripper
    gripper = set(gripper_links)
    for g in gripper:
        if g not in ids:
            raise RobotError(f"{path}: gripper link {g!r} is not a body of the MJCF")
    return gripper


def _ellipsoid_points(radii) -> np.ndarray:
    """Points on the ellipsoid of semi-axes ``radii``: its hull stands for it (MuJoCo's own ellipsoid is smooth)."""
    polar, azimuth = np.meshgrid(np.linspace(0.0, np.pi, 9), np.linspace(0.0, 2 * np.pi, 16, endpoint=False))
    unit = np.stack([np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth), np.cos(polar)], axis=-1)
    return np.unique(np.round(unit.reshape(-1, 3), 12), axis=0) * np.asarray(radii, dtype=float)


def _geom_shapes(model, g: int, notes: list[str]) -> list[Shape]:
    """The shapes standing for collision geom ``g`` in its body's frame (none for a plane, height field or SDF)."""
    import mujoco

    from simtune.robot.meshes import hull_of_points

    kind = mujoco.mjtGeom(int(model.geom_type[g]))
    size = model.geom_size[g]
    centre, rpy = _vec(model.geom_pos[g]), _rpy(model.geom_quat[g])
    name = model.geom(g).name or f"geom {g}"
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        return [BoxShape(centre, _vec(size), rpy)]
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return [Sphere(centre, float(size[0]), rpy)]
    if kind in (mujoco.mjtGeom.mjGEOM_CYLINDER, mujoco.mjtGeom.mjGEOM_CAPSULE):
        shapes: list[Shape] = [Cylinder(centre, float(size[0]), 2 * float(size[1]), rpy)]
        if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:  # a capsule: the cylinder and a sphere on each end
            axis = rpy_matrix(rpy)[:, 2] * float(size[1])
            shapes += [Sphere(_vec(np.asarray(centre) + sign * axis), float(size[0])) for sign in (1, -1)]
        return shapes
    if kind == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
        return [Mesh(str(hull_of_points(_ellipsoid_points(size), f"{name}-ellipsoid")), center=centre, rpy=rpy)]
    if kind == mujoco.mjtGeom.mjGEOM_MESH:
        mesh = int(model.geom_dataid[g])
        first, count = int(model.mesh_vertadr[mesh]), int(model.mesh_vertnum[mesh])
        points = model.mesh_vert[first : first + count]
        return [Mesh(str(hull_of_points(points, model.mesh(mesh).name or name)), center=centre, rpy=rpy)]
    notes.append(f"{name}: a {kind.name[7:].lower()} geom, left out of the URDF the engines other than MuJoCo read")
    return []


def _body_shapes(model, b: int, notes: list[str]) -> tuple[Shape, ...]:
    """The shapes of body ``b``'s collision geoms: those that collide with something (contype or conaffinity)."""
    shapes: list[Shape] = []
    for g in range(model.ngeom):
        if int(model.geom_bodyid[g]) == b and (model.geom_contype[g] or model.geom_conaffinity[g]):
            shapes += _geom_shapes(model, g, notes)
    return tuple(shapes)


def _link(model, b: int, gripper: set[str], notes: list[str]) -> Link:
    body = model.body(b)
    return Link(
        name=body.name,
        mass=float(body.mass[0]),
        com=_vec(body.ipos),
        inertia=_vec(body.inertia),
        shapes=_body_shapes(model, b, notes),
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
            if jid is not None:  # welded as drawn: at qpos = ref, where MuJoCo's scene, its joint removed, has it
                held.append((model.joint(jid).name, float(model.qpos0[int(model.jnt_qposadr[jid])])))
            weld = f"{body.name}_weld" if jid is None else model.joint(jid).name
            joints.append(Joint(weld, "fixed", parent, body.name, xyz, rpy))
            continue
        jnt = model.joint(jid)
        limited = bool(jnt.limited[0])
        ref = float(model.qpos0[int(jnt.qposadr[0])])  # a driven joint is a hinge: its ref [rad]
        if ref != 0.0:  # the body stands as drawn at qpos = ref: at qpos = 0 it is turned by -ref about the axis
            turned = rpy_matrix(rpy) @ axis_angle_matrix(np.asarray(jnt.axis, dtype=float), -ref)
            rpy = _matrix_rpy(turned)
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
                friction=float(model.dof_frictionloss[int(jnt.dofadr[0])]),
                armature=float(model.dof_armature[int(jnt.dofadr[0])]),
            )
        )
    return joints, held


def _warn_dropped_couplings(model, path: Path) -> None:
    """One :class:`RobotWarning` naming the file's equality constraints and tendons (with the actuators on them):
    the scene drops them, so the joints they couple move on their own in every engine."""
    import mujoco

    def joint_name(j: int) -> str:
        return repr(model.joint(j).name or f"joint {j}")

    dropped = []
    for e in range(model.neq):
        kind = mujoco.mjtEq(int(model.eq_type[e])).name[5:].lower()
        what = f"equality <{kind}>" + (f" {model.eq(e).name!r}" if model.eq(e).name else "")
        if kind == "joint":
            second = int(model.eq_obj2id[e])
            what += f" coupling {joint_name(int(model.eq_obj1id[e]))}" + (
                f" to {joint_name(second)}" if second >= 0 else " to a constant"
            )
        dropped.append(what)
    tendon_actuators = [a for a in range(model.nu) if int(model.actuator_trntype[a]) == int(mujoco.mjtTrn.mjTRN_TENDON)]
    for t in range(model.ntendon):
        first, count = int(model.tendon_adr[t]), int(model.tendon_num[t])
        joints = [
            joint_name(int(model.wrap_objid[w]))
            for w in range(first, first + count)
            if int(model.wrap_type[w]) == int(mujoco.mjtWrap.mjWRAP_JOINT)
        ]
        what = f"tendon {model.tendon(t).name or t!r}" + (f" on joints {', '.join(joints)}" if joints else "")
        on_it = [
            repr(model.actuator(a).name or f"actuator {a}")
            for a in tendon_actuators
            if int(model.actuator_trnid[a, 0]) == t
        ]
        if on_it:
            what += f" with its actuator{'s' if len(on_it) > 1 else ''} {', '.join(on_it)}"
        dropped.append(what)
    if dropped:
        warnings.warn(
            f"{path}: {'; '.join(dropped)}: dropped (simtune drives each joint with its own servo), so the joints "
            "they couple move on their own in every engine",
            RobotWarning,
            stacklevel=4,
        )


def _hinges_below(model, children: dict[int, list[int]], moving: dict[int, int]) -> dict[int, int]:
    """Body -> the number of hinge joints in its subtree (itself included)."""
    counts: dict[int, int] = {}

    def count(b: int) -> int:
        if b not in counts:
            own = int(b in moving and int(model.jnt_type[moving[b]]) == _hinge())
            counts[b] = own + sum(count(c) for c in children.get(b, []))
        return counts[b]

    for b in range(model.nbody):
        count(b)
    return counts


def _default_tracked(model, root: int, children: dict[int, list[int]], moving: dict[int, int], notes: list[str]):
    """The tracked body by default: down from the root while one child holds more hinges below it than every
    other (an arm's chain past a head or a camera mount); where the children tie (a gripper's fingers) or none
    is left, there."""
    hinges = _hinges_below(model, children, moving)
    tracked = root
    passed: list[str] = []
    while children.get(tracked):
        ranked = sorted(children[tracked], key=lambda c: hinges[c], reverse=True)
        if len(ranked) > 1 and hinges[ranked[0]] == hinges[ranked[1]]:
            break
        passed += [model.body(c).name for c in ranked[1:]]
        tracked = ranked[0]
    if passed:
        notes.append(f"the arm's chain goes past side bodies with fewer joints below: {', '.join(passed)}")
    return tracked


def _base(model, root, base_position: Vec3, base_rpy: Vec3) -> tuple[Vec3, Vec3]:
    """The root body's place in the world: its place in the file, moved by ``base_position``/``base_rpy``."""
    turn = rpy_matrix(base_rpy)
    file_turn = rpy_matrix(_rpy(root.quat))
    position = np.asarray(base_position, dtype=float) + turn @ np.asarray(root.pos, dtype=float)
    return _vec(position), _matrix_rpy(turn @ file_turn)


def home_pose(path: str | Path, joints: Iterable[str]) -> list[float] | None:
    """The positions [rad or m] of ``joints`` in the MJCF's ``home`` keyframe (Menagerie's start pose).

    Args:
        path: the MJCF file.
        joints: joint names of the file.

    Returns:
        One position per joint, or None where the file has no keyframe named ``home``.
    """
    model = _compile(Path(path))
    names = [model.key(k).name for k in range(model.nkey)]
    if HOME_KEYFRAME not in names:
        return None
    qpos = model.key_qpos[names.index(HOME_KEYFRAME)]
    return [float(qpos[int(model.jnt_qposadr[model.joint(j).id])]) for j in joints]


def load_mjcf(
    path: str | Path,
    *,
    arm_joints: Iterable[str] | None = None,
    tracked_link: str | None = None,
    gripper_links: Iterable[str] | None = None,
    name: str | None = None,
    base_position: Vec3 = (0.0, 0.0, 0.0),
    base_rpy: Vec3 = (0.0, 0.0, 0.0),
) -> RobotDescription:
    """The robot of the MJCF at ``path`` (one robot: one body tree below the world).

    Args:
        path: the MJCF file (its ``<include>``s, ``meshdir`` and default classes are MuJoCo's to resolve).
        arm_joints: the driven joints in order (default: the hinges from the root body to the tracked link).
        tracked_link: the body the motion capture follows (default: down the chain with the most hinges below
            it, to where it ends or splits evenly, as at a gripper's fingers).
        gripper_links: the bodies with the gripper's contact parameters (default: the tracked body and below).
        name: the robot's name (default: the model's, else the file's stem).
        base_position: added to the root body's position in the file [m].
        base_rpy: turns the root body's placement in the file [rad].

    Returns:
        The description; :attr:`RobotDescription.choices` says what was chosen and why.

    Raises:
        RobotError: one line naming the file and element, if the file cannot be used.
    """
    model = _compile(Path(path))
    path = Path(path).expanduser().resolve()
    for what, values in (("base_position", base_position), ("base_rpy", base_rpy)):
        if not np.all(np.isfinite(np.asarray(values, dtype=float))):
            raise RobotError(f"{path}: {what} {tuple(values)} is not finite")
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
    notes: list[str] = []
    if tracked_link is None:
        tracked_link = model.body(_default_tracked(model, root.id, children, moving, notes)).name
        notes.append(f"tracked link {tracked_link!r}: where the arm's chain ends or splits evenly")
    elif tracked_link not in ids:
        raise RobotError(f"{path}: tracked link {tracked_link!r} is not a body of the MJCF")
    driven = _driven(model, path, root.id, ids[tracked_link], moving, arm_joints)
    gripper = _gripper(model, path, tracked_link, order, ids, gripper_links)
    if gripper_links is None:
        notes.append(f"gripper links (the gripper's contact parameters): {', '.join(sorted(gripper))}")
    joints, held = _joints(model, order, moving, driven)
    if held and all(position == 0.0 for _, position in held):
        notes.append(f"joints not driven, welded at 0: {', '.join(j for j, _ in held)}")
    elif held:
        welded = ", ".join(j if position == 0.0 else f"{j} (at its ref {position:g})" for j, position in held)
        notes.append(f"joints not driven, welded as drawn: {welded}")
    _warn_dropped_couplings(model, path)
    position, rpy = _base(model, root, _vec(base_position), _vec(base_rpy))
    links = (_link(model, root.id, gripper, notes), *(_link(model, b, gripper, notes) for b in order))
    description = RobotDescription(
        name=name or model.names[: model.names.index(b"\0")].decode() or path.stem,
        links=links,
        joints=tuple(joints),
        arm_joints=tuple(driven),
        tracked_link=tracked_link,
        base_position=position,
        base_rpy=rpy,
        held=tuple(held),
        source=str(path),
        mjcf=str(path),
        choices=tuple(notes),
    )
    try:
        description.check()
    except ValueError as exc:
        raise RobotError(f"{path}: {exc}") from None
    return description
