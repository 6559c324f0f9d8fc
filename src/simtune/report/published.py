"""Published simulations (e.g. the qrg2019 authors' untuned runs), scored with simtune's own fitness.

A file ``<task>_<Engine>.csv`` is space separated at 20 Hz, one row per
sample k at time k * 0.05 s: end-effector x y z [m], its quaternion (x y z w;
PyBullet files w x y z), object x y z [m], object quaternion.  It becomes a
:class:`simtune.engines.Rollout` as long as the task's recordings (a shorter
file holds its last row, a longer one is cut) and is scored with
:func:`simtune.fitness.score_rollout`, exactly like a simtune engine's rollout
with generic parameters.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from simtune.data import TaskData
from simtune.engines import Rollout
from simtune.errors import SimtuneError
from simtune.fitness import TaskScore, score_rollout

PUBLISHED_RATE = 20.0
COLUMNS = 14
#: engines whose published end-effector quaternion is ordered w x y z (the others: x y z w)
WXYZ_ENGINES = {"pybullet"}


@dataclass
class PublishedSim:
    task: str
    engine: str  # as in the file name, e.g. "Mujoco", "VRepBullet283"
    path: Path
    rows: np.ndarray  # (m, 14)

    @property
    def label(self) -> str:
        return f"{self.engine} (published)"


def find_published(folder: Path, tasks: list[str]) -> list[PublishedSim | tuple[Path, str]]:
    """The published simulations in ``folder`` for ``tasks``: PublishedSim, or (file, reason) for an unreadable one."""
    folder = Path(folder)
    if not folder.is_dir():
        raise SimtuneError(f"--published-sims {folder}: no such folder")
    found: list[PublishedSim | tuple[Path, str]] = []
    for path in sorted(folder.iterdir()):
        if not path.is_file() or "_" not in path.stem:
            continue
        task, engine = path.stem.split("_", 1)
        if task not in tasks:
            continue
        try:
            found.append(PublishedSim(task, engine, path, read_published(path)))
        except SimtuneError as exc:
            found.append((path, str(exc)))
    return found


def read_published(path: Path) -> np.ndarray:
    """The rows of one published simulation file, checked: (m, 14) finite floats."""
    try:
        rows = np.loadtxt(path, ndmin=2)
    except (OSError, ValueError) as exc:
        raise SimtuneError(f"{path}: cannot read as space-separated numbers ({exc})") from None
    if rows.shape[0] == 0:
        raise SimtuneError(f"{path}: empty file")
    if rows.shape[1] != COLUMNS:
        raise SimtuneError(
            f"{path}: {rows.shape[1]} columns, expected {COLUMNS} (x y z, quaternion, object x y z, object quaternion)"
        )
    if not np.all(np.isfinite(rows)):
        bad = int(np.flatnonzero(~np.isfinite(rows).all(axis=1))[0])
        raise SimtuneError(f"{path} line {bad + 1}: non-finite value")
    return rows


def quaternion_matrices(q: np.ndarray, order: str = "xyzw") -> np.ndarray:
    """Rotation matrices (n, 3, 3) of unit quaternions (n, 4) in ``order`` ("xyzw" or "wxyz")."""
    q = np.asarray(q, dtype=float)
    if order == "wxyz":
        q = q[:, [1, 2, 3, 0]]
    norm = np.linalg.norm(q, axis=1, keepdims=True)
    q = np.where(norm > 0, q / np.where(norm > 0, norm, 1.0), np.array([0.0, 0.0, 0.0, 1.0]))
    x, y, z, w = q.T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], axis=1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], axis=1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=1),
        ],
        axis=1,
    )


def published_rollout(sim: PublishedSim, n: int) -> Rollout:
    """The published simulation as a rollout of ``n`` samples at 20 Hz (last row held, or cut)."""
    rows = sim.rows[:n]
    if len(rows) < n:
        rows = np.vstack([rows, np.repeat(rows[-1:], n - len(rows), axis=0)])
    order = "wxyz" if sim.engine.lower() in WXYZ_ENGINES else "xyzw"
    return Rollout(
        times=np.arange(n) / PUBLISHED_RATE,
        wrist_pos=rows[:, 0:3].copy(),
        wrist_rot=quaternion_matrices(rows[:, 3:7], order),
        joint_angles=np.zeros((n, 6)),
        object_pos=rows[:, 7:10].copy(),
    )


def score_published(sim: PublishedSim, reference: TaskData) -> tuple[TaskScore, Rollout]:
    """simtune's fitness of a published simulation against the task's recordings (no marker offset)."""
    rollout = published_rollout(sim, len(reference.times))
    return score_rollout(rollout, reference, {}), rollout
