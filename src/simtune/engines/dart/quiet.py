"""DART's warnings about the material files a robot's meshes name, summed up in one line.

DART reads OBJ meshes through Assimp, which opens the material library (``.mtl``) each OBJ's ``mtllib`` line
names.  Where that file is missing (published OBJs often name one that was never shipped; trimesh names
``material.mtl`` in the OBJs it converts) Assimp tries a dozen more paths, and DART's resource retriever warns
twice on each, straight to file descriptor 2: 1322 lines for pybullet_data's Franka Panda, 926 for
example-robot-data's Jaco 2.  Materials are colours only: collision and dynamics never read them.

So while DART reads a robot whose meshes name a missing material file, its stderr goes to a temporary file; the
lines about files that could not be opened, other than the meshes themselves, are left out and said in one
warning (how many meshes, and one of them with the file it names) through Python's warnings, like the other
engines' notes; every other line (a mesh DART cannot open, its notes on zero masses, an error) is written to
stderr unchanged, in its order, before the load's result or exception goes on.  A crash of DART inside the load
loses what it had written (it is in the temporary file): the meshes are checked at load
(:func:`simtune.robot.meshes.engine_mesh`), which keeps DART's known crashes out.
"""

from __future__ import annotations

import functools
import os
import re
import sys
import tempfile
import threading
import warnings
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TypeVar

from simtune.errors import RobotWarning

T = TypeVar("T")

#: File descriptor 2 is the process's, not a thread's: two loads capturing it at once would restore each
#: other's temporary file, and stderr would stay lost
_CAPTURING = threading.Lock()

#: DART's two warnings on a file it cannot open: LocalResource's (a path) and CompositeResourceRetriever's (a URI)
_NOT_OPENED = re.compile(rb"Failed opening file '([^']*)'|failed to retrieve the URI '([^']*)'")


@functools.lru_cache(maxsize=1024)
def _material_libraries(path: str, stamp: tuple[int, int]) -> tuple[str, ...]:
    """The file names on the ``mtllib`` lines of the OBJ ``path`` (``stamp``: its modification time and size,
    so an edited file is read again)."""
    names: list[str] = []
    with open(path, "rb") as f:
        for line in f:
            if line.startswith(b"mtllib"):
                names += line[len(b"mtllib") :].decode("utf-8", errors="replace").split()
    return tuple(names)


def missing_materials(meshes: Iterable[str]) -> dict[str, str]:
    """The OBJ meshes among ``meshes`` whose ``mtllib`` line names a file that does not exist.

    Args:
        meshes: mesh file paths (files that are not OBJ, or cannot be read, are passed over).

    Returns:
        Each such mesh's path mapped to the first missing file name it gives, in the order of ``meshes``.
    """
    missing: dict[str, str] = {}
    for mesh in dict.fromkeys(meshes):
        path = Path(mesh)
        if path.suffix.lower() != ".obj":
            continue
        try:
            stat = path.stat()
            names = _material_libraries(str(path), (stat.st_mtime_ns, stat.st_size))
        except OSError:  # DART says so itself, and that line is passed on
            continue
        absent = [name for name in names if not (path.parent / name).is_file()]
        if absent:
            missing[mesh] = absent[0]
    return missing


def _is_material_noise(line: bytes, meshes: frozenset[bytes]) -> bool:
    """Whether ``line`` is DART's warning on a file it could not open that is none of ``meshes`` (the paths as
    bytes): a material file, or one of the paths Assimp tries after it."""
    found = _NOT_OPENED.search(line)
    if found is None:
        return False
    named = found.group(1) or found.group(2)
    return not any(named.endswith(mesh) for mesh in meshes)


def _replay(captured: bytes, meshes: frozenset[bytes]) -> int:
    """Write the lines of ``captured`` that are not material noise to file descriptor 2, unchanged.

    Returns:
        How many lines were left out.
    """
    left_out = 0
    for line in captured.splitlines(keepends=True):
        if _is_material_noise(line, meshes):
            left_out += 1
        else:
            os.write(2, line)
    return left_out


def load_quietly(load: Callable[[], T], meshes: Iterable[str]) -> T:
    """``load()`` (DART reading a robot whose mesh files are ``meshes``) with DART's warnings about missing
    material files said in one warning (see the module's docstring); the call as it is where no mesh names one.

    Args:
        load: the call that makes DART read the meshes (e.g. a ``DartLoader.parseSkeleton``).
        meshes: the paths of the mesh files the robot names.

    Returns:
        What ``load`` returns; its exception, if it raises, after the stderr lines it wrote.
    """
    meshes = list(meshes)
    missing = missing_materials(meshes)
    if not missing:
        return load()
    with _CAPTURING:
        sys.stdout.flush()
        sys.stderr.flush()  # Python's own buffered text goes out before the descriptor is swapped
        saved = os.dup(2)
        with tempfile.TemporaryFile() as capture:
            os.dup2(capture.fileno(), 2)
            try:
                return load()
            finally:
                os.dup2(saved, 2)
                os.close(saved)
                capture.seek(0)
                left_out = _replay(capture.read(), frozenset(os.fsencode(mesh) for mesh in meshes))
                if left_out:
                    _say(missing, left_out)


def _say(missing: dict[str, str], left_out: int) -> None:
    """The one warning for the ``left_out`` lines about the material files of the meshes in ``missing``."""
    mesh, name = next(iter(missing.items()))
    warnings.warn(
        f"DART could not find the material (.mtl) files that {len(missing)} of the robot's meshes "
        f"name (e.g. {Path(mesh).name} names {name}): colours only, the simulation is unaffected "
        f"({left_out} lines of DART's warnings left out)",
        RobotWarning,
        stacklevel=4,
    )
