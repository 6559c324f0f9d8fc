"""A robot from a URDF file: parsed with ``yourdfpy``, turned into a :class:`RobotDescription`.

Published descriptions are read as the engines read them:

- A root link named ``world`` is the world frame, not a body: it is dropped and the fixed joint
  from it places the robot's base (added to the caller's ``base_position``/``base_rpy``).  Of several
  roots (or of several arms fixed to ``world``), the tree with the most movable joints is the robot,
  the others are left out with a warning.
- The tracked link is the end of the longest chain of arm joints from the root (followed on through
  fixed joints while they do not branch), so a base with a sensor or flange link on its own branch
  (most ROS arms, the ROS-Industrial UR layout) finds the arm's chain, not the first branch.
  Gripper joints (a mimic joint, a prismatic joint, a joint named like a gripper, finger or jaw) are
  held, not driven; :func:`arm_choice` says what was chosen and why.
- Mesh file names may be relative to the URDF's folder, ``file://`` or ``package://NAME/...``: NAME is
  looked for in ``package_path`` and the folders of ``$SIMTUNE_PACKAGE_PATH`` and
  ``$ROS_PACKAGE_PATH`` (each a package folder, or a folder holding packages, or ``NAME=DIR``: package
  NAME is folder DIR, whatever DIR is called), then beside the URDF and in its parent folders
  (pybullet_data's models use it so).  Every mesh becomes an OBJ file every engine reads
  (:mod:`simtune.robot.meshes`).  Collision elements are kept, visual ones ignored, except in a
  visual-only description (no ``<collision>`` in the robot at all), where each link's visual geometry
  stands in for its collision shapes, with a note naming the links.
- A link without an ``<inertial>`` gets the mass and inertia of its collision geometry (else its visual
  geometry) taken as a solid of ``density`` (aluminium's by default; or ``total_mass`` spread over such
  links by volume), as MuJoCo's ``inertiafromgeom`` does (:mod:`simtune.robot.inertia`), with a note naming
  the links and how; :attr:`RobotDescription.estimated_masses` names them.
- Undeclared namespace prefixes (``drake:`` attributes in some UR descriptions) are declared with a
  warning, as the engines' own parsers tolerate them.
- Physically impossible values stop at load with one line naming the URDF, the link or joint and the
  value: a mass that is negative or not finite, an inertia that is not positive semi-definite, a zero
  axis on a movable joint, a lower limit above the upper one, a negative effort, velocity or damping, a
  box, sphere or cylinder size that is not above 0, a mesh scale of 0.  A body that moves but has no mass
  and no geometry to estimate one from gets a placeholder, :data:`FLOOR_MASS`, with a warning, since no
  engine simulates a massless moving body (:attr:`RobotDescription.placeholder_masses` names its links).
- So do files the engines would crash or hang on: a number that is not finite (``inf``, ``nan``) or not a
  number in any origin, axis, limit, dynamics, mimic, mass, inertia or geometry attribute of a link or
  joint; a link or joint without a name or with another's name; a joint naming a link the file lacks; links
  that do not form a tree (a link with two parents, a joint from a link to itself, a loop).  Each is one
  line naming the URDF (and the line, where the XML says it), the link or joint and the attribute.

Movable joints that are not driven are held at a fixed pose: at the position the caller gives, else at
0 clamped into its limits, a mimic joint at its multiplier and offset from the joint it follows.  A
driven joint may not be a mimic joint (simtune has no coupled joints).
"""

from __future__ import annotations

