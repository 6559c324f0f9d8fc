"""Joint angles from ROS 2 logs: rosbag2 folders (SQLite 3 or MCAP storage) and bare MCAP files.

The `rosbags` library reads and writes them without a ROS installation
(``pip install 'simtune[ros]'``).  A recording is the ``sensor_msgs/msg/JointState``
messages of one topic: by default the log's one JointState topic, or the one
named.  Angles are matched to joints by each message's ``name`` field, so the
order may change from message to message and several publishers may share the
topic (each joint is then interpolated onto the union of their time stamps).
Time is the messages' header stamp, or the time the log received them where
the publisher left the stamps at zero.  A rosbag2 folder that lacks its
``metadata.yaml`` (what a killed ``ros2 bag record`` leaves) is read from its
storage files alone where they are whole: SQLite 3 files through their own
tables, MCAP files through their own index.  See docs/recordings.md.
"""

from __future__ import annotations

import re
import sqlite3
from collections.abc import Collection
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from simtune.data._table import display_name
from simtune.data.recording import DEGREES_HINT, MAX_ABS_JOINT_RAD, Recording
from simtune.errors import RecordingError

JOINT_STATE = "sensor_msgs/msg/JointState"
#: the topic a writer uses unless told otherwise (ROS 2's conventional one)
DEFAULT_TOPIC = "/joint_states"
#: ``write_joint_bag`` storages: rosbag2's two storage plugins
STORAGES = ("mcap", "sqlite3")
#: the storage files of a rosbag2 folder (SQLite 3, MCAP)
STORAGE_SUFFIXES = (".db3", ".mcap")
#: the angle units a log may be stated in (the task file's ``[recordings] units``), and the factor to radians
_UNITS = {"rad": 1.0, "deg": np.pi / 180.0}
_INSTALL = "pip install 'simtune[ros]'"


class UnindexedBag(RecordingError):
    """A rosbag2 folder without its metadata.yaml whose storage files cannot be read alone (a task's repeats
    leave it out with a warning)."""


def is_bag_folder(path: Path) -> bool:
    """A rosbag2 folder: a directory holding the ``metadata.yaml`` that rosbag2 writes, or only its storage
    files (a recording killed before rosbag2 wrote the metadata: :func:`storage_files`)."""
    if not path.is_dir():
        return False
    return (path / "metadata.yaml").is_file() or bool(storage_files(path))


def storage_files(folder: Path) -> list[Path]:
    """The storage files rosbag2 writes into a bag folder: ``<folder>.db3`` or ``.mcap``, or split ones
    ``<folder>_0.db3``, ``<folder>_1.db3`` ... (other files, a folder of separate logs among them, are not)."""
    own = re.compile(rf"{re.escape(folder.name)}(_[0-9]+)?")
    return sorted(
        (p for p in folder.iterdir() if p.suffix.lower() in STORAGE_SUFFIXES and own.fullmatch(p.stem) and p.is_file()),
        key=lambda p: (len(p.stem), p.stem),
    )


def _rosbags(display: str):
    """The rosbags modules this reader needs, or a one-line error saying how to install them."""
    try:
        from rosbags import highlevel, typesys
    except ImportError:
        raise RecordingError(
            f"{display}: reading ROS 2 bags and MCAP files needs the rosbags library: {_INSTALL}"
        ) from None
    return highlevel, typesys


def read_joint_bag(
    path: Path | str, joint_names: Collection[str] | None = None, topic: str | None = None, units: str | None = None
) -> Recording:
    """The JointState messages of ``topic`` (default: the only JointState topic) as a joint-angle Recording.

    ``joint_names``: the joints a message may name (None: any); ``units``: the unit the task states for its
    logs (None: radians, as JointState says).  Every problem is a RecordingError naming the file and the
    message (1-based, in the log's order on that topic); a rosbag2 folder without its metadata.yaml whose
    storage cannot be read alone is an :class:`UnindexedBag`.
    """
    path = Path(path)
    display = display_name(path)
    highlevel, typesys = _rosbags(display)
    if not path.exists():
        raise RecordingError(f"{display}: no such file or folder ({path})")
    store = typesys.get_typestore(typesys.Stores.ROS2_HUMBLE)
    if path.is_dir() and not (path / "metadata.yaml").is_file():
        where, samples = _read_without_metadata(path, topic, display, store, highlevel)
        return _joint_recording(path, where, samples, joint_names, units)
    try:
        with highlevel.AnyReader([path], default_typestore=store) as reader:
            connections = _pick_topic(reader.connections, topic, display)
            where = f"{display} topic {connections[0].topic}"
            samples = [
                (logged, reader.deserialize(raw, conn.msgtype))
                for conn, logged, raw in reader.messages(connections=connections)
            ]
    except RecordingError:
        raise
    except Exception as exc:  # the library's errors on damaged or foreign files have no common base class
        text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise RecordingError(f"{display}: cannot read as a ROS 2 bag or MCAP file ({text})") from None
    return _joint_recording(path, where, samples, joint_names, units)


