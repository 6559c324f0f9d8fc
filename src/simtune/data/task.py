"""The reference a simulation is scored against: all repeats of one task on a common clock."""

from __future__ import annotations

import math
import warnings
from collections.abc import Collection, Iterator, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import NoReturn

import numpy as np

from simtune.data._table import display_name
from simtune.data.clock import ClockAlignment, align_clocks, check_reference, read_later, spread, warn_outliers
from simtune.data.fingerprint import task_files
from simtune.data.formats import recording_kinds
from simtune.data.ingest import warn_of_ingest
from simtune.data.lerobot import LeRobotReading, is_lerobot_dataset
from simtune.data.loaders import load_recordings
from simtune.data.onset import motion_onset
from simtune.data.recording import Recording
from simtune.data.rosbag import UnindexedBag
from simtune.data.sanity import (
    GENERIC_REACH_M,
    JointRange,
    check_joint_units,
    check_same_units,
    check_time,
    check_units,
    duration_floor,
    wrist_distance,
)
from simtune.data.screen import far_repeats
from simtune.errors import ConfigError, RecordingError, RecordingWarning, check_choice

#: Which of a task's repeats build its reference: ``all``, or every other one in the loader's sorted order,
#: ``even`` (the 1st, 3rd, 5th ...: indices 0, 2, 4 ...) or ``odd`` (the 2nd, 4th ...: indices 1, 3 ...), to fit on
#: some repeats and score on the others.
REPEATS = ("all", "even", "odd")
#: The repeats of a run that names none (and of every run stored before the choice).
DEFAULT_REPEATS = "all"


def check_repeats(value: object, where: str = "repeats") -> str:
    """``value`` if it names a selection of repeats; else a one-line ConfigError naming ``where``."""
    return check_choice(
        value, REPEATS, where, "every repeat, or the 1st, 3rd ... or the 2nd, 4th ... of the repeats in sorted order"
    )


#: The first seconds of a recording, before the arm moves: what the object's start position is averaged over, and
#: the wrist's where it does not move sooner (:attr:`TaskData.wrist_rest_end`).
REST_S = 1.0


