"""Joint angles from ROS 2 logs: rosbag2 folders (SQLite 3 or MCAP storage) and bare MCAP files.

The `rosbags` library reads and writes them without a ROS installation
(``pip install 'simtune[ros]'``).  A recording is the ``sensor_msgs/msg/JointState``
messages of one topic: by default the log's one JointState topic, or the one
named.  Angles are matched to joints by each message's ``name`` field, so the
order may change from message to message and several publishers may share the
topic (each joint is then interpolated onto the union of their time stamps).
Time is the messages' header stamp, or the time the log received them where
the publisher left the stamps at zero.  See docs/recordings.md.
"""

from __future__ import annotations

from collections.abc import Collection
from pathlib import Path
from typing import Any

import numpy as np

from simtune.data._table import display_name
from simtune.data.recording import MAX_ABS_JOINT_RAD, Recording
from simtune.errors import RecordingError

JOINT_STATE = "sensor_msgs/msg/JointState"
#: the topic a writer uses unless told otherwise (ROS 2's conventional one)
DEFAULT_TOPIC = "/joint_states"
#: ``write_joint_bag`` storages: rosbag2's two storage plugins
STORAGES = ("mcap", "sqlite3")
_INSTALL = "pip install 'simtune[ros]'"


def is_bag_folder(path: Path) -> bool:
    """A rosbag2 folder: a directory holding the ``metadata.yaml`` that rosbag2 writes."""
    return path.is_dir() and (path / "metadata.yaml").is_file()


def _rosbags(display: str):
    """The rosbags modules this reader needs, or a one-line error saying how to install them."""
    try:
        from rosbags import highlevel, typesys
    except ImportError:
        raise RecordingError(
            f"{display}: reading ROS 2 bags and MCAP files needs the rosbags library: {_INSTALL}"
        ) from None
    return highlevel, typesys


def read_joint_bag(path: Path | str, joint_names: Collection[str] | None = None, topic: str | None = None) -> Recording:
    """The JointState messages of ``topic`` (default: the only JointState topic) as a joint-angle Recording.

    ``joint_names``: the joints a message may name (None: any).  Every problem
    is a RecordingError naming the file and the message (1-based, in the log's
    order on that topic).
    """
    path = Path(path)
    display = display_name(path)
    highlevel, typesys = _rosbags(display)
    if not path.exists():
        raise RecordingError(f"{display}: no such file or folder ({path})")
    store = typesys.get_typestore(typesys.Stores.ROS2_HUMBLE)
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
    return _joint_recording(path, where, samples, joint_names)


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
    path: Path, where: str, samples: list[tuple[int, Any]], known: Collection[str] | None
) -> Recording:
    """Per joint its (time, angle) samples, checked, then all joints on the union of their times."""
    if not samples:
        raise RecordingError(f"{where}: no messages")
    stamps = np.array([m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for _, m in samples])
    # a publisher that leaves the stamps at zero: the log's receive times are the best clock left
    times = stamps if np.any(stamps != 0.0) else np.array([logged * 1e-9 for logged, _ in samples])
    series: dict[str, tuple[list[float], list[float], list[int]]] = {}
    for k, (_, msg) in enumerate(samples):
        at = f"{where} message {k + 1}"
        names = list(msg.name)
        position = np.asarray(msg.position, dtype=float)
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
                raise RecordingError(
                    f"{at}: units check: joint {name!r} is {angle:.6g}, beyond two turns: looks like degrees "
                    "(JointState positions are radians)"
                )
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
    return Recording(source=path, time=common, joints=joints)


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
