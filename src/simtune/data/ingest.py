"""Ingest checks: what a joint log says against itself and the robot before its motion is trusted (issue 70 item 4).

The sanity stage (:mod:`simtune.data.sanity`) refuses what cannot be used (a unit that fits no joint, impossible
times) and leaves out what would spoil the reference (a repeat cut short: the duration check).  The checks here find
data that can be used but may not say what its user thinks, and warn (a :class:`~simtune.errors.RecordingWarning`,
one line each, naming the file or episode, the check and the channel):

* **excitation check**: a driven joint that barely moves in every repeat: the recordings hardly tell its own
  parameters (a teleoperator who never turned the wrist);
* **command check**: a LeRobot episode whose ``action`` equals its ``observation.state``: the measured positions
  logged as the commands, not what the servos were told;
* **clock check**: timestamps at a nominal rate that the motion contradicts: frames repeated while the arm moves,
  or a speed beyond the joint's velocity limit (LeRobot's timestamps are ``frame_index / fps``, synthesised, not
  measured: a loop that fell behind keeps its nominal clock);
* **offset check**: a joint logged past its limits by less than the units check refuses: a zero offset
  (LeRobot's degrees are measured from the middle of the calibrated range, not from the robot model's zero), which
  the calibrated space's encoder offset tunes where it is small.

:data:`CHECKS` is the one table of them (docs/recordings.md lists it).  Every message reads
``<file or episode>: <check>: <channel>: <what>``, which :func:`data_check_entry` reads back for ``simtune check
--json`` (a warning raised again from the start-up cache keeps its text alone).

data/ is the lowest layer: what a check knows of the robot and the task comes in a
:class:`~simtune.data.sanity.JointRange` per joint, as plain numbers.
"""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from simtune.data._table import display_name
from simtune.data.recording import Recording
from simtune.data.sanity import LIMIT_MARGIN_RAD, MIN_COMMANDED_SPAN_RAD, JointRange, offset_words
from simtune.errors import RecordingWarning


@dataclass(frozen=True)
class IngestCheck:
    """One ingest check: its name (as its messages carry it), what it finds and its rule, for docs/recordings.md."""

    name: str
    finds: str
    rule: str


#: A driven joint whose logged angle spans less than this [rad] in every repeat barely moves: 20 times a hobby
#: servo's 0.05-deg encoder noise, far below any deliberate motion.
WEAK_SPAN_RAD = math.radians(1.0)
#: An ``action`` within this [rad] of ``observation.state`` in every frame of an episode is the same stream: far
#: below a servo's resolution (0.09 deg on the SO-101's), far above float32's rounding of degrees.
SAME_STREAM_RAD = math.radians(0.01)
#: A frame whose every joint repeats the frame before exactly, while the arm moves faster than this [rad/s] around
#: it, was logged twice: at 30 frames a second a joint moving 10 deg/s changes by 0.33 deg a frame, four counts of
#: the SO-101's 0.088-deg encoder, so a real reading differs.
HELD_SPEED_RAD_S = math.radians(10.0)
#: ... and this many such frames in one recording say its clock ticked without new readings.
HELD_FRAMES = 3
#: Speeds are measured over this stretch [s] (a frame's noise does not count) ...
SPEED_WINDOW_S = 0.1
#: ... and a joint faster than this many times its velocity limit moved faster than the robot can.
SPEED_FACTOR = 1.5
#: A joint logged more than this [rad] beyond its limits is past them by more than an encoder's error.
OFFSET_WARN_RAD = math.radians(0.5)

