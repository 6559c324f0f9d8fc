"""Every recording format simtune reads and writes: one :class:`RecordingFormat` record each, in :data:`FORMATS`.

A record says how a format is told (file name endings, or a test of a folder), how it is read, how
``simtune synth`` writes it (its :class:`Writer` records, none for a format simtune only reads), what it
holds, and the optional extra it needs.  The loaders (:mod:`simtune.data.loaders`), the fingerprint
(:mod:`simtune.data.fingerprint`), ``simtune synth``, ``simtune init``, the command line's help and the tables
of docs/recordings.md all read them: a new format is its reader (and writer) module and one record here.
:func:`write_docs` rewrites docs/recordings.md's tables from the records (``tests/test_formats.py`` checks them).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass
from pathlib import Path

from simtune.data.c3dformat import read_c3d
from simtune.data.csvformat import read_csv, write_csv
from simtune.data.lerobot import (
    SYNTH_FPS,
    LeRobotReading,
    WrittenTask,
    dataset_members,
    is_lerobot_dataset,
    read_lerobot_dataset,
    stated_units,
    write_task_dataset,
)
from simtune.data.qualisys import read_qualisys_tsv, write_qualisys_tsv
from simtune.data.recording import Recording
from simtune.data.rosbag import is_bag_folder, read_joint_bag, write_joint_bag
from simtune.errors import ConfigError


@dataclass(frozen=True)
class ReadOptions:
    """What a reader may need besides the file (see :func:`simtune.data.loaders.load_recording`).

    ``joint_units`` is the unit of joint angles whose file states none (the task's); ``lerobot`` how a task
    reads a dataset (angle unit, names, episodes).
    """

    body_names: list[str] | None = None
    joint_names: Collection[str] | None = None
    joint_topic: str | None = None
    joint_units: str | None = None
    lerobot: LeRobotReading | None = None


#: a reader: the path and the options -> the repeats it holds (one, or each episode of a dataset)
Reader = Callable[[Path, ReadOptions], list[Recording]]
#: a writer: the task's folder, the repeats of the task and the task -> the files or folders written
WriteRepeats = Callable[[Path, Sequence[Recording], WrittenTask], list[Path]]
#: a writer of different episodes: the task's folder, the recordings and, per recording, the task whose schedule it
#: ran (``synth --episodes``) -> the dataset written
WriteEpisodes = Callable[[Path, Sequence[Recording], Sequence[WrittenTask]], list[Path]]


@dataclass(frozen=True)
class Writer:
    """One way ``simtune synth --format NAME`` writes a format."""

    name: str  # the --format value
    description: str  # one line: what each repeat holds and where
    write: WriteRepeats
    markers: bool = False  # writes the marker bodies
    joints: bool = False  # writes the joint angles
    ending: str = ""  # of each repeat's file name ("": a folder, or the repeats are one dataset)
    rate: float | None = None  # samples per second written (None: synth's own)
    dataset: bool = False  # each task's repeats one dataset, OUT/<task>/ (each repeat an episode)
    check: Callable[[WrittenTask], object] | None = None  # refuses a task before anything is simulated
    episodes: WriteEpisodes | None = None  # a dataset writer's different episodes, each its own commands


@dataclass(frozen=True)
class RecordingFormat:
    """One recording format: how it is told, read and written, and what it holds.

    A file format gives its name ``endings`` (lower case); a folder format gives ``folder`` (what such a folder
    is called, "rosbag2 folder") and ``is_folder`` (the test of a folder), and ``members`` where only some of
    its files are the recording (the fingerprint hashes those; else every file under it).
    """

    name: str
    description: str  # one line: the format's own name and what it holds
    read: Reader
    endings: tuple[str, ...] = ()
    folder: str = ""
    is_folder: Callable[[Path], bool] | None = None
    members: Callable[[Path], list[Path]] | None = None
    episodes: bool = False  # holds many repeats (its episodes); a task's folder may itself be one
    markers: bool = False  # may hold marker bodies
    joints: bool = False  # may hold joint angles
    units: str = ""  # the units its values are in
    extra: str | None = None  # the optional extra it needs: pip install 'simtune[EXTRA]'
    writers: tuple[Writer, ...] = ()

    def __post_init__(self) -> None:
        if bool(self.endings) == (self.is_folder is not None) or bool(self.folder) != (self.is_folder is not None):
            raise ValueError(f"recording format {self.name!r}: give either endings or a folder and its test")

    @property
    def shown(self) -> str:
        """How lists name its recordings: ``*.tsv`` or ``rosbag2 folders``."""
        return f"*{self.endings[0]}" if self.endings else f"{self.folder}s"


def _each(write_one: Callable[[Path, Recording], object]) -> WriteRepeats:
    """A writer of one file (or folder) per repeat, named as the repeat's source, in the task's folder."""

    def write(folder: Path, recordings: Sequence[Recording], task: WrittenTask) -> list[Path]:
        written = []
        for rec in recordings:
            path = folder / rec.source.name
            result = write_one(path, rec)
            written.append(result if isinstance(result, Path) else path)
        return written

    return write


def _bag_writer(name: str, where: str, storage: str, ending: str = "") -> Writer:
    """Each repeat's joint angles as JointState messages in ``where``, rosbag2's ``storage`` ("mcap", "sqlite3")."""
    return Writer(
        name,
        f"joint angles alone as sensor_msgs/JointState in {where}",
        _each(lambda path, rec: write_joint_bag(path, rec, storage=storage)),
        joints=True,
        ending=ending,
    )


def _dataset_writer(name: str, description: str, version: str) -> Writer:
    """Each task's repeats as the episodes of one LeRobot dataset in layout ``version``, at :data:`SYNTH_FPS`."""
    return Writer(
        name,
        description,
        lambda folder, recordings, task: [write_task_dataset(folder, task, recordings, version)],
        joints=True,
        rate=SYNTH_FPS,
        dataset=True,
        check=stated_units,
        episodes=lambda folder, recordings, ran: [write_task_dataset(folder, ran[0], recordings, version, ran)],
    )


def _read_bag(path: Path, o: ReadOptions) -> list[Recording]:
    return [read_joint_bag(path, o.joint_names, o.joint_topic, o.joint_units)]


FORMATS: tuple[RecordingFormat, ...] = (
    RecordingFormat(
        "tsv",
        'Qualisys Track Manager "6D" TSV export: markers',
        lambda path, o: [read_qualisys_tsv(path, o.body_names)],
        endings=(".tsv", ".tsv.gz"),
        markers=True,
        units="mm, degrees",
        writers=(
            Writer(
                "tsv",
                "markers in a Qualisys 6D TSV with header (as real recordings come)",
                _each(lambda path, rec: write_qualisys_tsv(path, rec, header=True)),
                markers=True,
                ending=".tsv",
            ),
        ),
    ),
    RecordingFormat(
        "csv",
        "simtune CSV: markers and/or joint angles",
        lambda path, o: [read_csv(path, o.joint_names, o.joint_units)],
        endings=(".csv", ".csv.gz"),
        markers=True,
        joints=True,
        units="m, quaternion; rad (or declared deg)",
        writers=(
            Writer(
                "csv",
                "markers and joint angles in one simtune CSV",
                _each(write_csv),
                markers=True,
                joints=True,
                ending=".csv",
            ),
            Writer(
                "joints-csv",
                "joint angles alone in a simtune CSV",
                _each(lambda path, rec: write_csv(path, Recording(rec.source, rec.time, joints=rec.joints))),
                joints=True,
                ending=".csv",
            ),
        ),
    ),
    RecordingFormat(
        "c3d",
        "C3D (biomechanics motion capture): marker points, no orientation",
        lambda path, o: [read_c3d(path)],
        endings=(".c3d",),
        markers=True,
        units="`POINT:UNITS` (mm, cm, m)",
        extra="c3d",
    ),
    RecordingFormat(
        "mcap",
        "ROS 2 `sensor_msgs/msg/JointState` messages in an MCAP file: joint angles",
        _read_bag,
        endings=(".mcap",),
        joints=True,
        units="rad",
        extra="ros",
        writers=(_bag_writer("mcap", "an MCAP file", "mcap", ".mcap"),),
    ),
    RecordingFormat(
        "rosbag2",
        "ROS 2 `sensor_msgs/msg/JointState` messages in a rosbag2 folder (SQLite 3 or MCAP storage): joint angles",
        _read_bag,
        folder="rosbag2 folder",
        is_folder=is_bag_folder,
        joints=True,
        units="rad",
        extra="ros",
        writers=(_bag_writer("rosbag2", "a rosbag2 folder (SQLite 3 storage)", "sqlite3"),),
    ),
    RecordingFormat(
        "lerobot",
        "LeRobot v2.0, v2.1, v3.0 dataset (Parquet): joint angles (and commanded targets), one repeat per episode",
        lambda path, o: read_lerobot_dataset(path, o.joint_names, o.lerobot),
        folder="LeRobot dataset",
        is_folder=is_lerobot_dataset,
        members=dataset_members,
        episodes=True,
        joints=True,
        units="stated in the task file: deg or rad",
        extra="lerobot",
        writers=(
            _dataset_writer(
                "lerobot",
                "joint angles and commanded targets as a LeRobot v3.0 dataset (`OUT/<task>/` is the dataset; the "
                "task file states the unit: [recordings] units)",
                "v3.0",
            ),
            _dataset_writer("lerobot-v2.1", "the same in LeRobot's v2.1 layout (one Parquet file per episode)", "v2.1"),
        ),
    ),
)

#: File endings that name a recording file (lower case).
RECORDING_SUFFIXES = tuple(ending for fmt in FORMATS for ending in fmt.endings)
#: ``simtune synth --format``: every writer, by name.
WRITERS: dict[str, Writer] = {writer.name: writer for fmt in FORMATS for writer in fmt.writers}


def format_of(path: Path) -> RecordingFormat | None:
    """The format of a recording.

    Args:
        path: a file or folder.

    Returns:
        The format whose folder test a folder passes (a dataset's first, whatever else it holds), else the one
        whose endings end its name (case-insensitive); None for none.
    """
    path = Path(path)
    if path.is_dir():
        for fmt in sorted(FORMATS, key=lambda f: not f.episodes):
            if fmt.is_folder is not None and fmt.is_folder(path):
                return fmt
    name = path.name.lower()
    return next((fmt for fmt in FORMATS if fmt.endings and name.endswith(fmt.endings)), None)


def writer(name: str) -> Writer:
    """The writer ``simtune synth --format NAME`` uses.

    Args:
        name: a key of :data:`WRITERS`.

    Returns:
        Its writer; a ConfigError naming ``--format`` and the known names for another name.
    """
    if name not in WRITERS:
        raise ConfigError(f"--format: unknown format {name!r} (known: {', '.join(WRITERS)})")
    return WRITERS[name]


def recording_kinds(holding: str = "") -> str:
    """The recordings a task's folder may hold, for messages and help (``*.tsv, *.csv, ... rosbag2 folders``).

    Args:
        holding: ``"markers"`` or ``"joints"``: only the formats that may hold them; "" every format.

    Returns:
        Their names joined by commas.
    """
    picked = [fmt for fmt in FORMATS if not holding or getattr(fmt, holding)]
    return ", ".join(fmt.shown for fmt in picked)


def expected_names() -> str:
    """What :func:`simtune.data.loaders.load_recording` reads, for its refusal of another name.

    Returns:
        Every file ending, then ``or a <folder>`` for each folder format of one repeat.
    """
    folders = [f"a {fmt.folder}" for fmt in FORMATS if fmt.folder and not fmt.episodes]
    return ", or ".join([", ".join(RECORDING_SUFFIXES), *folders])


# --- docs/recordings.md's tables --------------------------------------------------------------------------------


def markdown_tables() -> dict[str, str]:
    """docs/recordings.md's tables of the formats read (``read``) and written by synth (``synth``).

    Returns:
        Table name -> its Markdown lines, joined.
    """
    read = ["| ending or folder | format | install | units |", "|---|---|---|---|"]
    for fmt in FORMATS:
        told = ", ".join(f"`{e}`" for e in fmt.endings) or f"a {fmt.folder}"
        extra = f"`pip install 'simtune[{fmt.extra}]'`" if fmt.extra else "-"
        read.append(f"| {told} | {fmt.description} | {extra} | {fmt.units} |")
    synth = ["| `--format` | in `OUT/<task>/` | holds |", "|---|---|---|"]
    for fmt in FORMATS:
        for w in fmt.writers:
            where = "the dataset" if w.dataset else f"`<task>NNNN{w.ending}`" if w.ending else "`<task>NNNN/`"
            synth.append(f"| `{w.name}` | {where} | {w.description} |")
    return {"read": "\n".join(read), "synth": "\n".join(synth)}


def write_docs(path: Path) -> bool:
    """Rewrite the tables between ``<!-- formats: NAME -->`` and ``<!-- end formats -->`` in ``path``.

    Args:
        path: a Markdown file (docs/recordings.md).

    Returns:
        Whether the file changed.
    """
    text = Path(path).read_text(encoding="utf-8")
    new = text
    for name, table in markdown_tables().items():
        new = _with_table(new, name, table)
    if new != text:
        Path(path).write_text(new, encoding="utf-8")
    return new != text


def _with_table(text: str, name: str, table: str) -> str:
    """``text`` with its block ``name`` (between its two markers) replaced by ``table``."""
    block = re.compile(rf"(<!-- formats: {name} -->\n).*?(?=<!-- end formats -->)", re.S)
    return block.sub(lambda m: m.group(1) + table + "\n", text)