import io
import math
import os
import re
import warnings
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from simtune.common.geometry import rpy_matrix
from simtune.errors import RobotError, RobotWarning
from simtune.robot.description import (
    ZERO3,
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
from simtune.robot.inertia import DEFAULT_DENSITY, Solid, solid_of, with_solid_mass
from simtune.robot.meshes import engine_mesh, mesh_extent

_MOVABLE = ("revolute", "continuous", "prismatic")


def _vec(values) -> Vec3:
    x, y, z = (float(v) for v in values)
    return (x, y, z)


def _rpy(rotation: np.ndarray) -> Vec3:
    """URDF roll-pitch-yaw of a rotation matrix (R = Rz(yaw) Ry(pitch) Rx(roll): SciPy's extrinsic xyz)."""
    from scipy.spatial.transform import Rotation

    with warnings.catch_warnings():  # at pitch +-90 deg ("gimbal lock") the angles SciPy picks still make R
        warnings.simplefilter("ignore", UserWarning)
        return _vec(Rotation.from_matrix(rotation).as_euler("xyz"))


def _origin(matrix) -> tuple[Vec3, Vec3]:
    if matrix is None:
        return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    m = np.asarray(matrix, dtype=float)
    return _vec(m[:3, 3]), _rpy(m[:3, :3])


#: ``NAME=DIR`` in a package path: package NAME is folder DIR (a name holds no path separator).
_NAMED_PACKAGE = re.compile(r"^([A-Za-z0-9_.\-]+)=(.+)$")


def package_entry(entry: str | Path) -> tuple[str | None, Path]:
    """One entry of a package path: ``NAME=DIR`` maps package NAME to folder DIR (for ``package://NAME/...``
    where the folder has another name, as xacro-converted descriptions' ``..._support`` packages do); anything
    else is a folder (a package folder, or a folder of packages).

    Args:
        entry: the entry as written (``--package-path``, ``[robot] package_path``, an environment variable).

    Returns:
        (the package name, or None for a plain folder; the folder, ``~`` expanded).
    """
    match = _NAMED_PACKAGE.match(str(entry))
    if match is None:
        return None, Path(entry).expanduser()
    return match.group(1), Path(match.group(2)).expanduser()


def package_folders(extra: Iterable[str | Path] = ()) -> list[Path]:
    """Folders to look for ``package://`` packages in: ``extra``, then ``$SIMTUNE_PACKAGE_PATH`` and
    ``$ROS_PACKAGE_PATH`` (``os.pathsep``-separated, as ROS writes it); ``NAME=DIR`` entries are left out
    (:func:`named_packages`)."""
    return [folder for name, folder in _package_entries(extra) if name is None]


def named_packages(extra: Iterable[str | Path] = ()) -> dict[str, Path]:
    """The ``NAME=DIR`` entries of ``extra``, ``$SIMTUNE_PACKAGE_PATH`` and ``$ROS_PACKAGE_PATH``: package
    name -> its folder (the first entry for a name wins)."""
    named: dict[str, Path] = {}
    for name, folder in _package_entries(extra):
        if name is not None:
            named.setdefault(name, folder)
    return named


def _package_entries(extra: Iterable[str | Path]) -> list[tuple[str | None, Path]]:
    entries = [package_entry(f) for f in extra]
    for variable in ("SIMTUNE_PACKAGE_PATH", "ROS_PACKAGE_PATH"):
        entries += [package_entry(f) for f in os.environ.get(variable, "").split(os.pathsep) if f]
    return entries


def resolve_mesh(filename: str, urdf: Path, package_path: Iterable[str | Path] = ()) -> Path | None:
    """The mesh file a URDF names, or None if it is not found."""
    folder = urdf.parent
    if filename.startswith("file://"):
        candidates = [Path(filename[len("file://") :])]
    elif filename.startswith("package://"):
        package, _, rest = filename[len("package://") :].partition("/")
        named = named_packages(package_path)
        candidates = [named[package] / rest] if package in named else []
        for root in package_folders(package_path):  # a package folder itself, or a folder of packages
            candidates += [root / rest] if root.name == package else [root / package / rest]
        ancestors = [folder, *folder.parents]
        candidates.append(folder / package / rest)
        candidates += [a / rest for a in ancestors if a.name == package]
        candidates += [a / package / rest for a in ancestors[1:]]
        candidates.append(folder / rest)
    else:
        path = Path(filename)
        candidates = [path if path.is_absolute() else folder / path]
    return next((c.resolve() for c in candidates if c.is_file()), None)


def _shape(geometry, origin, urdf: Path, where: str, package_path: Iterable[str | Path]) -> Shape:
    xyz, rpy = _origin(origin)
    if geometry.box is not None:
        size = _sizes(np.asarray(geometry.box.size, dtype=float), urdf, where, "box size")
        return Box(xyz, _vec(size / 2), rpy)
    if geometry.sphere is not None:
        (radius,) = _sizes(np.array([geometry.sphere.radius], dtype=float), urdf, where, "sphere radius")
        return Sphere(xyz, float(radius), rpy)
    if geometry.cylinder is not None:
        (radius,) = _sizes(np.array([geometry.cylinder.radius], dtype=float), urdf, where, "cylinder radius")
        (length,) = _sizes(np.array([geometry.cylinder.length], dtype=float), urdf, where, "cylinder length")
        return Cylinder(xyz, float(radius), float(length), rpy)
    if geometry.mesh is not None:
        name = geometry.mesh.filename
        path = resolve_mesh(name, urdf, package_path)
        if path is None:
            package = name[len("package://") :].partition("/")[0] if name.startswith("package://") else "NAME"
            hint = (
                " (set --package-path or SIMTUNE_PACKAGE_PATH to the folder of its package, or "
                f"--package-path {package}=DIR where its folder DIR has another name)"
            )
            raise RobotError(f"{urdf}: {where}: mesh file {name!r} not found{hint if '://' in name else ''}")
        path = engine_mesh(path, f"{urdf}: {where}")
        scale = geometry.mesh.scale
        scale3 = (1.0, 1.0, 1.0) if scale is None else _vec(np.broadcast_to(np.asarray(scale, dtype=float), 3))
        if 0.0 in scale3:  # flat: MuJoCo, ODE and Drake refuse it (a negative scale mirrors: all read it)
            raise RobotError(f"{urdf}: {where}: mesh scale {scale3} flattens the mesh (no scale may be 0)")
        return Mesh(str(path), scale3, xyz, rpy)
    raise RobotError(f"{urdf}: {where}: an element without a geometry simtune knows")


def _sizes(values: np.ndarray, urdf: Path, where: str, field_: str) -> np.ndarray:
    """``values`` if every one is above 0; else one line naming the field.  A negative box side makes ODE
    abort the process; a zero box or cylinder side makes Drake do so, and MuJoCo refuses any zero size."""
    if np.any(values <= 0):
        shown = f"{float(values[0]):g}" if values.size == 1 else str(_vec(values))
        raise RobotError(f"{urdf}: {where}: {field_} {shown} is not possible (a size is > 0)")
    return values


#: The mass [kg] and inertia [kg m^2] of a moving body the URDF gives no mass: light enough to change
#: no motion of an arm, heavy enough for every engine (MuJoCo, DART and ODE refuse a massless moving body).
FLOOR_MASS = 1e-3
FLOOR_INERTIA = 1e-6


def _inertia_problem(moments: np.ndarray) -> str:
    """Why a 3x3 inertia about the centre of mass is impossible, or ''."""
    if not np.all(np.isfinite(moments)):
        return "is not finite"
    eigen = np.linalg.eigvalsh((moments + moments.T) / 2)
    scale = max(float(np.abs(eigen).max()), 1e-12)
    if eigen.min() < -1e-9 * scale:
        return f"is not positive semi-definite (principal moments {', '.join(f'{e:.4g}' for e in eigen)})"
    return ""


def _shapes(link, urdf: Path, kind: str, package_path: Iterable[str | Path]) -> tuple[Shape, ...]:
    """The shapes of a URDF link's ``kind`` elements (``collision`` or ``visual``), in its frame."""
    elements = link.collisions if kind == "collision" else link.visuals
    return tuple(
        _shape(e.geometry, e.origin, urdf, f"link {link.name!r} {kind} {k + 1}", package_path)
        for k, e in enumerate(elements)
    )


def _link(link, urdf: Path, material: str, package_path: Iterable[str | Path], kind: str = "collision") -> Link:
    """The link with its inertial as given (none: no mass) and the shapes of its ``kind`` elements."""
    inertial = link.inertial
    if inertial is None or inertial.mass is None:
        mass, com, inertia_rpy = 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        moments = np.zeros((3, 3))
    else:
        mass = float(inertial.mass)
        if not math.isfinite(mass) or mass < 0:
            raise RobotError(f"{urdf}: link {link.name!r}: mass {mass:g} kg is not possible (a mass is >= 0)")
        com, inertia_rpy = _origin(inertial.origin)
        moments = np.asarray(inertial.inertia if inertial.inertia is not None else np.zeros((3, 3)), dtype=float)
        problem = _inertia_problem(moments)
        if problem:
            raise RobotError(f"{urdf}: link {link.name!r}: its inertia {problem}")
    shapes = _shapes(link, urdf, kind, package_path)
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
        # 0 is ROS-Industrial's "not given": read as not given, so that every engine applies the same generic
        # limit (an engine that took it as "no torque" and one that took it as "no limit" disagreed)
        effort=None if limit is None or not limit.effort else float(limit.effort),
        velocity=None if limit is None or not limit.velocity else float(limit.velocity),
        damping=0.0 if dynamics is None or dynamics.damping is None else float(dynamics.damping),
        # Coulomb friction: the generic value of friction_joint_<n>; a negative one is no friction
        friction=0.0 if dynamics is None or not dynamics.friction else max(0.0, float(dynamics.friction)),
    )


