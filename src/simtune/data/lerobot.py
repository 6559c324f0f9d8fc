"""LeRobot datasets (v2.0, v2.1 and v3.0 layouts) as recordings: each episode one repeat, read with pyarrow.

A LeRobot dataset is a folder::

    meta/info.json                        codebase_version, fps, features {name: {dtype, shape, names}}
    data/chunk-000/episode_000000.parquet v2.x: one file per episode
    data/chunk-000/file-000.parquet       v3.0: many episodes per file (rows carry episode_index)
    meta/episodes.jsonl                   v2.x: per episode its length (optional here)
    meta/episodes/chunk-000/file-000.parquet  v3.0: the same as Parquet (optional here)

Each data row is one frame: ``observation.state`` (the measured joint positions) and ``action`` (the
commanded ones) are vectors whose entries ``features.<name>.names`` in info.json names, ``timestamp``
is seconds from the episode's start, ``episode_index`` the episode.  Videos are not read.

The names are matched to the robot's joints: a :class:`LeRobotReading` (a task file's ``[recordings]``
table) maps a name to a joint, or to "" to leave it out; else a name is a joint's own name, or a
joint's name with LeRobot's ``.pos`` suffix (``shoulder_pan.pos``).  Names of joints the task does
not drive are left out; any other name is an error.  LeRobot stores no unit: the reading states it
(``deg``, as LeRobot's SO-100/SO-101 log their joints, or ``rad``).  See docs/recordings.md.
"""

from __future__ import annotations

import json
import math
import warnings
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from simtune.data._table import read_bytes
from simtune.data.ingest import copied_commands, warn_of_copied_commands
from simtune.data.recording import MAX_ABS_JOINT_RAD, Recording, finish_recording
from simtune.data.sanity import (
    ANGLE_FACTORS,
    MIN_COMMANDED_SPAN_RAD,
    MIN_DURATION_SHARE,
    SMALL_MOTION_SHARE,
    JointRange,
    UnitsProblem,
    check_time,
    declared_units_problem,
    schedule_units_problem,
)
from simtune.data.sanity import (
    OTHER_MOTION_SHARE as OTHER_UNIT_MOTION_SHARE,
)
from simtune.errors import ConfigError, RecordingError, RecordingWarning

#: the dataset's description, relative to its folder
INFO = "meta/info.json"
STATE = "observation.state"
ACTION = "action"
#: the ``codebase_version`` values read here
VERSIONS = ("v2.0", "v2.1", "v3.0")
#: the layouts :func:`write_lerobot_dataset` writes
WRITE_VERSIONS = ("v3.0", "v2.1")
#: angle units a dataset may be stated in, and the factor to radians
ANGLE_UNITS = {"deg": math.pi / 180.0, "rad": 1.0}
#: LeRobot's suffix of a joint position's name (``shoulder_pan.pos``)
POS_SUFFIX = ".pos"
INSTALL = "pip install 'simtune[lerobot]'"
#: how many episodes a v2.x chunk folder holds (LeRobot's default)
CHUNK_SIZE = 1000


@dataclass(frozen=True)
class LeRobotReading:
    """How a task reads LeRobot datasets: the unit of their angles, their names' joints, which episodes.

    ``joints`` maps a dataset name to a robot joint ("" leaves the name out); ``episodes`` are the
    episodes that are repeats of the task (None: all); ``undriven`` are the robot's joints that the
    task does not drive (names of them are left out; filled in when a task's recordings are read).
    ``ranges`` are what each driven joint's angles should fit (the task's start angle and commanded range, the
    joint's limits; filled in when a task's recordings are read): the stated unit is checked against them
    (:func:`simtune.data.sanity.declared_units_problem`), not taken as given; empty: not checked.
    """

    units: str | None = None
    joints: tuple[tuple[str, str], ...] = ()
    episodes: tuple[int, ...] | None = None
    undriven: tuple[str, ...] = ()
    ranges: tuple[tuple[str, JointRange], ...] = ()

    def dataset_name(self, joint: str) -> str:
        """The name a written dataset gives ``joint``: the one ``joints`` maps to it, else ``<joint>.pos``."""
        return next((name for name, target in self.joints if target == joint), joint + POS_SUFFIX)


@dataclass
class Episode:
    """One episode's frames as read: where they are, their times and the raw vectors of the features read."""

    index: int
    file: Path
    rows: np.ndarray  # 0-based rows in ``file``
    time: np.ndarray
    vectors: dict[str, np.ndarray]  # feature -> (n, k), as stored (the dataset's unit)


@dataclass(frozen=True)
class Columns:
    """The entries of a vector feature that drive joints: their positions in the vector and their joints."""

    feature: str
    names: tuple[str, ...]
    picked: tuple[tuple[int, str], ...]  # (entry, joint)


def is_lerobot_dataset(path: Path) -> bool:
    """A folder with ``meta/info.json``, or with ``data/chunk-*/*.parquet`` files (a dataset lacking its info)."""
    path = Path(path)
    return path.is_dir() and ((path / INFO).is_file() or any(path.glob("data/chunk-*/*.parquet")))


def dataset_members(root: Path) -> list[Path]:
    """The files of a dataset that simtune reads (its info, episode metadata and data; not its videos)."""
    root = Path(root)
    return sorted(p for p in [*root.glob("meta/**/*"), *root.glob("data/**/*.parquet")] if p.is_file())


def _shown(root: Path, path: Path | None = None) -> str:
    """``<dataset folder>/<path in it>`` for messages."""
    return root.name if path is None else f"{root.name}/{path.relative_to(root).as_posix()}"


def _pyarrow(display: str) -> tuple[Any, Any]:
    try:
        import pyarrow
        import pyarrow.parquet
    except ImportError:
        raise RecordingError(f"{display}: reading and writing LeRobot datasets needs pyarrow: {INSTALL}") from None
    return pyarrow, pyarrow.parquet


