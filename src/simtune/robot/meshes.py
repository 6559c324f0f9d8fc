"""Mesh files as every engine can read them: one OBJ per source mesh, converted once and cached.

Published robot descriptions name collision meshes in Collada (``.dae``), STL (``.stl``, ``.STL``) or
OBJ.  The engines read different subsets: MuJoCo no Collada, Drake's convex hulls OBJ alone (not STL),
PyBullet and DART most.  So the description (:func:`simtune.robot.urdf.load_urdf`) names an OBJ file
for every mesh: an OBJ source as it is, any other converted through trimesh (pycollada for Collada,
whose ``<unit>`` is applied: a description in millimetres becomes metres) into a cache folder, keyed by
the source file's content hash, so a second load reads the converted file and an edited mesh is
converted anew.  The cache is ``$SIMTUNE_CACHE_DIR/meshes`` (default ``~/.cache/simtune/meshes``, XDG's
``$XDG_CACHE_HOME`` where set); files are written whole (a temporary name, then renamed), so parallel
workers converting the same mesh never read half a file.
"""

from __future__ import annotations

import functools
import hashlib
import os
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

from simtune.common.cache import cache_root
from simtune.errors import RobotError

if TYPE_CHECKING:
    import numpy as np

#: Extensions every engine reads as they are (compared in lower case).
READ_AS_IS = (".obj",)
#: Extensions converted to OBJ (trimesh reads them; Collada through pycollada).
CONVERTED = (".stl", ".dae", ".ply", ".off", ".glb", ".gltf")


def cache_folder() -> Path:
    """Where converted meshes are kept (see the module's docstring)."""
    return cache_root() / "meshes"


def _stamp(path: Path) -> tuple[int, int]:
    """A file's version as far as the caches here go: its modification time and size."""
    stat = path.stat()
    return stat.st_mtime_ns, stat.st_size


def _digest(path: Path) -> str:
    """The file's content hash, read once per version of the file in a process (every load of a robot, in
    every worker, names the same meshes)."""
    return _content_digest(path, _stamp(path))


@functools.lru_cache(maxsize=1024)
def _content_digest(path: Path, stamp: tuple[int, int]) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()[:32]


def _read(source: Path, where: str):
    """The mesh in ``source`` as one trimesh (a scene's parts joined, in metres); a one-line RobotError for a
    file that is not one, or holds no solid (fewer than 4 vertices: DART crashes on such a mesh)."""
    try:
        import trimesh
    except ImportError:
        raise RobotError(f"{where}: reading mesh {source.name} needs trimesh: pip install 'simtune[urdf]'") from None
    try:
        loaded = trimesh.load(str(source))
        if isinstance(loaded, trimesh.Scene):
            if loaded.units not in (None, "m", "meter", "meters"):
                loaded = loaded.convert_units("meters")
            mesh = loaded.to_mesh() if loaded.geometry else None
        else:
            mesh = loaded
    except ImportError as exc:  # pycollada for .dae
        raise RobotError(f"{where}: reading mesh {source.name} needs {exc.name}: pip install 'simtune[urdf]'") from None
    except Exception as exc:  # trimesh raises many kinds on a broken file
        raise RobotError(f"{where}: mesh {source} cannot be read ({type(exc).__name__}: {exc})") from None
    if mesh is None or len(mesh.vertices) < 4:
        raise RobotError(f"{where}: mesh {source} holds no solid (fewer than 4 vertices)")
    return mesh


@functools.lru_cache(maxsize=1024)
def _check(source: Path, stamp: tuple[int, int], where: str) -> None:
    """Read an OBJ file once per version (``stamp``: its modification time and size) to refuse a broken one at
    load rather than in an engine."""
    _read(source, where)


def _convert(source: Path, target: Path, where: str) -> None:
    _write_obj(_read(source, where), target)