_GRIPPER_NAME = re.compile(r"grip|finger|jaw|claw", re.IGNORECASE)
_UNDECLARED = re.compile(r"Namespace prefix (\S+) (?:for \S+ )?on \S+ is not defined")


def _parse(path: Path):
    try:
        import yourdfpy
        from lxml import etree
    except ImportError:
        raise RobotError(f"{path}: reading a URDF needs yourdfpy: pip install 'simtune[urdf]'") from None

    if not path.is_file():
        raise RobotError(f"{path}: no such URDF file")
    text = path.read_bytes()
    try:  # strictly first: yourdfpy would recover from broken XML and read what is left
        root = etree.fromstring(text)
    except etree.XMLSyntaxError as exc:
        prefixes = sorted({m.group(1) for e in exc.error_log if (m := _UNDECLARED.search(e.message or ""))})
        if not prefixes:
            raise RobotError(f"{path} line {exc.lineno}: not valid XML ({exc.msg})") from None
        # undeclared prefixes (`drake:` attributes of some UR descriptions): the engines' parsers read past
        # them, so declare them and read on
        declarations = "".join(f' xmlns:{p}="urn:simtune:undeclared:{p}"' for p in prefixes)
        text = re.sub(rb"<robot\b", b"<robot" + declarations.encode(), text, count=1)
        warnings.warn(
            f"{path}: namespace prefix {', '.join(prefixes)} used without a declaration: read as declared",
            RobotWarning,
            stacklevel=3,
        )
        try:
            root = etree.fromstring(text)
        except etree.XMLSyntaxError as again:
            raise RobotError(f"{path} line {again.lineno}: not valid XML ({again.msg})") from None
    if root.tag != "robot":
        raise RobotError(f"{path}: not a URDF: its root element is <{root.tag}>, a URDF's is <robot>")
    _check_names(root, path)
    _check_numbers(root, path)
    try:
        return yourdfpy.URDF.load(
            io.BytesIO(text),
            load_meshes=False,
            build_scene_graph=False,
            build_collision_scene_graph=False,
            load_collision_meshes=False,
        ).robot
    except (ValueError, KeyError, AttributeError, TypeError) as exc:
        raise RobotError(f"{path}: not a URDF simtune can read ({type(exc).__name__}: {exc})") from None


def _check_names(root, path: Path) -> None:
    """One line for a ``<link>`` or ``<joint>`` without a name, or with the name of another of its kind: the
    engines address links and joints by name (PyBullet crashes on a joint name used twice or empty)."""
    for kind in ("link", "joint"):
        lines: dict[str, list[int | None]] = {}
        for element in root.findall(kind):
            name = element.get("name")
            if not name:
                what = "an empty name" if name is not None else "no name"
                raise RobotError(f"{path} line {element.sourceline}: a <{kind}> has {what}: every {kind} needs its own")
            lines.setdefault(name, []).append(element.sourceline)
        for name, where in lines.items():
            if len(where) > 1:
                times = "twice" if len(where) == 2 else f"{len(where)} times"
                again = f", again on lines {', '.join(map(str, where[1:]))}" if len(where) > 2 else ""
                raise RobotError(
                    f"{path} line {where[1]}: {kind} {name!r} is defined {times} (first on line {where[0]}{again}): "
                    f"{kind} names must be unique"
                )


#: The numeric attributes of a link's or joint's elements that the URDF reader parses, with how many numbers
#: each holds (0: a mesh's scale, one or three, or none for the default).  Each is checked before the reader
#: parses it: the reader turns an infinite origin into NaN (losing what was written, with NumPy warnings) and
#: a NaN into a ``LinAlgError`` deep in the loader.
_NUMBERS: dict[str, dict[str, int]] = {
    "origin": {"xyz": 3, "rpy": 3},
    "axis": {"xyz": 3},
    "limit": {"lower": 1, "upper": 1, "effort": 1, "velocity": 1},
    "dynamics": {"damping": 1, "friction": 1},
    "mimic": {"multiplier": 1, "offset": 1},
    "safety_controller": {"soft_lower_limit": 1, "soft_upper_limit": 1, "k_position": 1, "k_velocity": 1},
    "calibration": {"rising": 1, "falling": 1},
    "mass": {"value": 1},
    "inertia": {"ixx": 1, "ixy": 1, "ixz": 1, "iyy": 1, "iyz": 1, "izz": 1},
    "box": {"size": 3},
    "sphere": {"radius": 1},
    "cylinder": {"radius": 1, "length": 1},
    "mesh": {"scale": 0},
}