def read_info(root: Path) -> dict[str, Any]:
    """``meta/info.json``, checked: a known ``codebase_version`` and a ``features`` table."""
    root = Path(root)
    shown = _shown(root, root / INFO)
    if not (root / INFO).is_file():
        raise RecordingError(
            f"{shown}: missing: a LeRobot dataset folder holds meta/info.json beside data/chunk-*/*.parquet"
        )
    text = read_bytes(root / INFO, shown)  # any encoding a text editor saves in
    try:
        info = json.loads(text)
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        where = f" (line {exc.lineno}, column {exc.colno})" if isinstance(exc, json.JSONDecodeError) else ""
        raise RecordingError(f"{shown}: not valid JSON: {getattr(exc, 'msg', exc)}{where}") from None
    if not isinstance(info, dict):
        raise RecordingError(f"{shown}: expected a JSON object, got {type(info).__name__}")
    version = info.get("codebase_version")
    if version not in VERSIONS:
        raise RecordingError(
            f"{shown}: codebase_version: {version!r} is not a layout simtune reads ({', '.join(VERSIONS)})"
        )
    if not isinstance(info.get("features"), dict):
        raise RecordingError(f"{shown}: features: missing or not a table of features")
    fps = info.get("fps")
    if fps is not None and (
        isinstance(fps, bool) or not isinstance(fps, int | float) or not math.isfinite(fps) or fps <= 0
    ):
        raise RecordingError(f"{shown}: fps: {json.dumps(fps)} is not a frame rate (frames per second, above 0)")
    return info


#: an episode's timestamps may step this much away from info.json's 1 / fps (median over the episode) before they
#: are another clock: a LeRobot writer synthesises them as frame_index / fps, so they agree to rounding
FPS_TOLERANCE = 0.05


def check_frame_rate(root: Path, info: dict[str, Any], episode: Episode) -> None:
    """An episode's timestamps against ``info.json``'s fps (probe 5: timestamps 10 x too large read as 3 Hz, the
    schedule stretched 10 x, without a line).

    Args:
        root: the dataset.
        info: its meta/info.json.
        episode: one episode as read.

    Raises:
        RecordingError: naming the file, the episode, both rates and what to do.
    """
    fps = info.get("fps")
    steps = np.diff(episode.time)
    if fps is None or steps.size == 0:
        return
    step = float(np.median(steps))
    if abs(step * fps - 1.0) > FPS_TOLERANCE:
        seen = f"{1.0 / step:.4g} frames per second" if step > 0 else "no time at all between frames"
        raise RecordingError(
            f"{_shown(root, episode.file)}: timestamp: episode {episode.index} steps {step:.6g} s a frame "
            f"({seen}), but meta/info.json says fps {fps:g} ({1.0 / fps:.6g} s): timestamps in another unit "
            "(milliseconds?) or a wrong fps; correct the dataset before simtune reads it"
        )


def feature_names(root: Path, info: dict[str, Any], feature: str) -> tuple[str, ...]:
    """The names of a vector feature's entries (``names`` a list, or a table holding one list such as
    ``{"motors": [...]}``), checked against its ``shape``."""
    where = f"{_shown(root, Path(root) / INFO)}: features.{feature}"
    spec = info["features"].get(feature)
    if not isinstance(spec, dict):
        raise RecordingError(f"{where}: missing (the dataset's features: {', '.join(info['features'])})")
    names = spec.get("names")
    if isinstance(names, dict) and len(names) == 1:
        ((key, names),) = names.items()
        where = f"{where}.names.{key}"
    else:
        where = f"{where}.names"
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        raise RecordingError(f"{where}: expected a list of the vector's joint names, got {names!r}")
    shape = spec.get("shape")
    if shape is not None and list(shape) != [len(names)]:
        raise RecordingError(
            f"{_shown(root, Path(root) / INFO)}: features.{feature}.shape: {shape} but names has {len(names)} entries"
        )
    return tuple(names)


def pick_columns(
    root: Path,
    info: dict[str, Any],
    feature: str,
    joint_names: Collection[str] | None,
    reading: LeRobotReading,
) -> Columns:
    """Which entries of ``feature`` drive which of ``joint_names`` (the driven joints; None: any name)."""
    names = feature_names(root, info, feature)
    table = dict(reading.joints)
    picked: list[tuple[int, str]] = []
    seen: dict[str, int] = {}
    for i, name in enumerate(names):
        where = f"{_shown(root, Path(root) / INFO)}: features.{feature}.names[{i}]"
        joint = _joint_of(name, table, joint_names, reading.undriven, where)
        if joint is None:
            continue
        if joint in seen:
            raise RecordingError(
                f"{where}: {name!r} and names[{seen[joint]}] {names[seen[joint]]!r} both name joint {joint!r}"
            )
        seen[joint] = i
        picked.append((i, joint))
    if not picked:
        driven = ", ".join(joint_names) if joint_names is not None else "any"
        raise RecordingError(
            f"{_shown(root, Path(root) / INFO)}: features.{feature}.names: none of {', '.join(names)} is a driven "
            f"joint ({driven}): map them in the task file's [recordings.joints]"
        )
    return Columns(feature, names, tuple(picked))


def _joint_of(
    name: str, table: dict[str, str], driven: Collection[str] | None, undriven: Collection[str], where: str
) -> str | None:
    """The driven joint a dataset name stands for; None for a name left out (mapped to "", or of a joint
    the task does not drive)."""
    if name in table:
        joint = table[name]
        if not joint or joint in undriven:
            return None
        if driven is not None and joint not in driven:
            raise RecordingError(
                f"{where}: {name!r} is mapped to {joint!r} by the task file's [recordings.joints], "
                f"which is not a joint of the robot (its joints: {', '.join(driven)})"
            )
        return joint
    bare = name.removesuffix(POS_SUFFIX)
    for candidate in (name, bare):
        if driven is not None and candidate in driven:
            return candidate
        if candidate in undriven:
            return None
    if driven is None:
        return bare
    raise RecordingError(
        f"{where}: {name!r} is not a joint of the robot (its driven joints: {', '.join(driven)}): map it to one "
        'in the task file\'s [recordings.joints], or to "" to leave it out'
    )


def to_radians(root: Path, reading: LeRobotReading, where: str) -> float:
    """The factor from the dataset's stated angle unit to radians."""
    if reading.units is None:
        raise RecordingError(
            f"{_shown(root)}: {where}: LeRobot datasets store no angle unit: state it in the task file's "
            '[recordings] table, units = "deg" (LeRobot\'s SO-100/SO-101) or units = "rad"'
        )
    if reading.units not in ANGLE_UNITS:
        raise RecordingError(f"{_shown(root)}: recordings.units: unknown unit {reading.units!r} (known: deg, rad)")
    return ANGLE_UNITS[reading.units]