def _write_obj(mesh, target: Path) -> None:
    """``mesh`` as the OBJ file ``target``, written whole (a temporary name, then renamed)."""
    import trimesh

    target.parent.mkdir(parents=True, exist_ok=True)
    fd, staging = tempfile.mkstemp(prefix=f".{target.stem}.", suffix=".obj", dir=target.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(trimesh.exchange.obj.export_obj(mesh, include_normals=False, include_color=False, digits=9))
        os.replace(staging, target)
    except BaseException:
        Path(staging).unlink(missing_ok=True)
        raise


def engine_mesh(source: Path, where: str) -> Path:
    """The OBJ file every engine reads for the mesh ``source``: itself if it is an OBJ, else its converted
    copy in :func:`cache_folder` (made here the first time).  ``where`` names the URDF and element for
    the one-line :class:`RobotError` of a mesh that cannot be read or converted."""
    suffix = source.suffix.lower()
    if suffix in READ_AS_IS:
        _check(source, _stamp(source), where)
        return source
    if suffix not in CONVERTED:
        known = ", ".join((*READ_AS_IS, *CONVERTED))
        raise RobotError(f"{where}: mesh {source.name}: unknown mesh format {source.suffix!r} (known: {known})")
    target = cache_folder() / f"{source.stem}-{_digest(source)}.obj"
    if not target.is_file():
        try:
            _convert(source, target, where)
        except OSError as exc:
            raise RobotError(f"{where}: cannot write the converted mesh to {target.parent} ({exc.strerror})") from None
    return target


def convex_hull_file(source: str | Path) -> Path:
    """An OBJ file of the convex hull of the mesh file ``source`` (an OBJ from :func:`engine_mesh`), cached
    like the converted meshes.  For an engine that collides with a mesh's hull but builds it from every vertex
    on each load (PyBullet: a published SO-101's meshes took it 1.2 s a load), the same shape, read faster."""
    source = Path(source)
    target = cache_folder() / f"{source.stem}-{_digest(source)}-hull.obj"
    if not target.is_file():
        _write_obj(_read(source, str(source)).convex_hull, target)
    return target


def obj_vertices(path: str | Path) -> np.ndarray:
    """The vertices of an OBJ file (its ``v`` lines) as an (n, 3) array, without reading its faces: the points of a
    convex hull from :func:`convex_hull_file`, for an engine that builds the hull itself.

    Args:
        path: the OBJ file.

    Returns:
        The vertices, in the file's units.
    """
    import numpy as np

    with open(path, encoding="utf-8") as f:
        rows = [line.split()[1:4] for line in f if line.startswith("v ")]
    return np.array(rows, dtype=float).reshape(-1, 3)


def hull_of_points(points, name: str) -> Path:
    """An OBJ file of the convex hull of ``points`` (an n x 3 array [m]) in :func:`cache_folder`, keyed by the
    points' bytes: the collision shape MuJoCo makes of an MJCF's mesh (its compiled vertices, in the mesh's
    own frame), for the engines that read the robot from a generated URDF.

    Args:
        points: the vertices, at least 4 not in one plane.
        name: a readable stem for the file (the mesh's name).

    Returns:
        The OBJ file's path (written the first time, whole: a temporary name, then renamed).
    """
    import numpy as np
    from scipy.spatial import ConvexHull

    points = np.ascontiguousarray(points, dtype=np.float64)
    digest = hashlib.sha256(points.tobytes()).hexdigest()[:32]
    stem = "".join(c if c.isalnum() or c in "-_" else "_" for c in name)[:40] or "mesh"
    target = cache_folder() / f"{stem}-{digest}-hull.obj"
    if target.is_file():
        return target
    hull = ConvexHull(points)
    used = np.unique(hull.simplices)
    index = {int(v): k + 1 for k, v in enumerate(used)}  # OBJ counts vertices from 1
    centre = points[used].mean(axis=0)
    lines = [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in points[used]]
    for simplex in hull.simplices:
        a, b, c = (points[i] for i in simplex)
        if np.dot(np.cross(b - a, c - a), a - centre) < 0:  # each face turned outwards
            simplex = simplex[[0, 2, 1]]
        lines.append("f " + " ".join(str(index[int(i)]) for i in simplex))
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, staging = tempfile.mkstemp(prefix=f".{target.stem}.", suffix=".obj", dir=target.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write("\n".join(lines) + "\n")
        os.replace(staging, target)
    except BaseException:
        Path(staging).unlink(missing_ok=True)
        raise
    return target


@functools.lru_cache(maxsize=1024)
def _extent(source: Path, stamp: tuple[int, int]) -> float:
    return float(max(_read(source, str(source)).extents))


def mesh_extent(source: str | Path) -> float:
    """The longest side of the axis-aligned box around the mesh in ``source``, in the file's own units (read once
    per version of the file)."""
    source = Path(source)
    return _extent(source, _stamp(source))