CHECKS = (
    IngestCheck(
        "excitation check",
        "a joint that barely moves (weak excitation)",
        f"a driven joint spanning less than {math.degrees(WEAK_SPAN_RAD):g} deg in every repeat (a joint of a "
        f"LeRobot dataset the task commands over {math.degrees(MIN_COMMANDED_SPAN_RAD):g} deg that stays under 2% "
        "of it in every episode is the still-joint warning's)",
    ),
    IngestCheck(
        "command check",
        "a command channel equal to the measured position (the wrong channel logged)",
        f"a LeRobot episode whose `action` lies within {math.degrees(SAME_STREAM_RAD):g} deg of its "
        "`observation.state` in every frame, for every driven joint, while it moves",
    ),
    IngestCheck(
        "clock check",
        "timestamps at a nominal rate that the motion contradicts",
        f"{HELD_FRAMES} or more frames repeating the one before in every joint while the arm moves "
        f"{math.degrees(HELD_SPEED_RAD_S):g} deg/s or faster, or a joint faster than {SPEED_FACTOR:g} x its velocity "
        f"limit over {SPEED_WINDOW_S:g} s",
    ),
    IngestCheck(
        "offset check",
        "a zero offset that does not fit the robot's limits",
        f"a joint logged more than {math.degrees(OFFSET_WARN_RAD):g} deg past a limit (more than "
        f"{math.degrees(LIMIT_MARGIN_RAD):g} deg: the units check refuses it where it checks the unit)",
    ),
)
NAMES = tuple(check.name for check in CHECKS)


def _warn(where: str, check: str, channel: str, text: str) -> None:
    assert check in NAMES, check
    warnings.warn(f"{where}: {check}: {channel}: {text}", RecordingWarning, stacklevel=4)  # at load_task_data's caller


def _which(recordings: Sequence[Recording]) -> str:
    """The first recording's name, and how many others, for a line about several."""
    first = display_name(recordings[0].source)
    others = len(recordings) - 1
    return first if not others else f"{first} (and {others} other repeat{'s' if others > 1 else ''})"


def warn_of_ingest(
    recordings: Sequence[Recording], ranges: Mapping[str, JointRange] | None, lerobot: Sequence[bool] = ()
) -> None:
    """The excitation, clock and offset checks of a task's joint logs (the command check needs a dataset's
    ``action``: :func:`copied_commands`), each a RecordingWarning.

    Args:
        recordings: the task's repeats as read (joint angles in radians; marker recordings are not checked).
        ranges: per driven joint, what its angles should fit (its commanded range, limits, velocity limit and the
            encoder offset the calibration tunes); None: only the joints' own motion is checked.
        lerobot: per recording, whether it is an episode of a LeRobot dataset (whose still joints are warned of
            by :func:`simtune.data.lerobot.warn_of_still_joints`); empty: none is.
    """
    from simtune.data.lerobot import STILL_SHARE  # on use: the LeRobot reader imports this module

    logs = [rec for rec in recordings if rec.joints and len(rec.time) >= 2]
    if not logs:
        return
    ranges = ranges or {}
    from_dataset = any(lerobot)
    weak: dict[str, tuple[float, float | None]] = {}  # joint -> (its largest span, its commanded span) [rad]
    for joint in logs[0].joints:
        spans = [float(np.ptp(rec.joints[joint])) for rec in logs if joint in rec.joints]
        commanded = ranges[joint].high - ranges[joint].low if joint in ranges else None
        if not spans or max(spans) >= WEAK_SPAN_RAD:
            continue
        told = from_dataset and commanded is not None and commanded >= MIN_COMMANDED_SPAN_RAD
        if told and commanded is not None and max(spans) < STILL_SHARE * commanded:
            continue  # never moves where it is told to, in any episode: the still-joint warning says so
        weak[joint] = (max(spans), commanded)
    if weak:
        # one line for them all: a task that holds some joints still on purpose gets one line, not one per joint
        each = ", ".join(
            f"{joint} {math.degrees(span):.2g} deg" + ("" if commanded is None else _commanded(commanded))
            for joint, (span, commanded) in weak.items()
        )
        _warn(
            _which(logs),
            "excitation check",
            f"joint{'s' if len(weak) > 1 else ''} {', '.join(repr(j) for j in weak)}",
            f"move{'' if len(weak) > 1 else 's'} less than {math.degrees(WEAK_SPAN_RAD):g} deg in every repeat ({each} "
            "at most): weak excitation, the recordings hardly tell such a joint's own parameters (damping, friction, "
            "armature, offset); record a motion that moves it, or leave them out (`simtune check --task` says which "
            "parameters the recordings inform)",
        )
    for rec in logs:
        _clock_check(rec, ranges)
    _offset_check(logs, ranges, any(lerobot))