def read_episodes(
    root: Path, features: Sequence[str], episodes: Collection[int] | None = None, key: str = "recordings.episodes"
) -> list[Episode]:
    """The episodes of the dataset in ``root`` (those in ``episodes``; None: all), in episode order, with the
    raw vectors of ``features``; every problem one RecordingError naming the file, row and field (an episode
    ``episodes`` names that the dataset lacks: the task file's ``key`` that named it)."""
    root = Path(root)
    info = read_info(root)
    widths = {f: len(feature_names(root, info, f)) for f in features}
    pa, pq = _pyarrow(_shown(root))
    files = sorted(root.glob("data/chunk-*/*.parquet"))
    if not files:
        raise RecordingError(f"{_shown(root)}/data: no chunk-*/*.parquet files (the dataset holds no frames)")
    found: dict[int, Episode] = {}
    for file in files:
        for episode in _file_episodes(root, file, widths, pa, pq):
            if episode.index in found:
                other = _shown(root, found[episode.index].file)
                raise RecordingError(f"{_shown(root, file)}: episode_index: episode {episode.index} is also in {other}")
            found[episode.index] = episode
    _check_lengths(root, info, found, pq)
    for episode in found.values():
        check_frame_rate(root, info, episode)
    if episodes is not None:
        missing = [k for k in episodes if k not in found]
        if missing:
            raise RecordingError(
                f"{_shown(root)}: {key}: no episode {missing[0]} (the dataset's episodes: "
                f"{index_ranges(sorted(found))})"
            )
        return [found[k] for k in episodes]
    return [found[k] for k in sorted(found)]


def episode_indices(root: Path | str) -> list[int]:
    """The episode numbers of the dataset in ``root``, in order (read from its frames, checked as
    :func:`read_episodes` checks them: every problem one RecordingError naming the file).

    Args:
        root: a LeRobot dataset folder.

    Returns:
        Its episodes' ``episode_index`` values, ascending.
    """
    return [episode.index for episode in read_episodes(Path(root), [ACTION])]


def index_ranges(indices: list[int]) -> str:
    """``0-4, 7`` for messages."""
    parts: list[str] = []
    start = prev = indices[0]
    for k in [*indices[1:], None]:
        if k is not None and k == prev + 1:
            prev = k
            continue
        parts.append(f"{start}-{prev}" if prev > start else str(start))
        if k is not None:
            start = prev = k
    return ", ".join(parts)


def _file_episodes(root: Path, file: Path, widths: dict[str, int], pa: Any, pq: Any) -> list[Episode]:
    shown = _shown(root, file)
    needed = ["timestamp", "episode_index", *widths]
    try:
        schema = pq.read_schema(file)
        absent = [c for c in needed if c not in schema.names]
        if absent:
            raise RecordingError(f"{shown}: no column {absent[0]!r} (its columns: {', '.join(schema.names)})")
        table = pq.read_table(file, columns=needed)
    except RecordingError:
        raise
    except Exception as exc:  # pyarrow's errors on damaged or foreign files
        text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise RecordingError(f"{shown}: cannot read as Parquet ({text})") from None
    n = table.num_rows
    if n == 0:
        raise RecordingError(f"{shown}: no rows")
    time = _scalar_column(table, "timestamp", shown, float)
    index = _scalar_column(table, "episode_index", shown, int)
    vectors = {f: _vector_column(table, f, k, shown, pa) for f, k in widths.items()}
    result = []
    for k in dict.fromkeys(index.tolist()):
        rows = np.flatnonzero(index == k)
        t = time[rows]
        back = np.flatnonzero(np.diff(t) < 0)
        if back.size:
            i = int(back[0]) + 1
            raise RecordingError(
                f"{shown} row {int(rows[i]) + 1}: timestamp: the time goes backwards in episode {k} "
                f"({t[i]:.6g} s after {t[i - 1]:.6g} s)"
            )
        result.append(Episode(int(k), file, rows, t, {f: v[rows] for f, v in vectors.items()}))
    return result


def _scalar_column(table: Any, name: str, shown: str, kind: type) -> np.ndarray:
    column = table.column(name).combine_chunks()
    if column.null_count:
        row = int(np.flatnonzero(column.is_null().to_numpy(zero_copy_only=False))[0])
        raise RecordingError(f"{shown} row {row + 1}: {name}: missing (null)")
    try:
        values = np.asarray(column.to_numpy(), dtype=float)
    except (TypeError, ValueError):
        raise RecordingError(f"{shown}: {name}: expected numbers, found {column.type}") from None
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise RecordingError(f"{shown} row {int(bad[0]) + 1}: {name}: {values[bad[0]]} is not a finite number")
    if kind is int:
        if np.any(values != np.round(values)) or np.any(values < 0):
            row = int(np.flatnonzero((values != np.round(values)) | (values < 0))[0])
            raise RecordingError(f"{shown} row {row + 1}: {name}: {values[row]:g} is not an episode number")
        return values.astype(np.int64)
    return values


def _vector_column(table: Any, name: str, width: int, shown: str, pa: Any) -> np.ndarray:
    """(rows, width) floats of a list column; a null row or a row of another length is an error naming it."""
    column = table.column(name).combine_chunks()
    kind = column.type
    if not (pa.types.is_list(kind) or pa.types.is_large_list(kind) or pa.types.is_fixed_size_list(kind)):
        raise RecordingError(f"{shown}: {name}: expected a list of numbers per row, found {kind}")
    if column.null_count:
        row = int(np.flatnonzero(column.is_null().to_numpy(zero_copy_only=False))[0])
        raise RecordingError(f"{shown} row {row + 1}: {name}: missing (null)")
    import pyarrow.compute as pc

    lengths = np.asarray(pc.list_value_length(column).to_numpy(zero_copy_only=False))
    wrong = np.flatnonzero(lengths != width)
    if wrong.size:
        row = int(wrong[0])
        raise RecordingError(
            f"{shown} row {row + 1}: {name}: {int(lengths[row])} values, but meta/info.json's features.{name} "
            f"names {width}"
        )
    try:
        flat = np.asarray(column.flatten().to_numpy(zero_copy_only=False), dtype=float)
    except (TypeError, ValueError):
        raise RecordingError(f"{shown}: {name}: expected numbers, found {kind}") from None
    return flat.reshape(len(column), width)