@dataclass
class TaskData:
    """Repeats of one task resampled to ``times`` = arange(n) / rate (0 = recording start).

    What the recordings hold is what is there: ``wrist_mean`` (n, 3) [m] and
    ``wrist_repeats`` (repeats, n, 3) when they track the wrist marker, else
    None; ``joint_mean`` (n, J) and ``joint_repeats`` (repeats, n, J) [rad] of
    the joints ``joint_names`` when they log joint angles, else None and [].
    """

    task: str
    rate: float
    times: np.ndarray
    wrist_mean: np.ndarray | None
    wrist_repeats: np.ndarray | None
    object_final: np.ndarray | None
    object_start: np.ndarray | None
    sources: list[Path]
    joint_names: list[str] = field(default_factory=list)
    joint_mean: np.ndarray | None = None
    joint_repeats: np.ndarray | None = None
    #: per repeat, the object's mean position over the recording's first :data:`REST_S` seconds (3,) [m]
    object_rest: np.ndarray | None = None
    #: ``aligned``: the repeats were shifted onto one clock before averaging (:mod:`simtune.data.clock`);
    #: ``mean``: each on its own clock, the paper's mean
    reference: str = "mean"
    #: the shifts of an aligned reference (None for the mean)
    alignment: ClockAlignment | None = None
    #: the wrist's :attr:`repeat_spread` with every repeat on its own clock [m]: the mean reference's
    unaligned_spread: float | None = None
    #: which of the repeats the loader kept build the reference (:data:`REPEATS`): ``all``, ``even`` or ``odd``
    repeats: str = DEFAULT_REPEATS
    #: the repeats the loader kept that the selection left out (none with ``all``), in sorted order
    held_out: list[Path] = field(default_factory=list)
    #: the repeats the repeat check left out as far from the others (:mod:`simtune.data.screen`), in sorted order
    left_out: list[Path] = field(default_factory=list)

    @property
    def object_start_mean(self) -> np.ndarray | None:
        """Where the object rests before the arm moves: the mean over the repeats of their first
        :data:`REST_S` seconds, (3,) [m]; None when the recordings do not track it."""
        return None if self.object_rest is None else self.object_rest.mean(axis=0)

    @property
    def wrist_rest_end(self) -> float | None:
        """When the recorded wrist's rest at the start ends [s]: :data:`REST_S`, or its motion onset
        (:func:`~simtune.data.onset.motion_onset`) where it moves sooner; None without a wrist.

        A task whose schedule starts at once (a synthetic recording, a log with a short delay) moves the arm
        within the first second: its mean would lie centimetres from the start pose it was commanded from."""
        if self.wrist_mean is None:
            return None
        onset = motion_onset(self.times, self.wrist_mean)
        return REST_S if onset is None else min(REST_S, onset)

    @property
    def wrist_start_mean(self) -> np.ndarray | None:
        """The mean recorded wrist position while it rests at the start (:attr:`wrist_rest_end`), (3,) [m], or
        None; the first sample alone where the wrist moves at once."""
        end = self.wrist_rest_end
        if self.wrist_mean is None or end is None:
            return None
        resting = self.times < end
        resting[0] = True
        return self.wrist_mean[resting].mean(axis=0)

    @property
    def object_final_mean(self) -> np.ndarray | None:
        """Mean final object position over the kept repeats, (3,), or None."""
        return None if self.object_final is None else self.object_final.mean(axis=0)

    @property
    def repeat_spread(self) -> float | None:
        """Mean over repeats of the mean 3-D distance between a repeat and ``wrist_mean`` [m]; None without a wrist."""
        if self.wrist_repeats is None or self.wrist_mean is None:
            return None
        return spread(self.wrist_repeats)

    @property
    def duration(self) -> float:
        """Length of the common time axis in seconds (last sample time)."""
        return float(self.times[-1])

    def resampled(self, indices: np.ndarray) -> TaskData:
        """The reference that the repeats ``indices`` (a repeat may come twice: a bootstrap draw) would build: their
        tracks, object positions and means.  An aligned reference's clock is the median of its repeats' shifts
        (:mod:`simtune.data.clock`), so a draw's tracks are read on its own median: ``m`` seconds later, with ``m``
        the draw's median shift less this reference's (ends held, as the loader holds them).

        Args:
            indices: positions of repeats in this reference's order (``sources``).
        Returns:
            The draw's reference; the loader's other choices (``reference``, ``repeats``, ``left_out`` ...) as here.
        """
        idx = np.asarray(indices, dtype=int)
        later, alignment = 0.0, self.alignment
        if alignment is not None:
            shifts = np.asarray(alignment.shifts, dtype=float)
            later = float(np.median(shifts[idx]) - np.median(shifts))
            onsets = [alignment.onsets[i] for i in idx]
            alignment = replace(alignment, onsets=onsets, shifts=shifts[idx] - later)

        def tracks(repeats: np.ndarray | None) -> np.ndarray | None:
            if repeats is None or later == 0.0:
                return None if repeats is None else repeats[idx]
            return np.stack([read_later(self.times, r, later) for r in repeats[idx]])

        def each(values: np.ndarray | None) -> np.ndarray | None:
            return None if values is None else values[idx]

        wrists, angles = tracks(self.wrist_repeats), tracks(self.joint_repeats)
        return replace(
            self,
            wrist_mean=None if wrists is None else wrists.mean(axis=0),
            wrist_repeats=wrists,
            joint_mean=None if angles is None else angles.mean(axis=0),
            joint_repeats=angles,
            object_final=each(self.object_final),
            object_start=each(self.object_start),
            object_rest=each(self.object_rest),
            sources=[self.sources[i] for i in idx],
            alignment=alignment,
        )