def _part(owner, element) -> str:
    """Where ``element`` sits in link or joint ``owner``: ``link 'a' collision 2``, ``link 'a' inertial``, or the
    owner alone for a joint's own elements."""
    where = f"{owner.tag} {owner.get('name')!r}"
    part = element
    while part.getparent() is not owner:
        part = part.getparent()
    if part.tag in ("collision", "visual"):
        return f"{where} {part.tag} {owner.findall(part.tag).index(part) + 1}"
    return f"{where} {part.tag}" if part.tag == "inertial" else where


def _check_numbers(root, path: Path) -> None:
    """One line, naming the URDF's line, the link or joint and the attribute, for a numeric attribute (of
    :data:`_NUMBERS`) that is not a number, has too few or too many numbers, or is not finite."""
    for owner in (*root.findall("link"), *root.findall("joint")):
        for element in owner.iter():
            attributes = _NUMBERS.get(element.tag) if element is not owner else None
            for attribute, count in (attributes or {}).items():
                text = element.get(attribute)
                if text is None:
                    continue
                # the reader splits box sizes and mesh scales at commas too
                words = text.replace(",", " ").split() if element.tag in ("box", "mesh") else text.split()
                field_ = "mass" if element.tag == "mass" else f"{element.tag} {attribute}"
                where = f"{path} line {element.sourceline}: {_part(owner, element)}: {field_}"
                if len(words) not in ((0, 1, 3) if count == 0 else (count,)):
                    expected = "1 or 3 numbers" if count == 0 else f"{count} number{'s' if count > 1 else ''}"
                    raise RobotError(f"{where} {text.strip()!r} is not {expected}")
                try:
                    values = [float(w) for w in words]
                except ValueError:
                    raise RobotError(f"{where} {text.strip()!r} is not a number") from None
                if not all(math.isfinite(v) for v in values):
                    shown = words[0] if len(words) == 1 else repr(" ".join(words))
                    raise RobotError(f"{where} {shown} is not finite")


def _check_tree(robot, path: Path) -> None:
    """One line for links that do not form a tree: a joint naming a link the URDF lacks, a joint from a link
    to itself, a link with two parents, or a loop (the loader would walk a loop for ever)."""
    links = {link.name for link in robot.links}
    if not links:
        raise RobotError(f"{path}: no <link>: a URDF's robot is made of links")
    parent_joint: dict[str, Any] = {}  # link -> yourdfpy's joint whose child it is
    for j in robot.joints:
        for role, link in (("parent", j.parent), ("child", j.child)):
            if link not in links:
                raise RobotError(f"{path}: joint {j.name!r}: {role} link {link!r} is not a link of the URDF")
        if j.parent == j.child:
            raise RobotError(f"{path}: joint {j.name!r}: link {j.parent!r} is both its parent and its child")
        if j.child in parent_joint:
            other = parent_joint[j.child].name
            raise RobotError(
                f"{path}: link {j.child!r} is the child of two joints, {other!r} and {j.name!r}: a URDF's links "
                "form a tree (one parent each)"
            )
        parent_joint[j.child] = j
    # one parent each: a link that no walk up from it leaves (to a root) is on a loop or below one
    done: set[str] = set()
    for start in (link.name for link in robot.links):  # in the file's order: the same line every time
        trail: list[str] = []
        on_trail: set[str] = set()
        link = start
        while link in parent_joint and link not in done:
            if link in on_trail:
                loop = trail[trail.index(link) :][::-1]  # walked up: named down, parent to child
                joints = [parent_joint[k] for k in loop]
                names = ", ".join(repr(j.name) for j in joints)
                links_ = " -> ".join(map(repr, [joints[0].parent, *loop]))
                raise RobotError(f"{path}: joints {names} form a loop ({links_}): a URDF's links form a tree")
            trail.append(link)
            on_trail.add(link)
            link = parent_joint[link].parent
        done.update(trail)


def _check_mimics(robot, path: Path) -> None:
    """One line for a mimic joint that follows a joint the URDF lacks, or mimics that form a loop (a joint that
    follows itself, directly or through others): its position would depend on itself."""
    by_name = {j.name: j for j in robot.joints}
    for j in robot.joints:
        if j.mimic is not None and j.mimic.joint not in by_name:
            raise RobotError(
                f"{path}: joint {j.name!r} mimics {j.mimic.joint!r}, which is not a joint of the URDF (a typo, or a "
                "joint removed?)"
            )
    for j in robot.joints:
        trail = [j.name]
        follows = j
        while follows.mimic is not None:
            follows = by_name[follows.mimic.joint]
            if follows.name in trail:
                loop = trail[trail.index(follows.name) :] + [follows.name]
                raise RobotError(
                    f"{path}: joint {follows.name!r}: mimic joints follow each other in a loop "
                    f"({' -> '.join(map(repr, loop))}): one of them must follow a joint that mimics none"
                )
            trail.append(follows.name)


def _warn_off_chain(tree: _Tree, path: Path, driven: list[str], tracked_link: str) -> None:
    """One warning naming the continuous joints off the arm's chain (a mobile base's wheels): held, they never
    turn; simtune simulates the base fixed."""
    chain = {j.name for j in tree.chain(tracked_link)}
    below = {tracked_link}
    for j in tree.order:
        if j.parent in below:
            below.add(j.child)
    off = [
        j.name
        for j in tree.order
        if j.type == "continuous" and j.name not in driven and j.name not in chain and j.parent not in below
    ]
    if off:
        warnings.warn(
            f"{path}: continuous joint{'s' if len(off) > 1 else ''} {', '.join(map(repr, off))} "
            f"{'lie' if len(off) > 1 else 'lies'} off the arm's chain from {tree.root!r} to "
            f"{tracked_link!r}: held at 0 and never turned (a mobile base's wheels? simtune simulates the base fixed; "
            "drive a joint by naming it in arm_joints)",
            RobotWarning,
            stacklevel=3,
        )


