"""One entry for a robot file: a URDF or an MJCF, told apart by the file's root element.

``simtune init`` and the project loader (:func:`simtune.tasks.project.resolve_robot`) both read a robot
through :func:`load_robot`, so that a file starts a project exactly as the project then loads it.
"""

from __future__ import annotations

import hashlib
import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Mapping
from pathlib import Path

from simtune.errors import RobotError
from simtune.robot.description import Mesh, RobotDescription, Vec3

#: The robot file formats: the root element that names each.
ROOT_ELEMENTS = {"robot": "urdf", "mujoco": "mjcf"}


def robot_format(path: str | Path) -> str:
    """Which format the robot file at ``path`` is in, by its root element.

    Args:
        path: the robot file.

    Returns:
        ``"urdf"`` (root ``<robot>``) or ``"mjcf"`` (root ``<mujoco>``).

    Raises:
        RobotError: one line naming the file, if it is missing or its root element is neither.  A file whose
            first element does not parse is read as a URDF, whose reader names the line.
    """
    path = Path(path).expanduser().resolve()
    if not path.is_file():
        kind = {".urdf": "URDF", ".xml": "MJCF"}.get(path.suffix.lower(), "robot")
        raise RobotError(f"{path}: no such {kind} file")
    try:
        for _, element in ET.iterparse(path, events=("start",)):
            tag = element.tag
            break
        else:  # pragma: no cover - iterparse raises on an empty document
            raise RobotError(f"{path}: empty file (a URDF or an MJCF expected)")
    except ET.ParseError:
        return "urdf"  # the URDF reader says where the XML breaks, and reads past undeclared prefixes
    except OSError as exc:
        raise RobotError(f"{path}: cannot be read ({exc.strerror})") from None
    if tag not in ROOT_ELEMENTS:
        raise RobotError(
            f"{path}: its root element is <{tag}>: neither a URDF (<robot>) nor an MJCF (<mujoco>)",
        )
    return ROOT_ELEMENTS[tag]


def load_robot(
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
    """The robot of the URDF or MJCF file at ``path`` (:func:`robot_format` tells which).

    Args:
        path: the robot file.
        arm_joints: the driven joints in order (default: the loader's choice).
        tracked_link: the link (an MJCF's body) the motion capture follows (default: the loader's choice).
        base_position: where the root stands [m], added to the file's own placement.
        base_rpy: how the root is turned [rad].
        held: positions of joints held at a fixed pose (a URDF only: an MJCF's undriven joints are welded at 0).
        gripper_links: the links with the gripper's contact parameters.
        name: the robot's name (default: the file's).
        package_path: folders for a URDF's ``package://`` names (a URDF only, refused with an MJCF; ``NAME=DIR``
            names a package's folder).
        density: [kg/m^3] of a URDF's links without an ``<inertial>``, whose masses come from their geometry.
        total_mass: [kg] spread over those links by volume instead (not with ``density``).

    Returns:
        The description; :attr:`RobotDescription.choices` says what the loader chose and why.

    Raises:
        RobotError: one line naming the file and element, if the file cannot be used.
    """
    path = Path(path).expanduser().resolve()
    if robot_format(path) == "mjcf":
        from simtune.robot.mjcf import load_mjcf

        if held:
            raise RobotError(
                f"{path}: held positions are for a URDF: an MJCF's joints that are not driven are welded at 0 "
                f"(held {', '.join(map(repr, held))})"
            )
        package_path = [str(entry) for entry in package_path]
        if package_path:
            raise RobotError(
                f"{path}: package_path {package_path} is for a URDF's package:// names: MuJoCo finds an MJCF's "
                "meshes itself (its compiler's meshdir); leave package_path out"
            )
        return load_mjcf(
            path,
            arm_joints=arm_joints,
            tracked_link=tracked_link,
            gripper_links=gripper_links,
            name=name,
            base_position=base_position,
            base_rpy=base_rpy,
        )
    options = {
        "arm_joints": None if arm_joints is None else list(arm_joints),
        "tracked_link": tracked_link,
        "base_position": tuple(base_position),
        "base_rpy": tuple(base_rpy),
        "held": dict(held or {}),
        "gripper_links": None if gripper_links is None else list(gripper_links),
        "name": name,
        "package_path": [str(entry) for entry in package_path],
        "density": density,
        "total_mass": total_mass,
    }
    return _cached_urdf(path, options)


#: a ``<mesh filename="...">`` of a URDF (either quote), for the files a description depends on
_MESH_FILENAME = re.compile(rb"""<mesh\b[^>]*?\bfilename\s*=\s*["']([^"']*)["']""")


def _cached_urdf(path: Path, options: dict) -> RobotDescription:
    """:func:`~simtune.robot.urdf.load_urdf`'s description of ``path``, read back from the start-up cache
    (:func:`simtune.data.cache.cached`) when neither the file, nor ``options``, nor a mesh it names has changed.

    Reading a URDF imports yourdfpy and trimesh (about 0.6 s) and walks the file (0.1 s a read): most of a warm
    ``simtune tune``'s start on an own robot.  The key holds the file's bytes, the options, the package
    variables and, for every mesh file the URDF names, the file it resolves to now with its size and
    modification time; an entry is used only while the meshes it points to (converted ones in the mesh cache)
    still exist.  The load's warnings are raised again on every read."""
    from simtune.data.cache import cached
    from simtune.robot.urdf import load_urdf, resolve_mesh

    try:
        text = path.read_bytes()
    except OSError:
        return load_urdf(path, **options)  # the reader names what is wrong with the file
    # by pattern, not by parsing: a file the strict parse refuses (undeclared prefixes) is read all the same
    meshes = sorted({m.decode(errors="replace") for m in _MESH_FILENAME.findall(text)} - {""})
    resolved = {}
    for filename in meshes:
        found = resolve_mesh(filename, path, options["package_path"])
        stat = None if found is None else found.stat()
        resolved[filename] = None if stat is None else (str(found), stat.st_size, stat.st_mtime_ns)
    what = {
        "urdf": str(path),
        "bytes": hashlib.sha256(text).hexdigest(),
        "options": options,
        "meshes": resolved,
        "environment": {v: os.environ.get(v, "") for v in ("SIMTUNE_PACKAGE_PATH", "ROS_PACKAGE_PATH")},
    }
    return cached("robots", what, lambda: load_urdf(path, **options), valid=_meshes_exist)


def _meshes_exist(robot: RobotDescription) -> bool:
    """Whether every mesh file ``robot`` points to is still there (a converted mesh lives in a cache)."""
    return all(Path(s.path).is_file() for link in robot.links for s in link.shapes if isinstance(s, Mesh))
