"""A link's mass and inertia from its geometry, where its description gives none (MuJoCo's ``inertiafromgeom``).

A URDF link without an ``<inertial>`` (a kinematic description: the geometry to draw and collide with, no
masses) would otherwise move as a placeholder no engine simulates as the arm: here its shapes are taken as
solids of one density.  Boxes, spheres and cylinders by their formulas; a mesh by trimesh's volume integrals
over its triangles, or over its convex hull where the mesh does not close a volume (a visual mesh with
holes, flipped faces or several loose shells).  A link's shapes are summed as MuJoCo sums a body's geoms:
overlaps count twice, each shape's inertia moved to the common centre of mass (parallel axes).
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from simtune.common.geometry import rpy_matrix
from simtune.robot.description import ZERO3, Box, Cylinder, Link, Mesh, Shape, Sphere

#: The density [kg/m^3] of a link estimated from its geometry unless told otherwise: aluminium's, what most arm
#: links' shells are made of (a solid block of it overestimates a hollow link; ``--total-mass`` scales it).
DEFAULT_DENSITY = 2700.0


@dataclass(frozen=True)
class Solid:
    """Shapes taken as solids of density 1: their volume [m^3], centre of volume (in the link frame [m]) and
    inertia about it per unit density [m^5], in the link frame."""

    volume: float
    centre: np.ndarray
    inertia: np.ndarray

    def at(self, density: float) -> tuple[float, np.ndarray, np.ndarray]:
        """(mass [kg], centre of mass [m], inertia [kg m^2]) at ``density`` [kg/m^3]."""
        return density * self.volume, self.centre, density * self.inertia


def _box(half: np.ndarray) -> tuple[float, np.ndarray]:
    volume = 8.0 * float(np.prod(half))
    h2 = half**2
    return volume, volume / 3.0 * np.diag([h2[1] + h2[2], h2[0] + h2[2], h2[0] + h2[1]])


def _sphere(radius: float) -> tuple[float, np.ndarray]:
    volume = 4.0 / 3.0 * np.pi * radius**3
    return volume, 0.4 * volume * radius**2 * np.eye(3)


def _cylinder(radius: float, length: float) -> tuple[float, np.ndarray]:
    volume = np.pi * radius**2 * length
    side = volume * (3.0 * radius**2 + length**2) / 12.0
    return volume, np.diag([side, side, volume * radius**2 / 2.0])


@functools.lru_cache(maxsize=256)
def _mesh(path: str, scale: tuple[float, float, float]) -> tuple[float, np.ndarray, np.ndarray]:
    """(volume, centre, inertia per unit density) of a mesh file scaled per axis, in its own frame; its convex
    hull's where it does not close a volume; (0, 0, 0) where not even the hull has one (a flat mesh).  Cached:
    the loader's meshes are content-keyed OBJ files."""
    import trimesh

    loaded: Any = trimesh.load(path, force="mesh")
    vertices = np.asarray(loaded.vertices, dtype=np.float64) * np.asarray(scale, dtype=np.float64)
    mesh = trimesh.Trimesh(vertices=vertices, faces=loaded.faces, process=True)
    try:
        with warnings.catch_warnings():  # a flat mesh's centre divides by its volume of 0
            warnings.simplefilter("ignore", RuntimeWarning)
            if not mesh.is_volume:
                mesh = mesh.convex_hull
            volume = float(mesh.volume)
        if not volume > 0:
            return 0.0, np.zeros(3), np.zeros((3, 3))
        mesh.density = 1.0
        return volume, np.asarray(mesh.center_mass, dtype=float), np.asarray(mesh.moment_inertia, dtype=float)
    except Exception:  # qhull refuses a flat or degenerate point set: it has no volume
        return 0.0, np.zeros(3), np.zeros((3, 3))


def shape_solid(shape: Shape) -> Solid:
    """One shape as a solid of density 1, in its link's frame.

    Args:
        shape: a box, sphere, cylinder (along its own z) or mesh, placed in its link's frame.

    Returns:
        Its volume, centre of volume and inertia about that centre per unit density, in the link frame.
    """
    centre = np.zeros(3)
    if isinstance(shape, Box):
        volume, inertia = _box(np.asarray(shape.half, dtype=float))
    elif isinstance(shape, Sphere):
        volume, inertia = _sphere(float(shape.radius))
    elif isinstance(shape, Cylinder):
        volume, inertia = _cylinder(float(shape.radius), float(shape.length))
    elif isinstance(shape, Mesh):
        sx, sy, sz = shape.scale
        volume, centre, inertia = _mesh(shape.path, (float(sx), float(sy), float(sz)))
    else:  # pragma: no cover - Shape is a closed union
        raise TypeError(f"not a shape: {shape!r}")
    turn = rpy_matrix(shape.rpy) if shape.rpy != ZERO3 else np.eye(3)
    return Solid(volume, np.asarray(shape.center, dtype=float) + turn @ centre, turn @ inertia @ turn.T)


def solid_of(shapes: Sequence[Shape]) -> Solid | None:
    """A link's shapes as one solid of density 1 (overlaps counted twice, as MuJoCo does).

    Args:
        shapes: the link's shapes, in its frame.

    Returns:
        The solid, or None where the shapes hold no volume (no shapes, or flat meshes only).
    """
    parts = [s for s in map(shape_solid, shapes) if s.volume > 0]
    if not parts:
        return None
    volume = sum(p.volume for p in parts)
    centre = sum(p.volume * p.centre for p in parts) / volume
    inertia = np.zeros((3, 3))
    for p in parts:  # each moved to the common centre (parallel axes)
        d = p.centre - centre
        inertia += p.inertia + p.volume * (float(d @ d) * np.eye(3) - np.outer(d, d))
    return Solid(float(volume), np.asarray(centre, dtype=float), (inertia + inertia.T) / 2)


def with_solid_mass(link: Link, solid: Solid, density: float) -> Link:
    """``link`` with the mass, centre of mass and inertia of ``solid`` at ``density``.

    Args:
        link: the link (its own mass, if any, is replaced).
        solid: its shapes as a solid (:func:`solid_of`).
        density: [kg/m^3].

    Returns:
        The link with that mass [kg], centre of mass and inertia (in the link frame: products where it is not
        diagonal there; those below 1e-12 of its largest moment are 0).
    """
    mass, centre, inertia = solid.at(density)
    small = 1e-12 * float(np.abs(inertia).max())
    clean = np.where(np.abs(inertia) < small, 0.0, inertia)
    return replace(
        link,
        mass=float(mass),
        com=(float(centre[0]), float(centre[1]), float(centre[2])),
        inertia=(float(clean[0, 0]), float(clean[1, 1]), float(clean[2, 2])),
        products=(float(clean[0, 1]), float(clean[0, 2]), float(clean[1, 2])),
        inertia_rpy=ZERO3,
    )
