"""One entry for a robot file: a URDF or an MJCF, told apart by the file's root element.

``simtune init`` and the project loader (:func:`simtune.tasks.project.resolve_robot`) both read a robot
through :func:`load_robot`, so that a file starts a project exactly as the project then loads it.
"""

from __future__ import annotations

import hashlib
import inspect
import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any, ParamSpec

from simtune.errors import RobotError
from simtune.robot import urdf  # called as urdf.load_urdf: a test may wrap the module's loader
from simtune.robot.description import Mesh, RobotDescription

#: The robot file formats: the root element that names each.
ROOT_ELEMENTS = {"robot": "urdf", "mujoco": "mjcf"}

P = ParamSpec("P")


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


def _keywords_of(
    loader: Callable[P, RobotDescription],
) -> Callable[[Callable[..., RobotDescription]], Callable[P, RobotDescription]]:
    """Gives the decorated loader ``loader``'s signature, for mypy, ``help()`` and :mod:`inspect` alike: the
    keywords, their defaults and their documentation have one home, ``loader``."""

    def take(function: Callable[..., RobotDescription]) -> Callable[P, RobotDescription]:
        function.__signature__ = inspect.signature(loader)  # type: ignore[attr-defined]
        return function

    return take


#: load_robot's keywords: load_urdf's
_SIGNATURE = inspect.signature(urdf.load_urdf)


@_keywords_of(urdf.load_urdf)
def load_robot(path: str | Path, **options: Any) -> RobotDescription:
    """The robot of the URDF or MJCF file at ``path`` (:func:`robot_format` tells which).

    Args:
        path: the robot file.
        **options: :func:`~simtune.robot.urdf.load_urdf`'s keywords, which say what each is.  With an MJCF, the
            URDF's own (``held``: an MJCF's undriven joints are welded at 0; ``package_path``: MuJoCo finds an
            MJCF's meshes; ``density``/``total_mass``: an MJCF's bodies have their masses) are refused when given.

    Returns:
        The description; :attr:`RobotDescription.choices` says what the loader chose and why.

    Raises:
        RobotError: one line naming the file and element, if the file cannot be used.
    """
    path = Path(path).expanduser().resolve()
    bound = _SIGNATURE.bind(path, **options)
    bound.apply_defaults()
    given = {key: _plain(value) for key, value in bound.arguments.items() if key != "path"}
    if robot_format(path) == "mjcf":
        from simtune.robot.mjcf import load_mjcf

        if given["held"]:
            raise RobotError(
                f"{path}: held positions are for a URDF: an MJCF's joints that are not driven are welded at 0 "
                f"(held {', '.join(map(repr, given['held']))})"
            )
        if given["package_path"]:
            raise RobotError(
                f"{path}: package_path {given['package_path']} is for a URDF's package:// names: MuJoCo finds an "
                "MJCF's meshes itself (its compiler's meshdir); leave package_path out"
            )
        for mass_key in ("density", "total_mass"):
            if given[mass_key] is not None:
                raise RobotError(
                    f"{path}: {mass_key} is for a URDF's links without an <inertial>: an MJCF's bodies have their "
                    f"masses (MuJoCo's compiler infers any from the geoms); leave {mass_key} out"
                )
        mjcf_keys = inspect.signature(load_mjcf).parameters.keys() - {"path"}
        return load_mjcf(path, **{key: value for key, value in given.items() if key in mjcf_keys})
    return _cached_urdf(path, given)


def _plain(value: Any) -> Any:
    """A keyword's value as plain data, read once (an iterator would be spent by the cache key): a mapping as
    a dict, a path as its string, any other iterable but a string as a list."""
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, Mapping):
        return dict(value)
    if isinstance(value, Iterable) and not isinstance(value, str):
        return [_plain(item) for item in value]
    return value


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

    try:
        text = path.read_bytes()
    except OSError:
        return urdf.load_urdf(path, **options)  # the reader names what is wrong with the file
    # by pattern, not by parsing: a file the strict parse refuses (undeclared prefixes) is read all the same
    meshes = sorted({m.decode(errors="replace") for m in _MESH_FILENAME.findall(text)} - {""})
    resolved = {}
    for filename in meshes:
        found = urdf.resolve_mesh(filename, path, options["package_path"])
        stat = None if found is None else found.stat()
        resolved[filename] = None if stat is None else (str(found), stat.st_size, stat.st_mtime_ns)
    what = {
        "urdf": str(path),
        "bytes": hashlib.sha256(text).hexdigest(),
        "options": options,
        "meshes": resolved,
        "environment": {v: os.environ.get(v, "") for v in ("SIMTUNE_PACKAGE_PATH", "ROS_PACKAGE_PATH")},
    }
    return cached("robots", what, lambda: urdf.load_urdf(path, **options), valid=_meshes_exist)


def _meshes_exist(robot: RobotDescription) -> bool:
    """Whether every mesh file ``robot`` points to is still there (a converted mesh lives in a cache)."""
    return all(Path(s.path).is_file() for link in robot.links for s in link.shapes if isinstance(s, Mesh))