def resample(time: np.ndarray, values: np.ndarray, rate: float, n: int) -> np.ndarray:
    """Linearly interpolate ``values`` (m,) or (m, k) sampled at ``time`` onto arange(n)/rate.

    ``time`` must increase and ``values`` be NaN-free; outside ``time`` the end
    values are held.
    """
    if not (math.isfinite(rate) and rate > 0):
        raise ConfigError(f"resample: rate must be a positive number, got {rate!r}")
    time = np.asarray(time, dtype=float)
    values = np.asarray(values, dtype=float)
    target = np.arange(int(n)) / rate
    if values.ndim == 1:
        return np.interp(target, time, values)
    out = np.empty((target.size,) + values.shape[1:])
    flat_in = values.reshape(values.shape[0], -1)
    flat_out = out.reshape(target.size, -1)
    for k in range(flat_in.shape[1]):
        flat_out[:, k] = np.interp(target, time, flat_in[:, k])
    return out


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) index pairs, stop exclusive, of the True runs in ``mask``."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist()))


def _fill_gaps(time: np.ndarray, xyz: np.ndarray, max_gap_s: float) -> tuple[np.ndarray, tuple[int, int, float] | None]:
    """Bridge NaN runs of at most ``max_gap_s`` linearly (ends: nearest valid sample).

    Returns the filled positions, or None and the longest gap (start, stop,
    seconds) when a gap is too long.  A gap lasts (missing frames) x (frame period).
    """
    lost = np.isnan(xyz).any(axis=1)
    if not lost.any():
        return xyz, None
    period = float(np.median(np.diff(time)))
    longest: tuple[int, int, float] | None = None
    for start, stop in _runs(lost):
        length = float(time[stop - 1] - time[start]) + period
        if longest is None or length > longest[2]:
            longest = (start, stop, length)
    assert longest is not None
    # Small tolerance: a gap of exactly max_gap_s must not fail on float rounding.
    if longest[2] > max_gap_s + 1e-9 or lost.all():
        return xyz, longest
    ok = ~lost
    filled = np.empty_like(xyz)
    for k in range(3):
        filled[:, k] = np.interp(time, time[ok], xyz[ok, k])
    return filled, None


_KINDS = recording_kinds()  # "*.tsv, *.csv, ..., rosbag2 folders, LeRobot datasets"


def _check_joints(rec: Recording, joints: list[str], display: str) -> None:
    """Every repeat logs the joints of the first one, no fewer and no more."""
    if set(rec.joints) == set(joints):
        return
    if not joints:
        raise RecordingError(
            f"{display}: holds joint angles ({', '.join(rec.joints)}) but the first repeat does not: "
            "every repeat of a task must hold the same kinds of data"
        )
    missing = [j for j in joints if j not in rec.joints]
    extra = [j for j in rec.joints if j not in joints]
    parts = ([f"lacks {', '.join(missing)}"] if missing else []) + ([f"adds {', '.join(extra)}"] if extra else [])
    raise RecordingError(
        f"{display}: its joints differ from the first repeat's ({'; '.join(parts)}): "
        "every repeat of a task must log the same joints"
    )


def _sources(files: list[Path], unreadable: list[str], body_names, **options) -> Iterator[Recording]:
    """Every repeat that ``files`` hold; a rosbag2 folder that lacks its metadata.yaml and cannot be read from its
    storage alone is left out with a warning naming it (and added to ``unreadable``)."""
    for path in files:
        try:
            yield from load_recordings(path, body_names, **options)
        except UnindexedBag as exc:
            warnings.warn(f"{exc}: left out", RecordingWarning, stacklevel=4)  # at load_task_data's caller
            unreadable.append(display_name(path))


def _find_body(rec: Recording, body: str, display: str) -> np.ndarray:
    if body not in rec.positions:
        raise RecordingError(f"{display}: no body {body!r} (bodies: {', '.join(rec.positions) or 'none'})")
    return rec.positions[body]


def _check_numbers(rate: float, max_gap_s: float, duration_s: float | None, reach_m: float) -> None:
    if not (math.isfinite(rate) and rate > 0):
        raise ConfigError(f"rate must be a positive number of samples per second, got {rate!r}")
    if not (math.isfinite(max_gap_s) and max_gap_s >= 0):
        raise ConfigError(f"max_gap_s must be a non-negative number of seconds, got {max_gap_s!r}")
    if duration_s is not None and not (math.isfinite(duration_s) and duration_s > 0):
        raise ConfigError(f"duration_s must be a positive number of seconds, got {duration_s!r}")
    if not (math.isfinite(reach_m) and reach_m > 0):
        raise ConfigError(f"reach_m must be a positive number of metres, got {reach_m!r}")