def _commanded(span: float) -> str:
    """How far [rad] the task commands a weakly excited joint, in words."""
    return " (the task holds it)" if span < math.radians(0.05) else f" (commanded over {math.degrees(span):.2g})"


def _speeds(rec: Recording) -> dict[str, np.ndarray]:
    """Each joint's speed [rad/s] at each frame, over the :data:`SPEED_WINDOW_S` ending there (the first frames':
    from the first frame; the first frame's: 0)."""
    t = rec.time
    before = np.clip(np.searchsorted(t, t - SPEED_WINDOW_S, side="right") - 1, 0, None)
    span = np.where(t - t[before] > 0, t - t[before], np.inf)
    return {j: np.abs(q - q[before]) / span for j, q in rec.joints.items()}


def _clock_check(rec: Recording, ranges: Mapping[str, JointRange]) -> None:
    """The clock check of one joint log: frames logged twice while the arm moves, a joint faster than it can."""
    where = display_name(rec.source)
    steps = np.diff(rec.time)
    # within float32's rounding of a timestamp: a measured clock jitters by far more (milliseconds)
    nominal = bool(steps.size) and float(np.ptp(steps)) <= 1e-3 * max(float(np.median(steps)), 1e-9)
    clock = (
        f"its timestamps step a uniform {float(np.median(steps)):.4g} s, a nominal rate (as LeRobot's frame_index / "
        "fps is), not a measured one"
        if nominal
        else "its timestamps are not the readings' own"
    )
    speed = _speeds(rec)
    moving = np.max(np.column_stack(list(speed.values())), axis=1)
    angles = np.column_stack(list(rec.joints.values()))
    repeated = np.flatnonzero(np.all(angles[1:] == angles[:-1], axis=1)) + 1
    # moving around the frame: the speed into the frame before it, or out of it to the next
    after = np.minimum(repeated + 1, len(moving) - 1)
    held = [int(i) for i, k in zip(repeated, after) if max(moving[i - 1], moving[k]) >= HELD_SPEED_RAD_S]
    if len(held) >= HELD_FRAMES:
        _warn(
            where,
            "clock check",
            "every joint",
            f"{len(held)} frames repeat the one before exactly while the arm moves (the first: {rec.where(held[0])}, "
            f"{rec.time[held[0]] - rec.time[0]:.3f} s): the clock ticked without new readings (a recording loop that "
            f"fell behind; {clock}), so the motion's timing is off by the frames held; record again, or drop the "
            "repeated frames",
        )
    for joint, v in speed.items():
        limit = ranges[joint].velocity if joint in ranges else None
        if limit is None or limit <= 0:
            continue
        i = int(np.argmax(v))
        if v[i] > SPEED_FACTOR * limit:
            _warn(
                where,
                "clock check",
                f"joint {joint!r}",
                f"moves {v[i]:.3g} rad/s at {rec.where(i)} ({rec.time[i] - rec.time[0]:.3f} s), {v[i] / limit:.1f} x "
                f"its velocity limit {limit:.3g} rad/s: faster than the robot can, so the frames lay farther apart "
                f"than their timestamps say (a wrong fps, dropped frames; {clock}) - or the angles are in another unit",
            )


def _offset_check(logs: Sequence[Recording], ranges: Mapping[str, JointRange], lerobot: bool) -> None:
    """The offset check: per joint with limits, the farthest any repeat lies past one, where it is past them by more
    than an encoder's error (:data:`OFFSET_WARN_RAD`)."""
    for joint, limits in ranges.items():
        if limits.lower is None or limits.upper is None:
            continue
        worst: tuple[float, Recording | None, int, str] = (0.0, None, 0, "")
        for rec in logs:
            q = rec.joints.get(joint)
            if q is None:
                continue
            low, high = int(np.argmin(q)), int(np.argmax(q))
            worst = max(
                worst,
                (limits.lower - float(q[low]), rec, low, f"below its lower limit {limits.lower:.4g} rad"),
                (float(q[high]) - limits.upper, rec, high, f"above its upper limit {limits.upper:.4g} rad"),
                key=lambda w: w[0],
            )
        past, found, frame, side = worst
        if found is None or past <= OFFSET_WARN_RAD:
            continue
        angles = np.concatenate([r.joints[joint] for r in logs if joint in r.joints])
        what = offset_words(angles, limits, lerobot).removeprefix("; ") or (
            "its motion spans more than the joint's range: a unit, or a joint of another robot"
        )
        _warn(
            display_name(found.source),
            "offset check",
            f"joint {joint!r}",
            f"reads {float(found.joints[joint][frame]):.4g} rad at {found.where(frame)}, {math.degrees(past):.3g} deg "
            f"{side}: {what}",
        )


