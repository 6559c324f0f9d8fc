"""The tracked body's recorded orientation over stretches of a task's clock, where the recordings hold one.

A :class:`~simtune.data.TaskData` keeps the wrist's position only (the fitness scores positions); the check's
inverse kinematics also wants the orientation the real wrist rested in.  A motion-capture rigid body of several
markers records it (Qualisys 6D, simtune CSV with a quaternion); a single marker, a C3D point or a body whose
rotation was never tracked does not (NaN rotations).  The recordings are read again here, each repeat on the
reference's clock (its alignment shift added, as :func:`simtune.data.task.load_task_data` resampled it).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from simtune.data.loaders import load_recording
from simtune.data.task import TaskData


class RecordedRotations:
    """The rotations of ``body`` (body to world, (3, 3)) in each repeat that built ``reference``.

    Args:
        reference: the task's reference (its sources, and the clock shifts of an aligned one).
        body: the motion-capture body whose rotation is read (the wrist's).
    """

    def __init__(self, reference: TaskData, body: str):
        shifts = np.zeros(len(reference.sources)) if reference.alignment is None else reference.alignment.shifts
        #: per repeat that tracks the body's rotation: its frames' times on the reference's clock, and the rotations
        self.repeats: list[tuple[np.ndarray, np.ndarray]] = []
        for source, shift in zip(reference.sources, shifts):
            rec = load_recording(Path(source))
            rotations = rec.rotations.get(body)
            if rotations is None:
                continue
            seen = np.isfinite(rotations).all(axis=(1, 2))
            if seen.any():
                self.repeats.append(((rec.time - rec.time[0] + shift)[seen], rotations[seen]))

    @property
    def available(self) -> bool:
        """Whether any repeat recorded the body's rotation."""
        return bool(self.repeats)

    def mean(self, start: float, end: float) -> np.ndarray | None:
        """The mean rotation (3, 3) over every repeat's frames from ``start`` to ``end`` [s] on the reference's
        clock (the chordal mean of their quaternions), or None where no repeat tracked it then."""
        from scipy.spatial.transform import Rotation

        frames = [rot[(t >= start) & (t <= end)] for t, rot in self.repeats]
        frames = [f for f in frames if len(f)]
        if not frames:
            return None
        return Rotation.from_matrix(np.concatenate(frames)).mean().as_matrix()