#: A mesh whose longest side (scaled) is more than this many times the robot's largest joint offset ...
MILLIMETRE_FACTOR = 100.0
#: ... and longer than this [m] is taken for a mesh in millimetres: a link is never 100 x the lever it hangs on.
MILLIMETRE_MIN_M = 2.0


def _warn_millimetre_meshes(robot, path: Path, kind: str, package_path: Iterable[str | Path]) -> None:
    """One warning per mesh in millimetres (an STL has no units; :data:`MILLIMETRE_FACTOR`), naming the link and the
    file and suggesting the ``scale`` attribute: read as metres it makes a link hundreds of metres long, which an
    engine calls unstable or scores quietly."""
    offsets = [
        float(np.linalg.norm(np.asarray(j.origin, dtype=float)[:3, 3])) for j in robot.joints if j.origin is not None
    ]
    reach = max(offsets, default=0.0)
    if reach <= 0:
        return
    for link in robot.links:
        for k, element in enumerate(link.collisions if kind == "collision" else link.visuals):
            mesh = element.geometry.mesh if element.geometry is not None else None
            source = None if mesh is None else resolve_mesh(mesh.filename, path, package_path)
            if mesh is None or source is None:
                continue
            where = f"link {link.name!r} {kind} {k + 1}"
            scale = 1.0 if mesh.scale is None else float(np.max(np.abs(np.asarray(mesh.scale, dtype=float))))
            extent = mesh_extent(engine_mesh(source, f"{path}: {where}")) * scale
            if extent > MILLIMETRE_FACTOR * reach and extent > MILLIMETRE_MIN_M:
                warnings.warn(
                    f"{path}: {where}: mesh {mesh.filename!r} spans {extent:.4g} m, {extent / reach:.0f} x the robot's "
                    f"largest joint offset ({reach:.3g} m): is it in millimetres? give its <mesh> the attribute "
                    'scale="0.001 0.001 0.001"',
                    RobotWarning,
                    stacklevel=3,
                )


def _check_joint(joint, path: Path) -> None:
    """One line naming the URDF and joint for a type simtune has no use for or impossible values."""
    if joint.type not in (*_MOVABLE, "fixed"):
        raise RobotError(
            f"{path}: joint {joint.name!r}: type {joint.type!r} is not supported (revolute, continuous, prismatic "
            "or fixed)"
        )
    if joint.type == "fixed":
        return  # published fixed joints carry zero axes and empty limits that nothing reads
    if joint.axis is not None:
        axis = np.asarray(joint.axis, dtype=float)
        if not np.all(np.isfinite(axis)) or float(np.linalg.norm(axis)) < 1e-12:
            raise RobotError(f"{path}: joint {joint.name!r}: axis {_vec(axis)} has no direction")
    limit = joint.limit
    if limit is not None:
        # 0 is ROS-Industrial's "not given": kept.  Below 0 Drake stops the process (joint.h's velocity limits)
        # or refuses the robot, and no engine means anything by it.
        for name_, value in (("effort", limit.effort), ("velocity", limit.velocity)):
            if value is not None and float(value) < 0:
                raise RobotError(
                    f"{path}: joint {joint.name!r}: limit {name_} {float(value):g} is negative (a limit is >= 0; "
                    "0 or none: not given)"
                )
    if joint.type != "continuous" and limit is not None and limit.lower is not None and limit.upper is not None:
        lower, upper = float(limit.lower), float(limit.upper)
        if not (math.isfinite(lower) and math.isfinite(upper)):
            raise RobotError(f"{path}: joint {joint.name!r}: limits [{lower:g}, {upper:g}] are not finite")
        if lower > upper:
            raise RobotError(f"{path}: joint {joint.name!r}: lower limit {lower:g} is above upper limit {upper:g}")
    dynamics = joint.dynamics
    if dynamics is not None and dynamics.damping is not None and float(dynamics.damping) < 0:
        raise RobotError(
            f"{path}: joint {joint.name!r}: dynamics damping {float(dynamics.damping):g} is negative (damping "
            "takes energy out, it is >= 0)"
        )


def gripper_reason(joint) -> str:
    """Why a movable URDF joint is a gripper's (held, not driven), or '' for an arm joint."""
    if joint.mimic is not None:
        return f"it mimics {joint.mimic.joint!r}"
    if joint.type == "prismatic":
        return "it is prismatic (a finger's slide)"
    if _GRIPPER_NAME.search(joint.name):
        return "its name is a gripper's"
    return ""


@dataclass
class _Tree:
    """The URDF's joints as a tree from the chosen root: joints in order (parents first), per link the joints
    below it, and where the root stands (the caller's base, with a dropped ``world`` link's joint added)."""

    root: str
    order: list
    below: dict[str, list]
    base_position: Vec3
    base_rpy: Vec3
    notes: list[str]
    parent_joint: dict = field(init=False)  # link -> the joint whose child it is

    def __post_init__(self) -> None:
        self.parent_joint = {j.child: j for j in self.order}

    def chain(self, link: str) -> list:
        out = []
        while link in self.parent_joint:
            out.append(self.parent_joint[link])
            link = self.parent_joint[link].parent
        return out[::-1]


def _subtree(root: str, below: dict[str, list]) -> list:
    order: list = []
    queue = [root]
    while queue:
        for j in below.get(queue.pop(0), []):
            order.append(j)
            queue.append(j.child)
    return order