def _check_lengths(root: Path, info: dict[str, Any], found: dict[int, Episode], pq: Any) -> None:
    """The episode lengths the metadata states (v2.x ``meta/episodes.jsonl``, v3.0 ``meta/episodes/``), where
    it is there, against the frames in the data."""
    stated: list[tuple[str, int, int]] = []  # (where, episode, length)
    jsonl = root / "meta" / "episodes.jsonl"
    if str(info["codebase_version"]).startswith("v2") and jsonl.is_file():
        for number, line in enumerate(jsonl.read_text(encoding="utf-8").splitlines(), start=1):
            if not line.strip():
                continue
            where = f"{_shown(root, jsonl)} line {number}"
            try:
                entry = json.loads(line)
                stated.append((where, int(entry["episode_index"]), int(entry["length"])))
            except (json.JSONDecodeError, KeyError, TypeError, ValueError):
                raise RecordingError(f"{where}: expected an object with episode_index and length") from None
    for file in sorted(root.glob("meta/episodes/chunk-*/*.parquet")):
        try:
            table = pq.read_table(file, columns=["episode_index", "length"])
        except Exception as exc:  # pyarrow's errors: damaged file, no such columns
            text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise RecordingError(f"{_shown(root, file)}: cannot read episode_index and length ({text})") from None
        for row, (k, length) in enumerate(
            zip(table.column("episode_index").to_pylist(), table.column("length").to_pylist())
        ):
            stated.append((f"{_shown(root, file)} row {row + 1}", int(k), int(length)))
    for where, k, length in stated:
        episode = found.get(k)
        frames = 0 if episode is None else len(episode.rows)
        if frames != length:
            held = "none" if episode is None else f"{frames} in {_shown(root, episode.file)}"
            raise RecordingError(f"{where}: length: episode {k} has {length} frames, the data holds {held}")


def _angles(episode: Episode, columns: Columns, factor: float, root: Path) -> dict[str, np.ndarray]:
    """Each picked entry of ``columns.feature`` in radians; a NaN or an angle beyond two turns names its row."""
    values = episode.vectors[columns.feature]
    joints: dict[str, np.ndarray] = {}
    for entry, joint in columns.picked:
        raw = values[:, entry]
        where = f"{columns.feature}[{entry}] ({columns.names[entry]!r})"
        bad = np.flatnonzero(~np.isfinite(raw))
        if bad.size:
            row = int(episode.rows[bad[0]]) + 1
            raise RecordingError(
                f"{_shown(root, episode.file)} row {row}: {where}: {raw[bad[0]]} is not an angle (episode "
                f"{episode.index}; every frame needs a value)"
            )
        angles = raw * factor
        beyond = np.flatnonzero(np.abs(angles) > MAX_ABS_JOINT_RAD)
        if beyond.size:
            i = int(beyond[0])
            hint = (
                'looks like degrees: units = "deg" in the task file\'s [recordings] table'
                if factor == 1.0
                else "more than two turns, not a joint angle"
            )
            raise RecordingError(
                f"{_shown(root, episode.file)} row {int(episode.rows[i]) + 1}: units check: {where} is {raw[i]:.6g} "
                f"({angles[i]:.4g} rad): {hint}"
            )
        joints[joint] = angles
    return joints


def read_lerobot_dataset(
    root: Path | str, joint_names: Collection[str] | None = None, reading: LeRobotReading | None = None
) -> list[Recording]:
    """Each episode's ``observation.state`` as one joint-angle Recording (radians) of the joints it names
    among ``joint_names`` (the driven joints; None: any), in episode order.

    A recording's ``source`` is ``root/episode_NNNNNN`` (it names the dataset and the episode in messages)
    and its frames are numbered from 1.
    """
    root = Path(root)
    reading = reading or LeRobotReading()
    info = read_info(root)
    columns = pick_columns(root, info, STATE, joint_names, reading)
    factor = to_radians(root, reading, f"features.{STATE}")
    ranges = dict(reading.ranges)
    recordings = []
    commanded = ACTION in info["features"]
    episodes = _drop_single_frames(
        root, read_episodes(root, [STATE, ACTION] if commanded else [STATE], reading.episodes)
    )
    for episode in episodes:
        joints = _angles(episode, columns, factor, root)
        if ranges:
            _check_stated_units(root, episode, columns, ranges, str(reading.units))
        source = root / f"episode_{episode.index:06d}"
        frames = np.arange(1, len(episode.time) + 1)
        recordings.append(finish_recording(source, _shown(root, source), episode.time, frames, {}, {}, joints, "frame"))
    if ranges:
        warn_of_still_joints(root, episodes, columns, [rec.joints for rec in recordings], ranges)
        warn_of_small_motion(root, episodes, columns, ranges, str(reading.units))
    actions = None
    if commanded:  # after the states' own checks, which name a wrong unit first
        try:
            actions = pick_columns(root, info, ACTION, joint_names, reading)
        except RecordingError:
            actions = None  # commands of other joints (or names) than the state's: nothing to compare
    if actions is not None and actions.picked:
        _check_commands(root, episodes, columns, actions, factor, to_radians(root, reading, f"features.{ACTION}"))
        if len(episodes) > 1:
            check_one_commanded_motion(root, episodes, actions, to_radians(root, reading, f"features.{ACTION}"))
    return recordings


def _check_commands(root: Path, episodes: Sequence[Episode], state: Columns, action: Columns, *factors: float) -> None:
    """The command check (:func:`simtune.data.ingest.copied_commands`) of the joints both features name."""
    shared = [joint for _, joint in state.picked if joint in {j for _, j in action.picked}]
    if not shared:
        return
    measured, commands = [], []
    for episode in episodes:
        try:
            q, u = _angles(episode, state, factors[0], root), _angles(episode, action, factors[1], root)
        except RecordingError:
            return  # commands that are no angles in the stated unit are not the state's: a warning has nothing to say
        measured.append(np.column_stack([q[j] for j in shared]))
        commands.append(np.column_stack([u[j] for j in shared]))
    same = copied_commands(measured, commands, [e.index for e in episodes])
    warn_of_copied_commands(_shown(root), f"{ACTION} vs {STATE}", same, len(episodes))


#: A joint the task commands over :data:`~simtune.data.sanity.MIN_COMMANDED_SPAN_RAD` or more whose logged state
#: spans less than this share of that span never moved: a stuck encoder, another joint's column, a log written
#: while the arm was off (probe 5: a state of zeros under a 10-deg command was scored, fitness 0.0434, no line).
#: An arm following its commands covers most of the span; 0.05-deg encoder noise alone spans 0.25 deg.
STILL_SHARE = 0.02
#: The least commanded span [rad] by which an arm that stays within a few degrees tells a stated unit (radians
#: stated as degrees move 57 times too little): far above an encoder's resolution, below any commanded motion.
MIN_TELLING_SPAN_RAD = math.radians(0.5)
#: Read in the other unit, such a log moves at most this many times its commanded span (else the other unit
#: fits no better: a still log's noise read as radians moves far more than any command).
MOST_MOTION_SHARE = 4.0