def copied_commands(states: Sequence[np.ndarray], actions: Sequence[np.ndarray], episodes: Sequence[int]) -> list[int]:
    """The command check: the episodes whose commands are their measured positions.

    Args:
        states: per episode, its driven joints' ``observation.state`` [rad], (n, k).
        actions: per episode, the same joints' ``action`` [rad], (n, k), in the same column order.
        episodes: the episodes' indices.

    Returns:
        The indices of the episodes whose ``action`` lies within :data:`SAME_STREAM_RAD` of their state in every
        frame and joint while some joint moves :data:`WEAK_SPAN_RAD` or more (a still arm's command is its state).
    """
    same = []
    for index, state, action in zip(episodes, states, actions):
        if state.shape != action.shape or not state.size:
            continue
        moves = float(np.max(np.ptp(state, axis=0))) >= WEAK_SPAN_RAD
        if moves and float(np.max(np.abs(state - action))) <= SAME_STREAM_RAD:
            same.append(int(index))
    return same


def warn_of_copied_commands(where: str, channel: str, episodes: Sequence[int], total: int) -> None:
    """The command check's warning (``episodes``: :func:`copied_commands`'s, of ``total`` read) for a dataset
    ``where`` whose ``channel`` names both features."""
    if not episodes:
        return
    which = f"episode {episodes[0]}" if len(episodes) == 1 else f"episodes {', '.join(map(str, episodes[:5]))}"
    more = f" and {len(episodes) - 5} more" if len(episodes) > 5 else ""
    others = f" (and {len(episodes) - 1} other episode{'s' if len(episodes) > 2 else ''})" if len(episodes) > 1 else ""
    _warn(
        f"{where}/episode_{episodes[0]:06d}{others}",
        "command check",
        channel,
        f"the commands equal the measured positions in {which}{more} (of {total}; every frame, every driven joint, "
        f"within {math.degrees(SAME_STREAM_RAD):g} deg): the positions were logged as the commands, not what the "
        "servos were told (a teleoperated `action` is the leader arm's, which the follower lags): a schedule read "
        "from them replays the arm's own motion, and its delay reads 0; log the commands",
    )


#: ``<file or episode>: <check>: <what>`` - a message of a named check (the ingest's, the sanity stage's, the
#: readers')
_MESSAGE = re.compile(r"^(?P<source>.+?): (?P<check>[a-z]+(?: [a-z]+)? check): (?P<rest>.*)$", re.S)
_EPISODE = re.compile(r"episode_(\d+)")


def data_check_entry(message: str) -> dict | None:
    """One warning of a named check as ``simtune check --json`` lists it (``data_checks``).

    Args:
        message: the warning's text.

    Returns:
        ``check`` (its name), ``source`` (the file or ``<dataset>/episode_NNNNNN`` it names), ``episode`` (a LeRobot
        episode's index, else None), ``channel`` (an ingest check's joint or feature, else None) and ``message``;
        None for a message of no named check.
    """
    match = _MESSAGE.match(message)
    if match is None:
        return None
    source, check, rest = match["source"], match["check"], match["rest"]
    episode = _EPISODE.search(source)
    channel = rest.split(": ", 1)[0] if check in NAMES and ": " in rest else None
    return {
        "check": check,
        "source": source,
        "episode": int(episode.group(1)) if episode else None,
        "channel": channel,
        "message": message,
    }


def data_check_entries(messages: Sequence[str]) -> list[dict]:
    """:func:`data_check_entry` of each message of a named check, in order, each once."""
    entries = (data_check_entry(m) for m in dict.fromkeys(messages))
    return [e for e in entries if e is not None]