def _tree(robot, path: Path, base_position: Vec3, base_rpy: Vec3) -> _Tree:
    """Choose the robot's root: a root link named ``world`` is dropped (its fixed joints place what hangs
    from it), and of several trees the one with the most movable joints is the robot."""
    below: dict[str, list] = {}
    for j in robot.joints:
        below.setdefault(j.parent, []).append(j)
    children = {j.child for j in robot.joints}
    roots = [link.name for link in robot.links if link.name not in children]
    if not roots:
        raise RobotError(f"{path}: no root link: the joints form a loop")
    base = (np.asarray(base_position, dtype=float), rpy_matrix(base_rpy))
    notes: list[str] = []
    candidates = []  # (root link, position, rotation)
    for root in roots:
        hanging = below.get(root, [])
        if root.lower() == "world" and hanging and all(j.type == "fixed" for j in hanging):
            for j in hanging:
                xyz, rpy = _origin(j.origin)
                candidates.append((j.child, base[0] + base[1] @ np.asarray(xyz), base[1] @ rpy_matrix(rpy)))
            notes.append(f"link {root!r} is the world frame: dropped, its fixed joint places the base")
        else:
            candidates.append((root, *base))
    movable = [sum(j.type in _MOVABLE for j in _subtree(c[0], below)) for c in candidates]
    best = int(np.argmax(movable))
    root, position, rotation = candidates[best]
    others = [c[0] for k, c in enumerate(candidates) if k != best]
    if others:
        warnings.warn(
            f"{path}: several trees: the robot is the one from {root!r} ({movable[best]} movable joints); "
            f"left out: the tree(s) from {', '.join(repr(o) for o in others)}",
            RobotWarning,
            stacklevel=3,
        )
    if root.lower() == "world":  # MuJoCo's and Drake's world body: a movable joint from it needs another name
        raise RobotError(f"{path}: link {root!r} is the robot's root and a joint moves from it: rename the link")
    if position.any() or not np.allclose(rotation, np.eye(3)):
        notes.append(f"base of {root!r} at ({', '.join(f'{v:.4g}' for v in position)}) m")
    order = _subtree(root, below)
    return _Tree(root, order, below, _vec(position), _rpy(rotation), notes)


def _tip(tree: _Tree, link: str) -> str:
    """``link`` followed on through fixed joints while they do not branch (a flange, then a hand; a gripper's
    joints are movable in the URDF, so the hand is where it ends)."""
    while True:
        hanging = tree.below.get(link, [])
        if len(hanging) != 1 or hanging[0].type != "fixed":
            return link
        link = hanging[0].child


def _arm_choice(
    tree: _Tree, path: Path, link_names: list[str], arm_joints: list[str] | None, tracked_link: str | None
) -> tuple[list[str], str, list[str]]:
    """(driven joints, tracked link, notes saying why) for the caller's choices, else the defaults: the
    longest chain of arm joints from the root, gripper joints held."""
    gripper = {j.name: why for j in tree.order if j.type in _MOVABLE and (why := gripper_reason(j))}
    notes = [f"joint {name!r} held: {why}" for name, why in gripper.items()]

    def arm(chain) -> list[str]:
        return [j.name for j in chain if j.type in ("revolute", "continuous") and j.name not in gripper]

    if tracked_link is not None:
        if tracked_link not in link_names:
            raise RobotError(f"{path}: tracked link {tracked_link!r} is not a link of the URDF")
        notes.append(f"tracked link {tracked_link!r}: as given")
    elif arm_joints is not None:
        joint_of = {j.name: j for j in tree.order}
        last = max((joint_of[n] for n in arm_joints if n in joint_of), key=tree.order.index, default=None)
        tracked_link = tree.root if last is None else _tip(tree, last.child)
        notes.append(f"tracked link {tracked_link!r}: below the last driven joint")
    else:
        ends = [j.child for j in tree.order]
        counts = [len(arm(tree.chain(end))) for end in ends]
        if not ends or max(counts) == 0:
            raise RobotError(f"{path}: no revolute or continuous arm joint below root link {tree.root!r}")
        end = ends[int(np.argmax(counts))]
        last = arm(tree.chain(end))[-1]
        start = next(j.child for j in tree.order if j.name == last)
        tracked_link = _tip(tree, start)
        notes.append(
            f"tracked link {tracked_link!r}: the end of the longest chain of arm joints from {tree.root!r} "
            f"({max(counts)} joints)"
        )
    driven = arm(tree.chain(tracked_link)) if arm_joints is None else list(arm_joints)
    if not driven:
        raise RobotError(f"{path}: no movable joint to drive up to link {tracked_link!r}")
    return driven, tracked_link, notes


def _gripper_links(
    tree: _Tree, tracked_link: str, links_by_name: dict, notes: list[str], visual_only: bool = False
) -> set[str]:
    """The tracked link and every link below it; where none of them has a collision shape (a tool frame
    tracked beyond the last link with a surface), the links above it up to the first with one (in a
    visual-only description, the visual shapes stand in); where no link above has one either, the first."""

    def surface(name: str) -> bool:
        link = links_by_name[name]
        return bool(link.collisions or (visual_only and link.visuals))

    gripper = {tracked_link}
    for j in tree.order:
        if j.parent in gripper:
            gripper.add(j.child)
    if any(surface(g) for g in gripper):
        return gripper
    above = set()
    for joint in reversed(tree.chain(tracked_link)):
        above.add(joint.parent)
        if surface(joint.parent):
            notes.append(f"gripper surface: link {joint.parent!r}, the last with a collision shape")
            return gripper | above
    return gripper


def _check_driven(robot, path: Path, driven: list[str], held: Mapping[str, float]) -> None:
    joints_by_name = {j.name: j for j in robot.joints}
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