def warn_of_still_joints(
    root: Path,
    episodes: Sequence[Episode],
    columns: Columns,
    angles: Sequence[Mapping[str, np.ndarray]],
    ranges: Mapping[str, JointRange],
) -> None:
    """Warn, one line per joint, where a joint that the task commands to move never moves in the log.

    Args:
        root: the dataset.
        episodes: the episodes read.
        columns: the ``observation.state`` entries of the driven joints.
        angles: per episode, its joints' angles [rad].
        ranges: per driven joint, what the task commands it over (its start angle and targets) [rad].
    """
    for entry, joint in columns.picked:
        if joint not in ranges:
            continue
        span = ranges[joint].high - ranges[joint].low
        if span < MIN_COMMANDED_SPAN_RAD:
            continue
        moved = [float(np.ptp(a[joint])) for a in angles]
        still = [episode.index for episode, m in zip(episodes, moved) if m < STILL_SHARE * span]
        if not still:
            continue
        which = f"episode {still[0]}" if len(still) == 1 else f"episodes {index_ranges(still)}"
        warnings.warn(
            f"{_shown(root)}: {STATE}[{entry}] ({columns.names[entry]!r}, joint {joint!r}) never moves in {which} "
            f"(spans {math.degrees(max(m for e, m in zip(episodes, moved) if e.index in still)):.3g} deg at most) "
            f"while the task commands it over {math.degrees(span):.3g} deg: a log that does not follow its commands "
            "is a stuck encoder, another joint's column or an arm that was off; check the dataset and the task "
            "file's [recordings.joints] (its motion is scored as logged)",
            RecordingWarning,
            stacklevel=4,  # at load_task_data's caller
        )


def warn_of_small_motion(
    root: Path, episodes: Sequence[Episode], columns: Columns, ranges: Mapping[str, JointRange], unit: str
) -> None:
    """Warn where a small arm's log in radians is stated as degrees: the refusing units check
    (:func:`simtune.data.sanity.declared_units_problem`) tells it by joints commanded over
    :data:`~simtune.data.sanity.MIN_COMMANDED_SPAN_RAD`; an arm commanded a few degrees has none (probe 5: 1.6-deg
    targets, read 57 times too small, no line).

    Warned when no joint is commanded that far, some joint over :data:`MIN_TELLING_SPAN_RAD`, and in every
    episode each such joint moves less than :data:`~simtune.data.sanity.SMALL_MOTION_SHARE` of its commanded span
    in the stated degrees, while read as radians some moves between
    :data:`~simtune.data.sanity.OTHER_MOTION_SHARE` and :data:`MOST_MOTION_SHARE` of it.

    Args:
        root: the dataset.
        episodes: the episodes read.
        columns: the ``observation.state`` entries of the driven joints.
        ranges: per driven joint, what the task commands it over [rad].
        unit: the stated unit (only ``"deg"`` is doubted: degrees stated as radians leave the joints' limits).
    """
    if unit != "deg" or not episodes:
        return
    spans = {joint: ranges[joint].high - ranges[joint].low for _, joint in columns.picked if joint in ranges}
    if not spans or max(spans.values()) >= MIN_COMMANDED_SPAN_RAD:
        return  # the refusing check tells these
    telling = [(entry, joint) for entry, joint in columns.picked if spans.get(joint, 0.0) >= MIN_TELLING_SPAN_RAD]
    if not telling:
        return
    best: tuple[float, int, str] | None = None  # (share read as radians, entry, joint) of the first episode
    for episode in episodes:
        shares = {}
        for entry, joint in telling:
            moved = float(np.ptp(episode.vectors[columns.feature][:, entry]))  # in the dataset's numbers
            if moved * ANGLE_FACTORS["deg"] >= SMALL_MOTION_SHARE * spans[joint]:
                return  # moves as commanded in degrees
            shares[(entry, joint)] = moved * ANGLE_FACTORS["rad"] / spans[joint]
        fitting = {k: v for k, v in shares.items() if OTHER_UNIT_MOTION_SHARE <= v <= MOST_MOTION_SHARE}
        if not fitting:
            return  # read as radians it moves no more like its commands
        if best is None:
            (entry, joint), share = max(fitting.items(), key=lambda item: spans[item[0][1]])  # the widest commanded
            best = (share, entry, joint)
    assert best is not None
    share, entry, joint = best
    as_stated = share * ANGLE_FACTORS["deg"]  # the same motion read in degrees: 57 times less
    warnings.warn(
        f'{_shown(root)}: units check: {STATE}[{entry}] ({columns.names[entry]!r}, joint {joint!r}), stated "deg", '
        f"moves {as_stated:.1%} of the {math.degrees(spans[joint]):.3g} deg the task commands it over in episode "
        f"{episodes[0].index} (and as little in every episode); read as radians it moves {share:.0%} of it: the "
        'log looks like radians, 57 times larger than read: set units = "rad" in the task file\'s [recordings] table '
        "if so",
        RecordingWarning,
        stacklevel=4,  # at load_task_data's caller
    )


def _drop_single_frames(root: Path, episodes: list[Episode]) -> list[Episode]:
    """The episodes of two or more frames: an episode of one frame (a recording aborted at its start) beside longer
    ones is left out with a warning, as a repeat too short for the task is; only one-frame episodes stop (the first
    one's error), since no recording remains."""
    kept = [e for e in episodes if len(e.time) >= 2]
    if not kept:
        return episodes  # finish_recording names the first episode's only frame
    for episode in episodes:
        if len(episode.time) < 2:
            warnings.warn(
                f"{_shown(root, root / f'episode_{episode.index:06d}')}: duration check: left out: holds "
                f"{len(episode.time)} frame (a recording needs at least 2)",
                RecordingWarning,
                stacklevel=4,  # at load_task_data's caller
            )
    return kept


#: Episodes whose commanded angles (``action``) differ by more than :data:`SAME_COMMAND_RAD` in more than
#: :data:`OTHER_MOTION_SHARE` of their frames, on the best shift of their clocks within :data:`COMMAND_SHIFT_S`,
#: are other motions: 1 deg is far above a servo's quantisation (0.09 deg on the SO-101's) and far below two
#: teleoperated takes; the shift and the share keep repeats of one schedule started at other moments (a start
#: jitter puts each step a frame or two apart) together
SAME_COMMAND_RAD = math.radians(1.0)
OTHER_MOTION_SHARE = 0.1
COMMAND_SHIFT_S = 1.0