def _files_in(folder: Path) -> list[Path]:
    """The recordings in ``folder``, sorted by name; an error when there are none."""
    if not folder.is_dir():
        raise RecordingError(f"no recordings ({_KINDS}) in {folder}: no such folder")
    files = task_files(folder)
    if not files:
        raise RecordingError(f"no recordings ({_KINDS}) in {folder}")
    return files


def _sane_recordings(
    sources: Iterator[Recording],
    wrist_body: str,
    object_body: str | None,
    base_body: str | None,
    duration_s: float | None,
    reach_m: float,
    joint_ranges: Mapping[str, JointRange] | None,
) -> tuple[list[Recording], list[str], list[str]]:
    """The sanity stage, per file: bodies or joints present, times, units; then units across the folder.

    Returns the recordings, the marker bodies and the joints they hold (as the first repeat decides).
    ``joint_ranges`` (None: the units are stated) tell joint logs in degrees from ones in radians.
    """
    recordings: list[Recording] = []
    distances: list[tuple[str, float]] = []
    bodies: list[str] = []
    joints: list[str] = []
    for rec in sources:
        display = display_name(rec.source)
        if not recordings:
            # the first repeat sets what the task's recordings hold
            joints = list(rec.joints)
            if wrist_body in rec.positions or not joints:
                bodies = [wrist_body] + ([object_body] if object_body is not None else [])
        for body in bodies:
            _find_body(rec, body, display)
        _check_joints(rec, joints, display)
        if joint_ranges is not None:
            check_joint_units(rec, joint_ranges, display)
        check_time(rec, display, duration_s)
        distance = wrist_distance(rec, wrist_body, base_body) if bodies else None
        if distance is not None:  # a wrist never seen is left out by the gap rule below
            check_units(distance, display, wrist_body, reach_m)
            distances.append((display, distance))
        recordings.append(rec)
    check_same_units(distances)
    return recordings, bodies, joints


#: a repeat kept: its recording, its clock (from its own first frame) and its bodies' gap-free tracks
_Repeat = tuple[Recording, np.ndarray, dict[str, np.ndarray]]


def _bridge_gaps(recordings: list[Recording], bodies: list[str], max_gap_s: float) -> list[_Repeat]:
    """Marker drop-outs: short ones bridged, a repeat with a long one left out with a warning."""
    repeats: list[_Repeat] = []
    for rec in recordings:
        display = display_name(rec.source)
        # The common clock starts at each recording's own first frame.
        t = rec.time - rec.time[0]
        filled: dict[str, np.ndarray] = {}
        for body in bodies:
            result, gap = _fill_gaps(t, rec.positions[body], max_gap_s)
            if gap is not None:
                start, stop, length = gap
                warnings.warn(
                    f"{display}: gap check: left out: {body!r} lost for {length:.2f} s "
                    f"(frames {start + 1}-{stop}, {t[start]:.2f}-{t[stop - 1]:.2f} s), "
                    f"longer than max_gap_s={max_gap_s:g}",
                    RecordingWarning,
                    stacklevel=3,  # at load_task_data's caller
                )
                break
            filled[body] = result
        else:
            repeats.append((rec, t, filled))
    return repeats


def _drop_short(repeats: list[_Repeat], duration_s: float | None) -> tuple[list[_Repeat], int, str]:
    """Duration check: a repeat cut off early would cut every repeat's reference to its length.

    Returns the repeats kept, how many were left out (each with a warning) and the floor's reason.
    """
    if not repeats:
        return repeats, 0, ""
    floor, reason = duration_floor([float(t[-1]) for _, t, _ in repeats], duration_s)
    for rec, t, _ in repeats:
        if t[-1] < floor:
            warnings.warn(
                f"{display_name(rec.source)}: duration check: left out: lasts {t[-1]:.2f} s "
                f"({len(t)} frames), less than {reason}",
                RecordingWarning,
                stacklevel=3,  # at load_task_data's caller
            )
    kept = [r for r in repeats if r[1][-1] >= floor]
    return kept, len(repeats) - len(kept), reason


