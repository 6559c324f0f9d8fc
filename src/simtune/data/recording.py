"""The in-memory form of one recording (marker poses, joint angles or both), and the checks every loader shares."""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from simtune.errors import RecordingError, RecordingWarning

#: Body order of the headerless qrg2019 Qualisys files: base marker, wrist marker, cube.
QRG2019_BODIES: list[str] = ["RB2(Black)", "RB1(Orange)", "PCube"]

# Coordinates beyond this many metres cannot come from a table-top lab set-up;
# such values mean the file is in other units than its format promises.
MAX_ABS_COORD_M = 10.0

# Largest tolerated |R R^T - I| entry; Qualisys rounds Rot[] to 5 decimals.
_ORTHO_TOL = 1e-2

#: A joint angle beyond two turns [rad] is not one an arm reaches in a take: such values are
#: degrees in a file (or a column) that promises radians.  Degrees of a motion that stays
#: within +-12.6 deg pass unnoticed; the check catches the common case of any real motion.
MAX_ABS_JOINT_RAD = 4 * math.pi
#: how a joint log says it is in degrees whatever its format (the task file's key, docs/task-files.md)
DEGREES_HINT = 'or units = "deg" in the [recordings] table of the task file'


@dataclass
class Recording:
    """One repeat of one task as read from disk.

    ``positions[name]`` is (n, 3) in metres and ``rotations[name]`` is (n, 3, 3)
    body-to-world rotation matrices (column j = body axis j in world frame);
    both are NaN at frames where the body's markers were lost.  ``joints[name]``
    is (n,) joint angles in radians, never NaN (an encoder is read every frame;
    readers refuse a missing value).  A recording may hold marker bodies, joints
    or both.  ``lines`` is each frame's line number in its file (for messages),
    or its frame number in a binary file (``line_word`` "frame"); None when the
    recording was made in memory or its frames number nothing in the file.
    """

    source: Path
    time: np.ndarray
    positions: dict[str, np.ndarray] = field(default_factory=dict)
    rotations: dict[str, np.ndarray] = field(default_factory=dict)
    lines: np.ndarray | None = None
    joints: dict[str, np.ndarray] = field(default_factory=dict)
    line_word: str = "line"  # what ``lines`` counts: "line" of a text file, "frame" of a binary one
    #: joint -> the angle unit its file or the task declared ("rad", "deg"); a joint not named was read as
    #: radians because its format says so, and the units check of task data tells degrees from its values
    joint_units: dict[str, str] = field(default_factory=dict)

    def where(self, frame: int) -> str:
        """``line N`` (or ``frame N`` without line numbers) of a 0-based frame index, for messages."""
        if self.lines is None:
            return f"frame {frame + 1}"
        return f"{self.line_word} {int(self.lines[frame])}"

    @property
    def bodies(self) -> list[str]:
        """Body names in file order."""
        return list(self.positions)

    def __len__(self) -> int:
        return int(self.time.shape[0])


def frame_list(frames: np.ndarray, limit: int = 8) -> str:
    """Compact, bounded listing of (1-based) frame or line numbers for messages."""
    items = [str(int(f)) for f in frames[:limit]]
    if len(frames) > limit:
        items.append(f"... ({len(frames)} in all)")
    return ", ".join(items)


def lost_positions(xyz: np.ndarray, zero_is_lost: bool) -> np.ndarray:
    """Boolean (n,) mask of frames whose position is missing (any NaN, or exactly 0,0,0)."""
    lost = np.isnan(xyz).any(axis=1)
    if zero_is_lost:
        lost |= (xyz == 0.0).all(axis=1)
    return lost


def clean_rotations(rot: np.ndarray, name: str, display: str) -> np.ndarray:
    """NaN out lost (all-zero or partly empty) matrices; warn about non-rotations."""
    rot = rot.copy()
    flat = rot.reshape(len(rot), 9)
    lost = np.isnan(flat).any(axis=1) | (flat == 0.0).all(axis=1)
    rot[lost] = np.nan
    ok = ~lost
    if ok.any():
        r = rot[ok]
        # Damaged cells can hold huge numbers; overflow just marks them as bad.
        with np.errstate(all="ignore"):
            err = np.abs(r @ r.transpose(0, 2, 1) - np.eye(3)).max(axis=(1, 2))
            det = np.linalg.det(r)
        bad = ~(err <= _ORTHO_TOL) | ~(det > 0)
        if bad.any():
            frames = np.flatnonzero(ok)[bad] + 1
            warnings.warn(
                f"{display}: rotation of {name!r} is not a rotation matrix at frames "
                f"{frame_list(frames)}; set to NaN there",
                RecordingWarning,
                stacklevel=4,
            )
            idx = np.flatnonzero(ok)[bad]
            rot[idx] = np.nan
    return rot