def check_one_commanded_motion(root: Path, episodes: Sequence[Episode], actions: Columns, factor: float) -> None:
    """Refuse episodes of other commanded motions as repeats of one task: their ``observation.state`` averaged into
    one reference fits no schedule (probe 5: a dataset of ten teleoperated episodes averaged, one line of warning).

    Each episode's ``action`` stream is compared with the first's frame by frame, on its own clock shifted by the
    whole number of frames (within :data:`COMMAND_SHIFT_S`) that brings the two closest, over the frames both hold.

    Args:
        root: the dataset.
        episodes: the episodes read as the task's recordings (two or more), with their ``action`` vectors.
        actions: the ``action`` entries of the driven joints.
        factor: the dataset's angle unit in radians.

    Raises:
        RecordingError: naming the episodes commanded otherwise, by how much, and the task file's remedies.
    """
    first = np.column_stack(list(_angles(episodes[0], actions, factor, root).values()))
    steps = np.diff(episodes[0].time)
    frame_s = float(np.median(steps)) if steps.size else 0.0
    most = int(COMMAND_SHIFT_S / frame_s) if frame_s > 0 else 0
    other: list[tuple[int, float]] = []
    for episode in episodes[1:]:
        angles = np.column_stack(list(_angles(episode, actions, factor, root).values()))
        shares = []
        for shift in range(-most, most + 1):
            a = first[max(0, -shift) :]
            b = angles[max(0, shift) :]
            n = min(len(a), len(b))
            if n >= max(2, len(first) // 2):  # at least half the first episode in common
                shares.append(float(np.mean(np.any(np.abs(a[:n] - b[:n]) > SAME_COMMAND_RAD, axis=1))))
        share = min(shares, default=1.0)
        if share > OTHER_MOTION_SHARE:
            other.append((episode.index, share))
    if other:
        shown = ", ".join(str(k) for k, _ in other[:5]) + (f" and {len(other) - 5} more" if len(other) > 5 else "")
        least = min(share for _, share in other)
        raise RecordingError(
            f"{_shown(root)}: episodes {shown} were commanded another motion than episode {episodes[0].index} (their "
            f"action streams differ from it by more than {math.degrees(SAME_COMMAND_RAD):g} deg in {100 * least:.0f} % "
            "or more of their frames): a task's recordings are repeats of one commanded motion, averaged into its "
            f"reference; name the repeats in the task file (`[recordings] episodes = [{episodes[0].index}]`), or make "
            "one task per episode (`schedule_episode`)"
        )


def _check_stated_units(
    root: Path, episode: Episode, columns: Columns, ranges: dict[str, JointRange], unit: str
) -> None:
    """Units check of an episode read in the stated unit: a dataset in radians stated as degrees moves 57 times
    too little, one in degrees stated as radians leaves the joints' limits; either names the row, the entry and
    the unit the data looks like."""
    values = {joint: episode.vectors[columns.feature][:, entry] for entry, joint in columns.picked}
    problem = declared_units_problem(values, ranges, unit)
    if problem is not None:
        raise RecordingError(units_message(root, episode, columns, problem, unit))


def units_message(root: Path, episode: Episode, columns: Columns, problem: UnitsProblem, unit: str) -> str:
    """The one-line message of a units check's ``problem`` in an episode of the dataset in ``root``.

    Args:
        root: the dataset's folder.
        episode: the episode, as read.
        columns: the feature's entries that drive joints (the problem's joint among them).
        problem: what :mod:`simtune.data.sanity`'s units checks found.
        unit: the unit the task file states.

    Returns:
        ``<file> row N: units check: <feature>[k] ('<name>'), episode E, stated "<unit>", ...`` with the key to set.
    """
    entry = next(k for k, joint in columns.picked if joint == problem.joint)
    row = int(episode.rows[problem.frame]) + 1
    hint = (
        f'units = "{problem.other}" in the task file\'s [recordings] table if so'
        if problem.other is not None
        else "check the dataset's unit and its joints' zero (LeRobot can also store -100..100 of a calibrated range)"
    )
    return (
        f"{_shown(root, episode.file)} row {row}: units check: {columns.feature}[{entry}] "
        f'({columns.names[entry]!r}, joint {problem.joint!r}) in episode {episode.index}, stated "{unit}", '
        f"{problem.text}: {hint}"
    )


@dataclass(frozen=True)
class Actions:
    """One episode's commanded targets and first measured angles, in radians (docs/task-files.md)."""

    time: np.ndarray  # (n,) [s] from the episode's start
    targets: dict[str, np.ndarray]  # driven joint -> (n,) commanded angle [rad]
    start: dict[str, float]  # driven joint -> its first ``observation.state`` angle [rad] (those the state names)
    episode: int


def read_lerobot_actions(
    root: Path | str,
    episode: int | None,
    joint_names: Collection[str] | None = None,
    reading: LeRobotReading | None = None,
    *,
    duration_s: float | None = None,
    limits: Mapping[str, tuple[float | None, float | None]] | None = None,
) -> Actions:
    """The ``action`` vectors of one episode (None: the dataset's first) as targets of the joints they name,
    and the episode's first ``observation.state`` where the dataset has that feature.

    Args:
        root: the dataset's folder.
        episode: the episode to read (None: the dataset's first).
        joint_names: the driven joints (None: any name).
        reading: the task file's ``[recordings]`` table: the stated unit, the names' joints.
        duration_s: the task's duration [s]: the episode is checked as a recording of the task is
            (:func:`check_schedule_episode`); None: not checked.
        limits: per driven joint its limits [rad] (None: unlimited): the stated unit is checked against them and
            against what angles in each unit look like (:func:`simtune.data.sanity.schedule_units_problem`);
            None: not checked.

    Returns:
        The episode's times (as stored), targets and first measured angles, in radians.
    """
    root = Path(root)
    reading = reading or LeRobotReading()
    info = read_info(root)
    action = pick_columns(root, info, ACTION, joint_names, reading)
    state = pick_columns(root, info, STATE, joint_names, reading) if STATE in info["features"] else None
    factor = to_radians(root, reading, f"features.{ACTION}")
    features = [ACTION] + ([STATE] if state is not None else [])
    chosen = read_episodes(root, features, None if episode is None else [episode], key="schedule_episode")[0]
    targets = _angles(chosen, action, factor, root)
    start = {} if state is None else {j: float(q[0]) for j, q in _angles(chosen, state, factor, root).items()}
    if limits is not None:
        for columns in [action] if state is None else [action, state]:
            values = {joint: chosen.vectors[columns.feature][:, entry] for entry, joint in columns.picked}
            problem = schedule_units_problem(values, limits, str(reading.units))
            if problem is not None:
                raise RecordingError(units_message(root, chosen, columns, problem, str(reading.units)))
    if duration_s is not None:
        check_schedule_episode(root, chosen, targets, duration_s)
    return Actions(chosen.time.copy(), targets, start, chosen.index)


def check_schedule_episode(root: Path, episode: Episode, targets: dict[str, np.ndarray], duration_s: float) -> None:
    """An episode whose actions are a task's schedule, checked by the rules a recording of the task meets
    (docs/recordings.md): at least 2 frames, timestamps in seconds (no frame more than
    :data:`~simtune.data.sanity.MAX_DURATION_MULTIPLE` x the task's duration after the first) and covering
    :data:`~simtune.data.sanity.MIN_DURATION_SHARE` of the task's duration.  Without them a schedule of timestamps
    in milliseconds, of one frame or of half the task would collapse or hold its last action.

    Args:
        root: the dataset's folder.
        episode: the episode, as read.
        targets: its commanded angles [rad] per driven joint.
        duration_s: the task's duration [s].

    Raises:
        RecordingError: one line naming the dataset, the episode (``<dataset>/episode_NNNNNN``) and what is wrong.
    """
    source = root / f"episode_{episode.index:06d}"
    display = _shown(root, source)
    frames = np.arange(1, len(episode.time) + 1)
    rec = finish_recording(source, display, episode.time, frames, {}, {}, dict(targets), "frame")
    check_time(rec, display, duration_s)
    lasts = float(rec.time[-1] - rec.time[0])
    if lasts < MIN_DURATION_SHARE * duration_s:
        raise RecordingError(
            f"{display}: duration check: lasts {lasts:.4g} s ({len(rec.time)} frames), less than "
            f"{MIN_DURATION_SHARE:.0%} of the task's {duration_s:g} s: as its schedule it would hold its last action "
            "for the rest of the task (shorten the task's duration, or pick a longer episode)"
        )


# --- writing -----------------------------------------------------------------------------------------------------


def write_lerobot_dataset(
    root: Path | str,
    episodes: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]],
    names: Sequence[str],
    fps: float,
    *,
    version: str = "v3.0",
    task: str = "",
    robot_type: str = "simtune",
) -> Path:
    """Write ``episodes`` (per episode: times [s] from its start, ``observation.state`` (n, k) and ``action``
    (n, k), in the unit the reader will be told) as a LeRobot dataset in ``root``; returns ``root``.

    ``names`` are the vectors' entry names (LeRobot's ``<joint>.pos``), ``version`` the layout (v3.0: one data
    file for all episodes; v2.1: one per episode), ``task`` each episode's task description.  Writes the data,
    ``meta/info.json``, the episodes' and tasks' metadata and the features' statistics; no videos.
    """
    root = Path(root)
    shown = _shown(root)
    pa, pq = _pyarrow(shown)
    if version not in WRITE_VERSIONS:
        raise RecordingError(f"{shown}: cannot write LeRobot layout {version!r} (known: {', '.join(WRITE_VERSIONS)})")
    if (root / INFO).exists() or (root / "data").exists():
        raise RecordingError(f"{shown}: cannot write: {root} already holds a LeRobot dataset")
    if not episodes:
        raise RecordingError(f"{shown}: cannot write a dataset without episodes")
    width = len(names)
    for k, (time, state, action) in enumerate(episodes):
        if np.shape(state) != (len(time), width) or np.shape(action) != (len(time), width):
            raise RecordingError(
                f"{shown}: cannot write episode {k}: state {np.shape(state)} and action {np.shape(action)} "
                f"for {len(time)} frames of {width} joints"
            )
    tables = []
    first = 0
    for k, (time, state, action) in enumerate(episodes):
        n = len(time)
        tables.append(
            pa.table(
                {
                    STATE: _list_array(pa, state, width),
                    ACTION: _list_array(pa, action, width),
                    "timestamp": pa.array(np.asarray(time, dtype=np.float32)),
                    "frame_index": pa.array(np.arange(n, dtype=np.int64)),
                    "episode_index": pa.array(np.full(n, k, dtype=np.int64)),
                    "index": pa.array(np.arange(first, first + n, dtype=np.int64)),
                    "task_index": pa.array(np.zeros(n, dtype=np.int64)),
                }
            )
        )
        first += n
    lengths = [len(time) for time, _, _ in episodes]
    v3 = version == "v3.0"
    for folder in ("meta", "data/chunk-000"):
        (root / folder).mkdir(parents=True, exist_ok=True)
    if v3:
        pq.write_table(pa.concat_tables(tables), root / "data/chunk-000/file-000.parquet")
    else:
        for k, table in enumerate(tables):
            chunk = root / f"data/chunk-{k // CHUNK_SIZE:03d}"
            chunk.mkdir(parents=True, exist_ok=True)
            pq.write_table(table, chunk / f"episode_{k:06d}.parquet")
    info = _info(version, fps, names, lengths, robot_type)
    (root / INFO).write_text(json.dumps(info, indent=4) + "\n", encoding="utf-8")
    _write_metadata(root, pa, pq, v3, task, lengths, episodes)
    return root