def _with_floor_masses(links: list[Link], joints: list[Joint], path: Path) -> tuple[list[Link], tuple[str, ...]]:
    """``links`` with :data:`FLOOR_MASS` on the first link of every moving body (a driven joint's child and
    what is fixed to it) that has no mass at all, with a warning naming it; and those links."""
    below: dict[str, list[Joint]] = {}
    for j in joints:
        below.setdefault(j.parent, []).append(j)
    mass = {link.name: link.mass for link in links}
    light = set()
    for j in joints:
        if not j.moves:
            continue
        body, queue = [], [j.child]
        while queue:
            body.append(queue.pop())
            queue += [k.child for k in below.get(body[-1], []) if not k.moves]
        if sum(mass[b] for b in body) <= 0:
            light.add(j.child)
    if light:
        warnings.warn(
            f"{path}: link {', '.join(repr(n) for n in sorted(light))} moves but has no mass (no <inertial> with a "
            f"mass, no geometry to estimate one from): a placeholder of {FLOOR_MASS:g} kg, so the robot cannot be "
            "simulated as described (add an <inertial>, or a <collision> to estimate its mass from)",
            RobotWarning,
            stacklevel=3,
        )
    floor = (FLOOR_INERTIA,) * 3
    filled = [
        replace(link, mass=FLOOR_MASS, inertia=floor, products=ZERO3, com=ZERO3) if link.name in light else link
        for link in links
    ]
    return filled, tuple(n for n in (link.name for link in links) if n in light)


#: A link lighter than this [kg] is a frame's token mass, not a body's (left as described).
TOKEN_MASS = 1e-6
#: The radius [m] of the solid sphere whose inertia a link with mass but none of its own gets where it has no shape.
LEAST_INERTIA_RADIUS = 0.01


def _with_rotational_inertia(links: list[Link], path: Path) -> list[Link]:
    """``links`` with an inertia for each link that has a mass but no rotational inertia (every principal moment 0,
    as some descriptions write ``<inertia>`` of zeros beside a real mass), with one warning naming them.

    The engines disagree on such a body - MuJoCo refuses it, ODE aborts the process, Drake's mass matrix loses rank,
    PyBullet and DART simulate it - so every engine gets the same stand-in: the inertia of the link's shapes as a
    solid of its mass (:mod:`simtune.robot.inertia`), or a solid sphere of :data:`LEAST_INERTIA_RADIUS` where it has
    none.  The mass and centre of mass stay as described."""
    from simtune.robot.inertia import solid_of

    filled, named = [], []
    for link in links:
        moments = np.linalg.eigvalsh(link.inertia_matrix())
        if link.mass <= TOKEN_MASS or moments.max() > 1e-12 * link.mass:
            filled.append(link)
            continue
        solid = solid_of(link.shapes)
        if solid is not None:
            tensor = solid.inertia * (link.mass / solid.volume)
            how = "of its shapes"
        else:
            tensor = 0.4 * link.mass * LEAST_INERTIA_RADIUS**2 * np.eye(3)
            how = f"of a {LEAST_INERTIA_RADIUS * 100:g}-cm sphere"
        filled.append(
            replace(
                link,
                inertia=(float(tensor[0, 0]), float(tensor[1, 1]), float(tensor[2, 2])),
                products=(float(tensor[0, 1]), float(tensor[0, 2]), float(tensor[1, 2])),
                inertia_rpy=ZERO3,
            )
        )
        named.append(f"{link.name} ({how})")
    if named:
        warnings.warn(
            f"{path}: link {', '.join(named)} has a mass but no rotational inertia (its <inertia> is all zeros): the "
            "engines disagree on such a body (MuJoCo refuses it, ODE aborts), so each gets the inertia of its shapes "
            "as a solid of that mass, else of a small sphere; give the link its own <inertia> to use that instead",
            RobotWarning,
            stacklevel=3,
        )
    return filled


def _check_mass_options(path: Path, density: float | None, total_mass: float | None) -> None:
    """One line for a density or total mass that is not above 0, or for both given."""
    if density is not None and total_mass is not None:
        raise RobotError(f"{path}: density and total_mass both given: give one (a total mass sets the density)")
    for what, value, unit in (("density", density, "kg/m^3"), ("total_mass", total_mass, "kg")):
        if value is not None and not (math.isfinite(float(value)) and float(value) > 0):
            raise RobotError(f"{path}: {what} {float(value):g} {unit} is not possible (it is above 0)")