def check_units(
    positions: dict[str, np.ndarray], linenos: np.ndarray, display: str, message: str, line_word: str = "line"
) -> None:
    """Reject coordinates beyond MAX_ABS_COORD_M; ``message`` is formatted with the value."""
    for name, xyz in positions.items():
        mag = np.abs(xyz)
        if not np.any(mag > MAX_ABS_COORD_M):  # NaN compares False: lost markers pass
            continue
        row = int(np.flatnonzero((mag > MAX_ABS_COORD_M).any(axis=1))[0])
        peak = float(np.nanmax(mag))
        raise RecordingError(
            f"{display} {line_word} {int(linenos[row])}: units check: body {name!r} " + message.format(peak=peak)
        )


def finish_recording(
    source: Path,
    display: str,
    time: np.ndarray,
    linenos: np.ndarray,
    positions: dict[str, np.ndarray],
    rotations: dict[str, np.ndarray],
    joints: dict[str, np.ndarray] | None = None,
    line_word: str = "line",
) -> Recording:
    """Check the time column, drop duplicate frames and build the Recording (``line_word``: what linenos count)."""
    joints = {} if joints is None else joints
    bad = np.flatnonzero(~np.isfinite(time))
    if bad.size:
        i = int(bad[0])
        raise RecordingError(f"{display} {line_word} {int(linenos[i])}: time check: the time is missing or not finite")
    step = np.diff(time)
    back = np.flatnonzero(step < 0)
    if back.size:
        i = int(back[0]) + 1
        raise RecordingError(
            f"{display} {line_word} {int(linenos[i])}: time check: the time goes backwards "
            f"({time[i]:.6g} s after {time[i - 1]:.6g} s)"
        )
    dup = np.flatnonzero(step == 0) + 1
    if dup.size:
        # Qualisys repeats a frame when a buffer is re-sent; the first copy is kept.
        warnings.warn(
            f"{display}: time check: dropped {dup.size} duplicate frame(s) repeating the previous time "
            f"at {line_word}s {frame_list(linenos[dup])}",
            RecordingWarning,
            stacklevel=4,
        )
        keep = np.ones(time.shape[0], dtype=bool)
        keep[dup] = False
        time = time[keep]
        linenos = linenos[keep]
        positions = {k: v[keep] for k, v in positions.items()}
        rotations = {k: v[keep] for k, v in rotations.items()}
        joints = {k: v[keep] for k, v in joints.items()}
    if time.shape[0] < 2:
        raise RecordingError(
            f"{display} {line_word} {int(linenos[0])}: only {time.shape[0]} valid frame; need at least 2"
        )
    return Recording(
        source=Path(source),
        time=time,
        positions=positions,
        rotations=rotations,
        lines=linenos,
        joints=joints,
        line_word=line_word,
    )


def check_for_writing(rec: Recording, display: str, forbidden: str) -> int:
    """Validate shapes and body names of ``rec`` before writing; returns the frame count."""
    time = np.asarray(rec.time)
    if time.ndim != 1 or time.shape[0] < 1:
        raise RecordingError(f"{display}: cannot write: time must be a non-empty 1-D array")
    n = time.shape[0]
    if set(rec.positions) != set(rec.rotations):
        raise RecordingError(f"{display}: cannot write: positions and rotations name different bodies")
    for name in rec.positions:
        if not name or any(ch in name for ch in forbidden):
            raise RecordingError(f"{display}: cannot write: body name {name!r} is not allowed")
        if np.shape(rec.positions[name]) != (n, 3):
            raise RecordingError(
                f"{display}: cannot write: positions[{name!r}] has shape "
                f"{np.shape(rec.positions[name])}, expected ({n}, 3)"
            )
        if np.shape(rec.rotations[name]) != (n, 3, 3):
            raise RecordingError(
                f"{display}: cannot write: rotations[{name!r}] has shape "
                f"{np.shape(rec.rotations[name])}, expected ({n}, 3, 3)"
            )
    for name, angles in rec.joints.items():
        if not name or name in rec.positions or any(ch in name for ch in forbidden):
            raise RecordingError(f"{display}: cannot write: joint name {name!r} is not allowed")
        if np.shape(angles) != (n,):
            raise RecordingError(
                f"{display}: cannot write: joints[{name!r}] has shape {np.shape(angles)}, expected ({n},)"
            )
    return n