def _list_array(pa: Any, values: np.ndarray, width: int) -> Any:
    flat = pa.array(np.asarray(values, dtype=np.float32).reshape(-1))
    offsets = pa.array(np.arange(0, flat.__len__() + 1, width, dtype=np.int32))
    return pa.ListArray.from_arrays(offsets, flat)


def _info(version: str, fps: float, names: Sequence[str], lengths: list[int], robot_type: str) -> dict[str, Any]:
    vector = {"dtype": "float32", "shape": [len(names)], "names": list(names)}
    features = {
        STATE: vector,
        ACTION: dict(vector),
        "timestamp": {"dtype": "float32", "shape": [1], "names": None},
        **{
            key: {"dtype": "int64", "shape": [1], "names": None}
            for key in ("frame_index", "episode_index", "index", "task_index")
        },
    }
    rate = int(fps) if float(fps).is_integer() else float(fps)  # LeRobot writes a whole rate as an integer
    common = {
        "codebase_version": version,
        "robot_type": robot_type,
        "total_episodes": len(lengths),
        "total_frames": sum(lengths),
        "total_tasks": 1,
    }
    if version == "v3.0":
        layout = {
            "chunks_size": CHUNK_SIZE,
            "data_files_size_in_mb": 100,
            "video_files_size_in_mb": 500,
            "fps": rate,
            "splits": {"train": f"0:{len(lengths)}"},
            "data_path": "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet",
            "video_path": None,
        }
    else:
        layout = {
            "total_videos": 0,
            "total_chunks": (len(lengths) - 1) // CHUNK_SIZE + 1,
            "chunks_size": CHUNK_SIZE,
            "fps": rate,
            "splits": {"train": f"0:{len(lengths)}"},
            "data_path": "data/chunk-{episode_chunk:03d}/episode_{episode_index:06d}.parquet",
            "video_path": None,
        }
    return {**common, **layout, "features": features}