class _Connection(NamedTuple):
    """A topic of a SQLite 3 storage file, as rosbags' connections name it."""

    id: int
    topic: str
    msgtype: str


def _read_without_metadata(path: Path, topic: str | None, display: str, store, highlevel) -> tuple[str, list]:
    """The messages of ``topic`` in a rosbag2 folder that lacks metadata.yaml, read from its storage files:
    SQLite 3 files through their ``topics`` and ``messages`` tables, MCAP files through their own index."""
    files = storage_files(path)
    databases = [p for p in files if p.suffix.lower() == ".db3"]
    try:
        if not databases:
            with highlevel.AnyReader(files, default_typestore=store) as reader:
                connections = _pick_topic(reader.connections, topic, display)
                samples = [
                    (logged, reader.deserialize(raw, conn.msgtype))
                    for conn, logged, raw in reader.messages(connections=connections)
                ]
            return f"{display} topic {connections[0].topic}", samples
        rows: list[tuple[int, _Connection, bytes]] = []
        chosen: list[_Connection] = []
        for db_file in databases:
            db = sqlite3.connect(f"{db_file.resolve().as_uri()}?mode=ro", uri=True)
            try:
                topics = [_Connection(*row) for row in db.execute("SELECT id, name, type FROM topics")]
                chosen = _pick_topic(topics, topic, display)
                ids = {c.id: c for c in chosen}
                marks = ",".join("?" * len(ids))
                query = f"SELECT topic_id, timestamp, data FROM messages WHERE topic_id IN ({marks}) ORDER BY id"
                rows += [(logged, ids[tid], bytes(raw)) for tid, logged, raw in db.execute(query, list(ids))]
            finally:
                db.close()
        rows.sort(key=lambda row: row[0])  # the log's order, as rosbag2 replays it
        samples = [(logged, store.deserialize_cdr(raw, conn.msgtype)) for logged, conn, raw in rows]
        return f"{display} topic {chosen[0].topic}", samples
    except RecordingError:
        raise
    except Exception as exc:  # sqlite3's, the MCAP reader's and the deserializer's errors share no base class
        text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise UnindexedBag(
            f"{display}: a rosbag2 folder with no metadata.yaml (what a killed `ros2 bag record` leaves) whose "
            f"storage cannot be read alone ({text}); `ros2 bag reindex` rewrites the metadata"
        ) from None


def _pick_topic(connections, topic: str | None, display: str) -> list:
    states = sorted({c.topic for c in connections if c.msgtype == JOINT_STATE})
    if topic is None:
        if len(states) != 1:
            found = f"several ({', '.join(states)}): name one as the joint topic" if states else "none"
            raise RecordingError(f"{display}: expected one {JOINT_STATE} topic, found {found}")
        topic = states[0]
    chosen = [c for c in connections if c.topic == topic]
    if not chosen:
        raise RecordingError(f"{display}: no topic {topic!r} (its {JOINT_STATE} topics: {', '.join(states) or 'none'})")
    if any(c.msgtype != JOINT_STATE for c in chosen):
        raise RecordingError(f"{display}: topic {topic!r} holds {chosen[0].msgtype}, not {JOINT_STATE}")
    return chosen


