"""Format dispatch: one entry point for every recording simtune reads."""

from __future__ import annotations

from collections.abc import Collection
from pathlib import Path

from simtune.data._table import display_name
from simtune.data.formats import RECORDING_SUFFIXES, ReadOptions, RecordingFormat, expected_names, format_of
from simtune.data.lerobot import LeRobotReading
from simtune.data.recording import Recording
from simtune.errors import RecordingError

__all__ = ["RECORDING_SUFFIXES", "ReadOptions", "is_recording_file", "load_recording", "load_recordings"]


def is_recording_file(path: Path) -> bool:
    """Whether a path is a recording simtune reads.

    Args:
        path: a file or folder.

    Returns:
        True for a file named with one of RECORDING_SUFFIXES (case-insensitive), or a folder that one of the
        folder formats (a rosbag2 folder, a LeRobot dataset) recognises.
    """
    path = Path(path)
    fmt = format_of(path)
    return fmt is not None and (fmt.is_folder is not None) == path.is_dir()


def load_recording(
    path: Path | str,
    body_names: list[str] | None = None,
    *,
    joint_names: Collection[str] | None = None,
    joint_topic: str | None = None,
    joint_units: str | None = None,
) -> Recording:
    """Load a recording, its format told by its name or its folder (:data:`simtune.data.formats.FORMATS`;
    docs/recordings.md).

    For text files the name picks the format only: compression and text
    encoding are read from the content (see :func:`simtune.data._table.decode_content`).

    Args:
        path: a recording file, or a rosbag2 folder (a LeRobot dataset holds many: :func:`load_recordings`).
        body_names: the bodies of a headerless TSV in column order (default QRG2019_BODIES); a TSV header's
            BODY_NAMES wins, and CSV files carry their own names.
        joint_names: the joints a recording may name (the arm's); None accepts any.
        joint_topic: the topic of a ROS 2 log's JointState messages (default: the one JointState topic).
        joint_units: ("rad", "deg") the unit of joint angles whose file does not declare one (the task's;
            None: the format's, radians).

    Returns:
        The recording.
    """
    path = Path(path)
    fmt = _format(path)
    if fmt.episodes:
        raise RecordingError(f"{display_name(path)}: a {fmt.folder} holds many episodes: read it with load_recordings")
    (recording,) = fmt.read(path, ReadOptions(body_names, joint_names, joint_topic, joint_units))
    return recording


def _format(path: Path) -> RecordingFormat:
    """The format of ``path`` (:func:`simtune.data.formats.format_of`), or a RecordingError naming it."""
    fmt = format_of(path)
    if fmt is None:
        raise RecordingError(f"{display_name(path)}: unknown recording format (expected {expected_names()})")
    return fmt


def load_recordings(
    path: Path | str,
    body_names: list[str] | None = None,
    *,
    joint_names: Collection[str] | None = None,
    joint_topic: str | None = None,
    lerobot: LeRobotReading | None = None,
) -> list[Recording]:
    """The repeats one recording source holds: each episode of a LeRobot dataset folder, else the one recording
    :func:`load_recording` reads.

    Args:
        path: a recording file or folder.
        body_names: as for :func:`load_recording`.
        joint_names: as for :func:`load_recording`.
        joint_topic: as for :func:`load_recording`.
        lerobot: how the task reads a dataset (its angle unit, names and episodes); its unit is the task's unit
            of every joint log.

    Returns:
        The repeats, in the source's order.
    """
    path = Path(path)
    fmt = _format(path)
    units = None if lerobot is None else lerobot.units  # the task's unit, for every joint log
    return fmt.read(path, ReadOptions(body_names, joint_names, joint_topic, units, lerobot))