def _estimated_masses(
    links: list[Link],
    given: dict,
    path: Path,
    package_path: Iterable[str | Path],
    density: float | None,
    total_mass: float | None,
) -> tuple[list[Link], tuple[str, ...], list[str]]:
    """``links`` with the mass and inertia of their geometry (:mod:`simtune.robot.inertia`) on each whose URDF
    link (``given``: name -> yourdfpy's link) has no ``<inertial>``: its shapes, else its visual ones, at
    ``density`` (default aluminium's), or with ``total_mass`` spread over them by volume.  Also the links
    estimated and the notes saying how (none where no link is)."""
    solids: dict[str, Solid] = {}
    from_visual = []
    for link in links:
        source = given[link.name]
        if source.inertial is not None and source.inertial.mass is not None:
            continue
        shapes = link.shapes or _shapes(source, path, "visual", package_path)
        solid = solid_of(shapes)
        if solid is not None:
            solids[link.name] = solid
            if not link.shapes:
                from_visual.append(link.name)
    if not solids:
        if total_mass is not None:
            raise RobotError(
                f"{path}: total_mass {total_mass:g} kg: no link lacks an <inertial> and has geometry to spread it "
                "over (the URDF gives every mass: leave total_mass out)"
            )
        return links, (), ([] if density is None else [f"density {density:g} kg/m^3: not used (every mass is given)"])
    if total_mass is not None:
        density = total_mass / sum(s.volume for s in solids.values())
        how = f"{total_mass:g} kg (total_mass) shared by volume ({density:.4g} kg/m^3)"
    elif density is None:
        density = DEFAULT_DENSITY
        how = f"as solids of {density:g} kg/m^3 (aluminium; --density or --total-mass to change)"
    else:
        how = f"as solids of {density:g} kg/m^3"
    filled = [with_solid_mass(link, solids[link.name], density) if link.name in solids else link for link in links]
    masses = ", ".join(f"{link.name} {link.mass:.3g} kg" for link in filled if link.name in solids)
    visual = f"; from visual geometry: {', '.join(from_visual)}" if from_visual else ""
    note = f"masses estimated from geometry (no <inertial>), {how}: {masses}{visual}"
    return filled, tuple(link.name for link in links if link.name in solids), [note]


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
    package_path: Iterable[str | Path] = (),
    density: float | None = None,
    total_mass: float | None = None,
) -> RobotDescription:
    """The robot of the URDF at ``path``; ``RobotError`` (one line naming the file and element) if it
    cannot be used.  The module's docstring says how a published description is read.

    ``arm_joints``: the driven joints in order (default: the arm joints from the root to the tracked
    link); ``tracked_link``: the link the motion capture follows (default: the end of the longest chain of
    arm joints, or below the last of ``arm_joints``); ``base_position``/``base_rpy``: where the root stands
    (a dropped ``world`` link's joint is added to it); ``held``: positions of joints held at a fixed pose
    (default 0, clamped into the joint's limits); ``gripper_links``: the links with the gripper's contact
    parameters (default: the tracked link and every link below it); ``package_path``: folders to look
    for ``package://`` packages in first (or ``NAME=DIR``: package NAME is folder DIR); ``density``
    [kg/m^3] of the links without an ``<inertial>``, whose masses come from their geometry (default
    :data:`~simtune.robot.inertia.DEFAULT_DENSITY`), or ``total_mass`` [kg] spread over those links by
    volume (not both).  :attr:`RobotDescription.choices` says what was chosen and why.

    Returns the description; :attr:`RobotDescription.estimated_masses` and
    :attr:`RobotDescription.placeholder_masses` name the links whose masses the URDF does not give.
    """
    path = Path(path).expanduser().resolve()
    _check_mass_options(path, density, total_mass)
    robot = _parse(path)
    held = dict(held or {})
    link_names = [link.name for link in robot.links]
    _check_tree(robot, path)
    for j in robot.joints:
        _check_joint(j, path)
    _check_mimics(robot, path)
    # the caller's numbers too: a NaN pose would reach the loader's rotations (a LinAlgError) and the engines
    for what, values in (("base_position", base_position), ("base_rpy", base_rpy)):
        if not np.all(np.isfinite(np.asarray(values, dtype=float))):
            raise RobotError(f"{path}: {what} {tuple(values)} is not finite")
    for joint_name, position in held.items():
        if not math.isfinite(float(position)):
            raise RobotError(f"{path}: held joint {joint_name!r}: position {position} is not finite")
    tree = _tree(robot, path, _vec(base_position), _vec(base_rpy))
    driven, tracked_link, notes = _arm_choice(
        tree, path, link_names, None if arm_joints is None else list(arm_joints), tracked_link
    )
    _check_driven(robot, path, driven, held)
    _warn_off_chain(tree, path, driven, tracked_link)
    links_by_name = {link.name: link for link in robot.links}
    if tracked_link != tree.root and tracked_link not in tree.parent_joint:
        raise RobotError(f"{path}: tracked link {tracked_link!r} is not in the robot's tree from {tree.root!r}")
    ordered_links = [tree.root, *(j.child for j in tree.order)]
    # a visual-only description: no <collision> in the robot at all (a link without one among links with one
    # is left so: its publisher chose so, as the SO-100's gripper and the Z1's link01 show)
    visual_only = not any(links_by_name[n].collisions for n in ordered_links)
    visual_only = visual_only and any(links_by_name[n].visuals for n in ordered_links)
    if gripper_links is None:
        gripper = _gripper_links(tree, tracked_link, links_by_name, notes, visual_only)
    else:
        gripper = set(gripper_links)
        for g in gripper:
            if g not in link_names:
                raise RobotError(f"{path}: gripper link {g!r} is not a link of the URDF")

    positions: dict[str, float] = {}
    held_at: list[tuple[str, float]] = []
    joints = []
    for j in tree.order:
        is_driven = j.name in driven
        position = 0.0
        if j.type in _MOVABLE and not is_driven:
            position = _held_position(j, held, positions)
            positions[j.name] = position
            held_at.append((j.name, position))
        joints.append(_joint(j, is_driven, position))
    unstated = [
        j.name
        for j in tree.order
        if j.type in _MOVABLE and j.limit is not None and 0 in (j.limit.effort, j.limit.velocity)
    ]
    if unstated:
        listed = ", ".join(unstated[:4]) + (f" and {len(unstated) - 4} more" if len(unstated) > 4 else "")
        warnings.warn(
            f"{path}: effort or velocity 0 on {listed}: read as not given (the ROS-Industrial convention); every "
            "engine applies simtune's generic torque and velocity limits there (the max_torque_* and max_velocity_* "
            "parameters tune them)",
            RobotWarning,
            stacklevel=2,
        )
    kind = "visual" if visual_only else "collision"
    _warn_millimetre_meshes(robot, path, kind, package_path)
    links = [
        _link(links_by_name[n], path, "gripper" if n in gripper else "arm", package_path, kind) for n in ordered_links
    ]
    if visual_only:
        shown = ", ".join(link.name for link in links if link.shapes)
        notes.append(f"no <collision> in the robot: the visual geometry of link {shown} stands in for its collisions")
    links, estimated, estimate_notes = _estimated_masses(links, links_by_name, path, package_path, density, total_mass)
    links, placeholders = _with_floor_masses(links, joints, path)
    links = _with_rotational_inertia(links, path)
    description = RobotDescription(
        name=name or robot.name or path.stem,
        links=tuple(links),
        joints=tuple(joints),
        arm_joints=tuple(driven),
        tracked_link=tracked_link,
        base_position=tree.base_position,
        base_rpy=tree.base_rpy,
        held=tuple(held_at),
        source=str(path),
        estimated_masses=estimated,
        placeholder_masses=placeholders,
        choices=tuple(tree.notes + notes + estimate_notes),
    )
    try:
        description.check()
    except ValueError as exc:
        raise RobotError(f"{path}: {exc}") from None
    return description