def _none_usable(
    folder: Path, read: int, lost: int, unreadable: list[str], short: int, reason: str, max_gap_s: float
) -> NoReturn:
    """The error when every repeat was left out, with how many for each reason."""
    reasons = [f"{lost} with markers lost for longer than max_gap_s={max_gap_s:g} s"] if lost else []
    if unreadable:
        reasons.append(f"{len(unreadable)} rosbag2 folders without metadata.yaml that cannot be read")
    if short:
        reasons.append(f"{short} shorter than {reason}")
    raise RecordingError(
        f"no usable repeats in {folder}: all {read + len(unreadable)} left out ({', '.join(reasons)}; see the warnings)"
    )


def _object_positions(repeats: list[_Repeat], object_body: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per repeat, the object's first and last tracked positions (never a NaN of a lost first or last frame)
    and its position at rest: the mean of its tracked frames of the first REST_S seconds (the first one if none)."""
    seen = [np.flatnonzero(np.isfinite(rec.positions[object_body]).all(axis=1)) for rec, _, _ in repeats]
    starts = np.stack([rec.positions[object_body][s[0]] for (rec, _, _), s in zip(repeats, seen)])
    finals = np.stack([rec.positions[object_body][s[-1]] for (rec, _, _), s in zip(repeats, seen)])
    rests = np.stack(
        [rec.positions[object_body][s[t[s] < t[s[0]] + REST_S]].mean(axis=0) for (rec, t, _), s in zip(repeats, seen)]
    )
    return starts, finals, rests


def _aligned_clocks(
    repeats: list[_Repeat], bodies: list[str], joints: list[str], wrist_body: str, rate: float, warn: bool = True
) -> ClockAlignment:
    """Each repeat's shift onto the task's clock, from its wrist track (joint logs: its joint angles); a shift
    that is an outlier is warned about (``warn``)."""
    if bodies:
        tracks = [filled[wrist_body] for _, _, filled in repeats]
    else:
        tracks = [np.stack([rec.joints[j] for j in joints], axis=1) for rec, _, _ in repeats]
    alignment = align_clocks([t for _, t, _ in repeats], tracks, rate)
    if warn:
        warn_outliers([rec.source for rec, _, _ in repeats], alignment.shifts, 1.0 / rate)
    return alignment


def _select(folder: Path, kept: list[_Repeat], repeats: str) -> tuple[list[_Repeat], list[_Repeat]]:
    """The repeats ``repeats`` selects of those kept (in the loader's sorted order), and those it leaves out;
    a selection of none is a one-line error naming the folder and the choice."""
    if repeats == "all":
        return kept, []
    first = 0 if repeats == "even" else 1
    chosen = kept[first::2]
    if not chosen:
        names = ", ".join(display_name(rec.source) for rec, _, _ in kept)
        raise RecordingError(
            f"{folder}: repeats {repeats!r} selects none of its {len(kept)} usable repeat(s) ({names}): "
            f"{repeats} takes the 2nd, 4th ... of them; choose all or even"
        )
    return chosen, [r for i, r in enumerate(kept) if i % 2 != first]


def _on_common_clock(
    task: str,
    rate: float,
    repeats: list[_Repeat],
    bodies: list[str],
    joints: list[str],
    wrist_body: str,
    object_body: str | None,
    reference: str = "mean",
    warn: bool = True,
) -> TaskData:
    """The repeats resampled to ``rate`` over the shortest one's length, and their means; with the ``aligned``
    reference each repeat is shifted onto the task's clock first (its ends held where the shift uncovers them),
    warning about an outlying shift (``warn``)."""
    shortest = min(float(t[-1]) for _, t, _ in repeats)
    # floor(duration * rate) + 1 samples: every repeat covers the last one.
    n = int(math.floor(shortest * rate + 1e-9)) + 1
    alignment = None
    if reference == "aligned" and (bodies or joints):
        alignment = _aligned_clocks(repeats, bodies, joints, wrist_body, rate, warn)
    shifts = np.zeros(len(repeats)) if alignment is None else alignment.shifts
    wrists = unaligned = None
    if bodies:
        wrists = np.stack([resample(t + s, filled[wrist_body], rate, n) for (_, t, filled), s in zip(repeats, shifts)])
        unaligned = wrists
        if alignment is not None:
            unaligned = np.stack([resample(t, f[wrist_body], rate, n) for _, t, f in repeats])
    angles = None
    if joints:
        angles = np.stack(
            [
                resample(t + s, np.stack([rec.joints[j] for j in joints], axis=1), rate, n)
                for (rec, t, _), s in zip(repeats, shifts)
            ]
        )
    starts = finals = rests = None
    if object_body is not None and object_body in bodies:
        starts, finals, rests = _object_positions(repeats, object_body)
    return TaskData(
        task=task,
        rate=float(rate),
        times=np.arange(n) / rate,
        wrist_mean=None if wrists is None else wrists.mean(axis=0),
        wrist_repeats=wrists,
        object_final=finals,
        object_start=starts,
        sources=[rec.source for rec, _, _ in repeats],
        joint_names=joints,
        joint_mean=None if angles is None else angles.mean(axis=0),
        joint_repeats=angles,
        object_rest=rests,
        reference=reference,
        alignment=alignment,
        unaligned_spread=None if unaligned is None else spread(unaligned),
    )


def _screen(
    task: str, rate: float, kept: list[_Repeat], tracks: tuple[list[str], list[str], str, str | None]
) -> tuple[list[_Repeat], list[_Repeat], TaskData | None]:
    """Repeat check (:mod:`simtune.data.screen`): the repeats kept and those left out as far from the others by
    the aligned floor, each with a warning naming its file; and the aligned reference of the repeats kept that
    the check measured.  The farthest repeat goes first, and the rest are aligned and judged again without it,
    while fewer than half are gone.  ``tracks``: the bodies, joints, wrist and object body."""
    bodies, joints, wrist_body, object_body = tracks
    left_out: list[_Repeat] = []
    while True:
        aligned = _on_common_clock(task, rate, kept, bodies, joints, wrist_body, object_body, "aligned", warn=False)
        far = far_repeats(aligned.wrist_repeats, aligned.object_final, aligned.joint_repeats)
        if not far or 2 * (len(left_out) + 1) >= len(kept) + len(left_out):
            return kept, left_out, aligned
        worst = max(far, key=lambda f: f.excess)
        warnings.warn(
            f"{display_name(kept[worst.index][0].source)}: repeat check: left out: far from the other repeats of "
            f"{task} ({worst.describe()}): a marker glitch, a mirrored or swapped body, an object never touched, or "
            "another motion? --keep-repeats keeps it",
            RecordingWarning,
            stacklevel=3,  # at load_task_data's caller
        )
        left_out.append(kept[worst.index])
        kept = [r for i, r in enumerate(kept) if i != worst.index]


def load_task_data(
    folder: Path | str,
    task: str,
    wrist_body: str,
    object_body: str | None = None,
    rate: float = 20.0,
    body_names: list[str] | None = None,
    max_gap_s: float = 0.25,
    *,
    duration_s: float | None = None,
    reach_m: float = GENERIC_REACH_M,
    base_body: str | None = None,
    joint_names: Collection[str] | None = None,
    joint_topic: str | None = None,
    lerobot: LeRobotReading | None = None,
    joint_ranges: Mapping[str, JointRange] | None = None,
    reference: str = "mean",
    repeats: str = DEFAULT_REPEATS,
    keep_repeats: bool = False,
) -> TaskData:
    """Load every repeat in ``folder`` (sorted by name), check it, and put the repeats on a common clock.

    The sanity stage (:mod:`simtune.data.sanity`) checks each repeat against
    the task's commanded ``duration_s`` and the arm's ``reach_m`` (the wrist's
    largest possible distance from ``base_body``, or from the origin): a file
    in the wrong units or with impossible times is an error; a repeat much
    shorter than the task or the other repeats is left out with a
    RecordingWarning.  Short marker drop-outs are interpolated; a repeat whose
    wrist or object is lost for longer than ``max_gap_s`` is left out with a
    RecordingWarning.  The result holds no NaN.

    Joint logs: the first repeat decides what the task's recordings hold (the
    wrist marker, joint angles, or both) and every other repeat must hold the
    same (the same joints).  ``joint_names`` are the joints a recording may name
    (the arm's; None: any), ``joint_topic`` the JointState topic of ROS 2 logs.
    Without marker bodies ``object_body`` is not looked for.  A LeRobot dataset
    folder (``folder`` itself, or one in it) gives one repeat per episode, read as
    ``lerobot`` says (angle unit, names, episodes); its ``units``, the task's, is
    the unit of every joint log whose file declares none.  Without it, the
    angles of each joint in ``joint_ranges`` (the task's start angle, commanded
    range and the joint's limits) tell a log in degrees from one in radians
    (:func:`~simtune.data.sanity.check_joint_units`).  A rosbag2 folder without
    its metadata.yaml that cannot be read from its storage alone is left out
    with a RecordingWarning.

    ``reference``: ``mean`` averages the repeats each on its own clock (the seed paper's reference);
    ``aligned`` shifts each repeat onto the task's clock first (:mod:`simtune.data.clock`), warning about a
    repeat whose shift is an outlier.

    ``repeats``: which of the repeats kept (after the checks above, in sorted order) build the reference, before
    their clocks are aligned and they are averaged: ``all``, ``even`` (indices 0, 2, 4 ...) or ``odd`` (1, 3 ...);
    the ones left out are :attr:`TaskData.held_out`.  A selection of none is a RecordingError.

    The ingest checks (:mod:`simtune.data.ingest`: excitation, clock and offset of joint logs, and a LeRobot
    dataset's command check) warn, one RecordingWarning each, of data that can be used but may not say what its
    user thinks.

    Before the selection, a repeat far from the others by the aligned floor (:mod:`simtune.data.screen`: a marker
    glitch, a mirrored or body-swapped take, an object never touched) is left out with a RecordingWarning naming
    its file, and listed in :attr:`TaskData.left_out`; ``keep_repeats`` keeps every repeat.
    """
    check_reference(reference)
    check_repeats(repeats)
    _check_numbers(rate, max_gap_s, duration_s, reach_m)
    folder = Path(folder)
    files = _files_in(folder)
    unreadable: list[str] = []
    sources = _sources(files, unreadable, body_names, joint_names=joint_names, joint_topic=joint_topic, lerobot=lerobot)
    stated = None if lerobot is None else lerobot.units
    ranges = joint_ranges if stated is None else None
    recordings, bodies, joints = _sane_recordings(
        sources, wrist_body, object_body, base_body, duration_s, reach_m, ranges
    )
    # what the logs say against themselves and the robot, whatever their unit's source (simtune.data.ingest)
    warn_of_ingest(recordings, joint_ranges, [is_lerobot_dataset(rec.source.parent) for rec in recordings])
    kept = _bridge_gaps(recordings, bodies, max_gap_s)
    lost = len(recordings) - len(kept)
    kept, short, reason = _drop_short(kept, duration_s)
    if not kept:
        _none_usable(folder, len(recordings), lost, unreadable, short, reason, max_gap_s)
    left_out: list[_Repeat] = []
    data = None
    if not keep_repeats:
        kept, left_out, data = _screen(task, rate, kept, (bodies, joints, wrist_body, object_body))
    chosen, held_out = _select(folder, kept, repeats)
    if data is not None and repeats == "all" and reference == "aligned" and data.alignment is not None:
        warn_outliers(data.sources, data.alignment.shifts, 1.0 / rate)  # the check measured this reference
    else:
        data = _on_common_clock(task, rate, chosen, bodies, joints, wrist_body, object_body, reference)
    data.repeats = repeats
    data.held_out = [rec.source for rec, _, _ in held_out]
    data.left_out = sorted(rec.source for rec, _, _ in left_out)
    return data