def _joint_recording(
    path: Path, where: str, samples: list[tuple[int, Any]], known: Collection[str] | None, units: str | None = None
) -> Recording:
    """Per joint its (time, angle) samples, checked, then all joints on the union of their times (``units``:
    the unit the task states for its logs; None: radians)."""
    to_rad = _UNITS[units or "rad"]
    if not samples:
        raise RecordingError(f"{where}: no messages")
    stamps = np.array([m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for _, m in samples])
    # a publisher that leaves the stamps at zero: the log's receive times are the best clock left
    times = stamps if np.any(stamps != 0.0) else np.array([logged * 1e-9 for logged, _ in samples])
    series: dict[str, tuple[list[float], list[float], list[int]]] = {}
    for k, (_, msg) in enumerate(samples):
        at = f"{where} message {k + 1}"
        names = list(msg.name)
        position = np.asarray(msg.position, dtype=float) * to_rad
        if position.size == 0:
            continue  # velocities or efforts only: no angles in this message
        if position.size != len(names):
            raise RecordingError(f"{at}: {len(names)} joint names but {position.size} positions")
        for name, angle in zip(names, position.tolist()):
            if known is not None and name not in known:
                raise RecordingError(f"{at}: unknown joint {name!r} (the arm's joints: {', '.join(known)})")
            if not np.isfinite(angle):
                raise RecordingError(f"{at}: joint {name!r} has no finite angle ({angle})")
            if abs(angle) > MAX_ABS_JOINT_RAD:
                hint = (
                    f"looks like degrees (JointState positions are radians; {DEGREES_HINT})"
                    if units is None
                    else f"({angle / to_rad:.6g} {units}) more than two turns, not a joint angle"
                )
                raise RecordingError(f"{at}: units check: joint {name!r} is {angle:.6g}, beyond two turns: {hint}")
            t_list, q_list, k_list = series.setdefault(name, ([], [], []))
            if t_list and times[k] < t_list[-1]:
                raise RecordingError(
                    f"{at}: time check: the time goes backwards for joint {name!r} "
                    f"({times[k]:.9g} s after {t_list[-1]:.9g} s)"
                )
            if t_list and times[k] == t_list[-1]:
                continue  # the same sample logged twice: the first copy is kept
            t_list.append(float(times[k]))
            q_list.append(angle)
            k_list.append(k)
    if not series:
        raise RecordingError(f"{where}: no joint positions in {len(samples)} messages")
    common = np.unique(np.concatenate([np.asarray(t) for t, _, _ in series.values()]))
    if common.size < 2:
        raise RecordingError(f"{where}: only {common.size} distinct time; need at least 2")
    joints = {name: np.interp(common, np.asarray(t), np.asarray(q)) for name, (t, q, _) in series.items()}
    return Recording(source=path, time=common, joints=joints, joint_units=dict.fromkeys(joints, units) if units else {})


def write_joint_bag(
    path: Path | str,
    rec: Recording,
    *,
    storage: str = "mcap",
    topic: str = DEFAULT_TOPIC,
) -> Path:
    """Write ``rec``'s joint angles as JointState messages; returns the file or folder written.

    ``storage="sqlite3"``: a rosbag2 folder ``path``.  ``storage="mcap"``: with a
    name ending in ``.mcap`` one bare MCAP file (rosbag2's MCAP layout, which
    ROS 2 and Foxglove read), otherwise a rosbag2 folder with MCAP storage.
    Time stamps are ``rec.time`` (header and log time alike).
    """
    path = Path(path)
    display = display_name(path)
    _, typesys = _rosbags(display)
    from rosbags.rosbag2 import StoragePlugin, Writer

    if storage not in STORAGES:
        raise RecordingError(f"{display}: unknown bag storage {storage!r} (known: {', '.join(STORAGES)})")
    if not rec.joints:
        raise RecordingError(f"{display}: cannot write: the recording holds no joint angles")
    bare = storage == "mcap" and path.name.lower().endswith(".mcap")
    folder = path.with_name(path.name[: -len(".mcap")] + ".bag") if bare else path
    if path.exists() or folder.exists():
        raise RecordingError(f"{display}: cannot write: {path if path.exists() else folder} exists")
    store = typesys.get_typestore(typesys.Stores.ROS2_HUMBLE)
    types = store.types
    msg_type = types[JOINT_STATE]
    names = list(rec.joints)
    angles = np.stack([np.asarray(rec.joints[n], dtype=float) for n in names], axis=1)
    nanos = np.round(np.asarray(rec.time, dtype=float) * 1e9).astype(np.int64)
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    empty = np.zeros(0)
    with Writer(folder, version=8, storage_plugin=plugin) as writer:
        conn = writer.add_connection(topic, JOINT_STATE, typestore=store)
        for t, q in zip(nanos.tolist(), angles):
            stamp = types["builtin_interfaces/msg/Time"](sec=t // 1_000_000_000, nanosec=t % 1_000_000_000)
            msg = msg_type(
                header=types["std_msgs/msg/Header"](stamp=stamp, frame_id=""),
                name=names,
                position=q.copy(),
                velocity=empty,
                effort=empty,
            )
            writer.write(conn, t, store.serialize_cdr(msg, JOINT_STATE))
    if not bare:
        return folder
    # rosbag2's MCAP storage writes one self-describing .mcap file beside metadata.yaml
    (inner,) = folder.glob("*.mcap")
    inner.replace(path)
    for leftover in folder.iterdir():
        leftover.unlink()
    folder.rmdir()
    return path
