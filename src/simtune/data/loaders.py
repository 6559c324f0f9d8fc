"""Format dispatch: one entry point for every recording simtune reads."""

from __future__ import annotations

from collections.abc import Callable, Collection
from dataclasses import dataclass
from pathlib import Path

from simtune.data._table import display_name
from simtune.data.c3dformat import read_c3d
from simtune.data.csvformat import read_csv
from simtune.data.lerobot import LeRobotReading, is_lerobot_dataset, read_lerobot_dataset
from simtune.data.qualisys import read_qualisys_tsv
from simtune.data.recording import Recording
from simtune.data.rosbag import is_bag_folder, read_joint_bag
from simtune.errors import RecordingError


@dataclass(frozen=True)
class ReadOptions:
    """What a reader may need besides the file: see :func:`load_recording`."""

    body_names: list[str] | None = None
    joint_names: Collection[str] | None = None
    joint_topic: str | None = None
    joint_units: str | None = None


#: The file formats, by name ending (lower case): a new format is a module in data/ and one line here.
FILE_FORMATS: tuple[tuple[tuple[str, ...], Callable[[Path, ReadOptions], Recording]], ...] = (
    ((".tsv", ".tsv.gz"), lambda path, o: read_qualisys_tsv(path, o.body_names)),
    ((".csv", ".csv.gz"), lambda path, o: read_csv(path, o.joint_names, o.joint_units)),
    ((".c3d",), lambda path, o: read_c3d(path)),
    ((".mcap",), lambda path, o: read_joint_bag(path, o.joint_names, o.joint_topic, o.joint_units)),
)
#: File endings load_recording understands (lower case); a rosbag2 folder is a recording too.
RECORDING_SUFFIXES = tuple(ending for endings, _ in FILE_FORMATS for ending in endings)


def is_recording_file(path: Path) -> bool:
    """True for a file named with one of RECORDING_SUFFIXES (case-insensitive), a rosbag2 folder or a LeRobot
    dataset folder."""
    path = Path(path)
    if path.is_dir():
        return is_bag_folder(path) or is_lerobot_dataset(path)
    return path.name.lower().endswith(RECORDING_SUFFIXES)


def load_recording(
    path: Path | str,
    body_names: list[str] | None = None,
    *,
    joint_names: Collection[str] | None = None,
    joint_topic: str | None = None,
    joint_units: str | None = None,
) -> Recording:
    """Load a recording, its format told by its name (see docs/recordings.md).

    ``.tsv[.gz]``: Qualisys 6D TSV (mm); ``.csv[.gz]``: simtune CSV (m, and
    joint angles); ``.c3d``: C3D marker points (positions only);
    ``.mcap`` or a rosbag2 folder: ROS 2 JointState messages
    (of ``joint_topic``, by default the one JointState topic).  For text files
    the name picks the format only: compression and text encoding are read
    from the content (see :func:`simtune.data._table.decode_content`).

    ``body_names`` names the bodies of a headerless TSV in column order
    (default QRG2019_BODIES); a TSV header's BODY_NAMES wins, and CSV files
    carry their own names.  ``joint_names`` are the joints a recording may
    name (the arm's); None accepts any.  ``joint_units`` ("rad", "deg") is the
    unit of joint angles whose file does not declare one (the task's; None:
    the format's, radians).
    """
    path = Path(path)
    name = path.name.lower()
    if is_lerobot_dataset(path):
        raise RecordingError(
            f"{display_name(path)}: a LeRobot dataset holds many episodes: read it with load_recordings"
        )
    options = ReadOptions(body_names, joint_names, joint_topic, joint_units)
    if is_bag_folder(path):
        return read_joint_bag(path, joint_names, joint_topic, joint_units)
    for endings, read in FILE_FORMATS:
        if name.endswith(endings):
            return read(path, options)
    raise RecordingError(
        f"{display_name(path)}: unknown recording format "
        f"(expected {', '.join(RECORDING_SUFFIXES)}, or a rosbag2 folder)"
    )


def load_recordings(
    path: Path | str,
    body_names: list[str] | None = None,
    *,
    joint_names: Collection[str] | None = None,
    joint_topic: str | None = None,
    lerobot: LeRobotReading | None = None,
) -> list[Recording]:
    """The repeats one recording source holds: each episode of a LeRobot dataset folder (``lerobot``: its
    angle unit, names and episodes), else the one recording :func:`load_recording` reads."""
    path = Path(path)
    if is_lerobot_dataset(path):
        return read_lerobot_dataset(path, joint_names, lerobot)
    units = None if lerobot is None else lerobot.units  # the task's unit, for every joint log
    return [load_recording(path, body_names, joint_names=joint_names, joint_topic=joint_topic, joint_units=units)]