def _stats(values: np.ndarray) -> dict[str, list[float]]:
    values = np.asarray(values, dtype=float)
    return {
        "min": values.min(axis=0).tolist(),
        "max": values.max(axis=0).tolist(),
        "mean": values.mean(axis=0).tolist(),
        "std": values.std(axis=0).tolist(),
        "count": [len(values)],
    }


def _write_metadata(
    root: Path, pa: Any, pq: Any, v3: bool, task: str, lengths: list[int], episodes: Sequence[tuple]
) -> None:
    """Episodes, tasks and statistics, as each layout keeps them."""
    starts = np.cumsum([0, *lengths])
    if v3:
        (root / "meta/episodes/chunk-000").mkdir(parents=True, exist_ok=True)
        n = len(lengths)
        meta = {
            "episode_index": pa.array(np.arange(n, dtype=np.int64)),
            "tasks": pa.array([[task]] * n, type=pa.list_(pa.string())),
            "length": pa.array(np.asarray(lengths, dtype=np.int64)),
            "data/chunk_index": pa.array(np.zeros(n, dtype=np.int64)),
            "data/file_index": pa.array(np.zeros(n, dtype=np.int64)),
            "dataset_from_index": pa.array(starts[:-1].astype(np.int64)),
            "dataset_to_index": pa.array(starts[1:].astype(np.int64)),
            "meta/episodes/chunk_index": pa.array(np.zeros(n, dtype=np.int64)),
            "meta/episodes/file_index": pa.array(np.zeros(n, dtype=np.int64)),
        }
        pq.write_table(pa.table(meta), root / "meta/episodes/chunk-000/file-000.parquet")
        pq.write_table(pa.table({"task_index": [0], "task": [task]}), root / "meta/tasks.parquet")
        every = [np.concatenate([np.asarray(e[i]) for e in episodes]) for i in (1, 2)]
        stats = {STATE: _stats(every[0]), ACTION: _stats(every[1])}
        (root / "meta/stats.json").write_text(json.dumps(stats, indent=4) + "\n", encoding="utf-8")
        return
    lines = [json.dumps({"episode_index": k, "tasks": [task], "length": n}) for k, n in enumerate(lengths)]
    (root / "meta/episodes.jsonl").write_text("\n".join(lines) + "\n", encoding="utf-8")
    (root / "meta/tasks.jsonl").write_text(json.dumps({"task_index": 0, "task": task}) + "\n", encoding="utf-8")
    stat_lines = [
        json.dumps({"episode_index": k, "stats": {STATE: _stats(state), ACTION: _stats(action)}})
        for k, (_, state, action) in enumerate(episodes)
    ]
    (root / "meta/episodes_stats.jsonl").write_text("\n".join(stat_lines) + "\n", encoding="utf-8")


#: frames per second of the LeRobot datasets ``simtune synth`` writes (LeRobot records the SO-100/SO-101 at 30)
SYNTH_FPS = 30.0


class _Named(Protocol):
    @property
    def name(self) -> str: ...


class WrittenTask(Protocol):
    """What a writer of a task's repeats may need of the task (a :class:`simtune.tasks.TaskSpec` is one): declared
    here, so that the data layer knows nothing of tasks."""

    @property
    def name(self) -> str: ...
    @property
    def description(self) -> str: ...
    @property
    def joints(self) -> tuple[str, ...]: ...
    @property
    def lerobot(self) -> LeRobotReading | None: ...
    @property
    def schedule(self) -> tuple[np.ndarray, np.ndarray]: ...
    @property
    def robot(self) -> _Named: ...


def stated_units(task: WrittenTask) -> str:
    """The unit the task states for LeRobot datasets' angles.

    Args:
        task: the task whose ``[recordings]`` table is read.

    Returns:
        ``"deg"`` or ``"rad"``; a ConfigError naming the key when the task states none.
    """
    if task.lerobot is None or task.lerobot.units is None:
        raise ConfigError(
            f"task {task.name!r}: a LeRobot dataset's angles need a stated unit: add units = \"deg\" (LeRobot's "
            'SO-100/SO-101) or units = "rad" to the [recordings] table of its task file'
        )
    return task.lerobot.units


def write_task_dataset(
    root: Path,
    task: WrittenTask,
    recordings: Sequence[Recording],
    version: str,
    schedules: Sequence[WrittenTask] | None = None,
) -> Path:
    """``recordings`` (repeats of ``task`` logging its driven joints, sampled at :data:`SYNTH_FPS`) as a LeRobot
    dataset in ``root``: ``observation.state`` their angles, ``action`` the task's targets in force at each frame,
    in the unit the task states, named as its ``[recordings.joints]`` maps them (else ``<joint>.pos``).

    Args:
        root: the dataset folder to write.
        task: the task the repeats are of (its joints, schedule, stated unit and names).
        recordings: the repeats, each one episode.
        version: the layout, one of :data:`WRITE_VERSIONS`.
        schedules: per recording, the task whose schedule it ran (``synth --episodes``: each episode its own
            commands); None: every recording ran ``task``'s.

    Returns:
        ``root``.
    """
    reading = task.lerobot or LeRobotReading()
    factor = ANGLE_UNITS[stated_units(task)]
    episodes = []
    for rec, ran in zip(recordings, schedules or [task] * len(recordings)):
        starts, table = ran.schedule
        # the command in force at each frame's timestamp as written (float32): a schedule read from a dataset
        # starts its phases at float32 timestamps, which lie above or below the float64 frame time in about half
        # the frames; compared in float32, the phase that starts at a frame's own timestamp is in force there,
        # never one frame late
        phase_starts = np.asarray(starts, dtype=np.float32)
        state = np.column_stack([rec.joints[j] for j in task.joints]) / factor
        stamps = np.asarray(rec.time, dtype=np.float32)
        action = np.radians(table[np.searchsorted(phase_starts, stamps, side="right")]) / factor
        episodes.append((rec.time, state, action))
    names = [reading.dataset_name(j) for j in task.joints]
    return write_lerobot_dataset(
        root,
        episodes,
        names,
        SYNTH_FPS,
        version=version,
        task=task.description or task.name,
        robot_type=task.robot.name,
    )
