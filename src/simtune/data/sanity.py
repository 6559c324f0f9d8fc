"""Recording sanity: the checks that tell a usable repeat of a task from a mis-scaled, mis-timed or cut-off one.

They form one stage of :func:`simtune.data.load_task_data`, between reading
each file and putting the repeats on a common clock.  Every check has a name
that its message carries (``units check``, ``time check``, ``duration check``;
the readers add ``encoding check``), listed in docs/recordings.md.

data/ is the lowest layer: what a check must know about the arm and the task
(the wrist's reach, the task's duration, the base marker's name) comes in as
plain numbers from the caller, with generous generic values when it does not.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from simtune.data.recording import Recording
from simtune.errors import RecordingError

#: Reach [m] to judge units by when the caller does not know the arm: longer than any
#: table-top arm's (the MICO's wrist reaches 0.89 m, a UR10's 1.3 m), and with the
#: bounds below still far from both unit mistakes.
GENERIC_REACH_M = 1.5

#: The wrist's median distance from the base must lie between these shares of the reach.
#: Below (9 mm for the MICO): the wrist's and the base's rigid bodies are marker clusters
#: centimetres across on different links, which cannot sit inside each other or inside the
#: arm's 8 cm wide base column for most of a take; a file in metres read as millimetres
#: puts the wrist at most reach/1000 away.  Above: a wrist cannot be farther than the
#: reach; twice leaves room for marker offsets and a base marker off the arm's axis, while
#: millimetres read as metres are 1000x out.
UNITS_LOW_SHARE = 0.01
UNITS_HIGH_SHARE = 2.0

#: Repeats of one task move the same way, so their wrist distances agree within a few
#: per cent; a repeat off by more than this factor from the median is in other units
#: (centimetres, inches) than the rest.
SAME_UNITS_FACTOR = 3.0

#: A repeat lasting less than this share of the task's duration or of the median repeat
#: is left out: kept, it would cut every repeat's reference to its own length.
MIN_DURATION_SHARE = 0.9

#: A recording running more than this multiple of the task's duration past its first
#: frame is not a recording of the task (a time column in ms, or a damaged frame).
MAX_DURATION_MULTIPLE = 10.0

#: Without a task duration: no motion-capture take of a table-top task lasts a day.
MAX_SPAN_S = 86400.0


def check_time(rec: Recording, display: str, duration_s: float | None) -> None:
    """Time check: no frame lies further from the first than a sane multiple of the task's duration.

    (Finite and increasing times are checked by the readers, see
    :func:`simtune.data.recording.finish_recording`.)
    """
    span = rec.time - rec.time[0]
    if duration_s is None:
        limit, what = MAX_SPAN_S, "a day"
    else:
        limit = MAX_DURATION_MULTIPLE * duration_s
        what = f"{MAX_DURATION_MULTIPLE:g} x the task's {duration_s:g} s"
    beyond = np.flatnonzero(span > limit)
    if beyond.size:
        i = int(beyond[0])
        raise RecordingError(
            f"{display} {rec.where(i)}: time check: the time {rec.time[i]:.6g} s is more than {what} after the "
            f"first frame's {rec.time[0]:.6g} s (a time column in other units, or a damaged frame?)"
        )


def wrist_distance(rec: Recording, wrist_body: str, base_body: str | None) -> float | None:
    """Median distance [m] of the wrist from the base over its tracked frames; None if never tracked.

    The base is where ``base_body`` was tracked (its median position), else the
    world origin, where the recordings' frame puts the arm's base.
    """
    wrist = rec.positions[wrist_body]
    seen = np.isfinite(wrist).all(axis=1)
    if not seen.any():
        return None
    base = np.zeros(3)
    if base_body is not None and base_body in rec.positions:
        marker = rec.positions[base_body]
        tracked = np.isfinite(marker).all(axis=1)
        if tracked.any():
            base = np.median(marker[tracked], axis=0)
    return float(np.median(np.linalg.norm(wrist[seen] - base, axis=1)))


def check_units(distance: float, display: str, wrist_body: str, reach_m: float) -> None:
    """Units check: the wrist's median distance from the base must fit the arm's workspace."""
    low, high = UNITS_LOW_SHARE * reach_m, UNITS_HIGH_SHARE * reach_m
    if low <= distance <= high:
        return
    if distance < low:
        where = f"at least {low:.3g} m away (not inside the arm)"
        hint = "positions look too small - metres in a millimetre file?"
    else:
        where = f"within {high:.3g} m (twice its reach)"
        hint = "positions look too large - millimetres in a metre file?"
    raise RecordingError(
        f"{display}: units check: the wrist {wrist_body!r} stays {distance:.3g} m from the base (median), "
        f"but an arm reaching {reach_m:.3g} m keeps it {where}: {hint}"
    )


def check_same_units(distances: list[tuple[str, float]]) -> None:
    """Units check across a folder: every repeat's wrist distance agrees with the others'.

    ``distances`` holds (file name, :func:`wrist_distance`) per repeat.  A
    repeat off the median of the others by more than SAME_UNITS_FACTOR is odd;
    a minority of odd repeats is named, and when no majority agrees (two
    repeats, or half and half) the two extremes are.
    """
    if len(distances) < 2:
        return
    values = np.array([d for _, d in distances])
    # Each repeat against the median of the others: with two repeats, the median of both would hide a factor 4.
    others = [float(np.median(np.delete(values, i))) for i in range(len(values))]
    odd = [
        (name, d)
        for (name, d), ref in zip(distances, others)
        if not (1 / SAME_UNITS_FACTOR <= d / ref <= SAME_UNITS_FACTOR)
    ]
    if not odd:
        return
    if len(odd) < len(distances) / 2:
        name, d = odd[0]
        agreeing = float(np.median([x for n, x in distances if (n, x) not in odd]))
        ratio = d / agreeing
        size = f"{ratio:.3g} x larger" if ratio > 1 else f"{1 / ratio:.3g} x smaller"
        more = f" (as is {', '.join(n for n, _ in odd[1:])})" if len(odd) > 1 else ""
        raise RecordingError(
            f"{name}: units check: the wrist stays {d:.3g} m from the base (median), {size} than in the other "
            f"repeats ({agreeing:.3g} m): this repeat is in other units than the rest{more}"
        )
    (near, d_near), (far, d_far) = min(distances, key=lambda x: x[1]), max(distances, key=lambda x: x[1])
    raise RecordingError(
        f"{near}: units check: the wrist stays {d_near:.3g} m from the base (median) but {d_far:.3g} m in {far}: "
        f"the repeats are in different units"
    )


def duration_floor(durations: list[float], duration_s: float | None) -> tuple[float, str]:
    """Duration check: the shortest repeat [s] to keep, and the reason for that length, for messages.

    MIN_DURATION_SHARE of the task's duration or of the median repeat, whichever
    is longer: a repeat cut off early cannot cut the reference of all the others,
    and a folder of cut-off repeats cannot pass for the task.
    """
    median = float(np.median(durations))
    by_median = MIN_DURATION_SHARE * median
    share = f"{MIN_DURATION_SHARE * 100:g} %"
    if duration_s is not None and MIN_DURATION_SHARE * duration_s >= by_median:
        return MIN_DURATION_SHARE * duration_s, f"{share} of the task's {duration_s:g} s"
    return by_median, f"{share} of the median repeat's {median:.2f} s"


#: How far [rad] a joint log's angle may stray beyond what the task commands (its start angle and targets)
#: before the units check doubts the log: an arm following a clamped P velocity law stays between its start and
#: its targets, give or take its overshoot, a push and an encoder's zero offset (a few degrees each).
JOINT_MARGIN_RAD = math.radians(20.0)
#: The same for the joint's limits, which a real joint meets at most by its encoder's error.
LIMIT_MARGIN_RAD = math.radians(2.0)
#: A log whose angles, read as degrees, stray less than this share of how far they stray read as radians, is in
#: degrees (a log in degrees read as radians moves 57 times as far).
DEGREES_FIT_SHARE = 0.1


@dataclass(frozen=True)
class JointRange:
    """What one joint's logged angles [rad] should fit, from the task and the arm (passed as plain numbers:
    data/ knows neither): the task's start angle, the range it commands (start angle and every target), the
    joint's limits (None: unlimited), its velocity limit and the encoder offset the calibration tunes."""

    start: float
    low: float
    high: float
    lower: float | None = None
    upper: float | None = None
    #: the joint's velocity limit [rad/s] (None: not given), which the ingest's clock check holds a log's speed to
    velocity: float | None = None
    #: how far [rad] either side of zero the calibration tunes the joint's encoder offset (None: not known), which
    #: the ingest's offset check names
    tuned_offset: float | None = None

    def beyond_limits(self, angles: np.ndarray) -> tuple[float, int, str]:
        """How far [rad] ``angles`` lie beyond the joint's limits and their margin (0: not at all), at which frame,
        and the limits, for messages."""
        worst = (0.0, 0, "")
        if self.lower is None or self.upper is None:
            return worst
        low, high = int(np.argmin(angles)), int(np.argmax(angles))
        limits = f"outside its limits [{self.lower:.4g}, {self.upper:.4g}] rad"
        worst = max(worst, (self.lower - LIMIT_MARGIN_RAD - angles[low], low, limits), key=lambda w: w[0])
        return max(worst, (angles[high] - self.upper - LIMIT_MARGIN_RAD, high, limits), key=lambda w: w[0])

    def stray(self, angles: np.ndarray) -> tuple[float, int, str]:
        """How far [rad] ``angles`` stray beyond this range (0: not at all), at which frame, and what they leave."""
        worst = self.beyond_limits(angles)
        if worst[0] > 0:
            return worst  # the limits first: what no joint can do says most
        low, high = int(np.argmin(angles)), int(np.argmax(angles))
        start = f"far from the task's start angle {self.start:.4g} rad"
        worst = max(worst, (abs(angles[0] - self.start) - JOINT_MARGIN_RAD, 0, start), key=lambda w: w[0])
        commanded = f"beyond what the task commands ({self.low:.4g} to {self.high:.4g} rad)"
        worst = max(worst, (self.low - JOINT_MARGIN_RAD - angles[low], low, commanded), key=lambda w: w[0])
        return max(worst, (angles[high] - self.high - JOINT_MARGIN_RAD, high, commanded), key=lambda w: w[0])


def zero_offset(angles: np.ndarray, limits: JointRange) -> float | None:
    """The least shift [rad] that puts ``angles`` within the joint's limits, where their span fits inside them (a log
    whose zero is not the robot model's); 0 where they lie within; None where they span more than the joint's range
    or the joint has no limits."""
    if limits.lower is None or limits.upper is None:
        return None
    low, high = float(np.min(angles)), float(np.max(angles))
    if high - low > limits.upper - limits.lower:
        return None
    return max(limits.lower - low, 0.0) - max(high - limits.upper, 0.0)


def offset_words(angles: np.ndarray, limits: JointRange, lerobot: bool = True) -> str:
    """What a log past the joint's limits says of its zero (for the units and offset checks' messages): where its
    motion fits inside the limits, a zero offset of so many degrees, one the calibrated space's encoder offset tunes
    (:attr:`JointRange.tuned_offset`) or more; empty where it does not fit (a unit, another robot's joint)."""
    shift = zero_offset(angles, limits)
    if shift is None or shift == 0.0:
        return ""
    words = (
        f"; its motion fits inside the joint's limits shifted by {math.degrees(shift):+.3g} deg: a zero offset, not a "
        "unit"
    )
    if lerobot:
        words += (
            " (a LeRobot dataset's degrees are measured from the middle of the calibrated range, not the model's zero)"
        )
    tuned = limits.tuned_offset
    if tuned is not None and abs(shift) <= tuned:
        return words + (
            f", which the calibrated space's encoder offset already tunes (joint_offset_<n>, +-{math.degrees(tuned):g} "
            "deg: --space calibrated)"
        )
    if tuned is not None:
        return words + f", more than the +-{math.degrees(tuned):g} deg the calibration tunes: correct the log's zero"
    return words


def check_joint_units(rec: Recording, ranges: Mapping[str, JointRange], display: str) -> None:
    """Units check of a joint log: a log in degrees that stays within two turns passes the readers as radians.

    Joints whose unit nobody declared: where their angles read as radians stray beyond the joints' limits, the
    task's start pose or what it commands, and read as degrees fit (:data:`DEGREES_FIT_SHARE`) and move as
    commanded (:func:`_moves_as_commanded`), the log is in degrees: an error naming the file, the joint and the
    key that declares the unit.  Joints whose CSV column declares its unit (``joint_2 [deg]``) are checked in that
    unit (:func:`declared_units_problem`).

    Args:
        rec: the joint log, its angles in radians (``rec.joint_units``: the joints whose unit its file declares).
        ranges: per driven joint, what its angles should fit (the task's and the arm's).
        display: the log's name in messages.

    Raises:
        RecordingError: the log does not fit in the unit it was read in, naming the file, frame and joint.
    """
    _check_undeclared_units(rec, ranges, display)
    for unit in sorted(set(rec.joint_units.values())):
        names = [j for j in rec.joints if rec.joint_units.get(j) == unit and j in ranges]
        raw = {j: rec.joints[j] / ANGLE_FACTORS[unit] for j in names}  # the numbers as the file holds them
        problem = declared_units_problem(raw, ranges, unit)
        if problem is not None:
            hint = (
                f"declare '{problem.joint} [{problem.other}]' in its header if so"
                if problem.other is not None
                else "check the log's unit and its joints' zero against the robot model's"
            )
            raise RecordingError(
                f"{display} {rec.where(problem.frame)}: units check: joint {problem.joint!r}, declared [{unit}], "
                f"{problem.text}: {hint}"
            )


def _check_undeclared_units(rec: Recording, ranges: Mapping[str, JointRange], display: str) -> None:
    """:func:`check_joint_units` of the joints whose unit nobody declared (read as radians)."""
    names = [j for j in rec.joints if j in ranges and j not in rec.joint_units]
    if not names:
        return
    as_rad = {j: ranges[j].stray(rec.joints[j]) for j in names}
    joint = max(names, key=lambda j: as_rad[j][0])
    stray, frame, what = as_rad[joint]
    if stray <= 0:
        return
    as_deg = {j: np.radians(rec.joints[j]) for j in names}
    if max(ranges[j].stray(as_deg[j])[0] for j in names) > DEGREES_FIT_SHARE * stray:
        return
    if _moves_as_commanded(as_deg, ranges) is False:
        return  # read as degrees the arm would barely move where it was told to: radians, past its commands
    value = float(rec.joints[joint][frame])
    raise RecordingError(
        f"{display} {rec.where(frame)}: units check: joint {joint!r} reads {value:.4g} rad, {what}; read as degrees "
        f"({math.radians(value):.4g} rad) the log fits the joints' limits and the task's start pose and targets: "
        f"it is in degrees: declare units = \"deg\" in the [recordings] table of the task file (or '{joint} [deg]' "
        'in a CSV\'s header); units = "rad" if it is radians'
    )


# --- declared units ----------------------------------------------------------------------------------------------

#: the angle units a joint log may be declared in, the factor to radians and the word for messages
ANGLE_FACTORS = {"rad": 1.0, "deg": math.pi / 180.0}
UNIT_WORDS = {"rad": "radians", "deg": "degrees"}
#: A joint that the task commands over at least this span [rad] (its start angle and targets) tells a declared
#: unit by how far the log moves it: an arm following a clamped P velocity law covers much of what it is commanded.
MIN_COMMANDED_SPAN_RAD = math.radians(10.0)
#: Read in its declared unit, a log moving every such joint less than this share of its commanded span moves too
#: little for that unit ...
SMALL_MOTION_SHARE = 0.1
#: ... when read in the other unit it fits the task and moves some such joint at least this share (a log in
#: radians read as degrees moves 57 times less than it did).
OTHER_MOTION_SHARE = 0.25
#: A schedule stated in degrees, with nothing of the task to compare it with, looks like radians when every value
#: lies within one turn's number of 0 (radians of a joint's angle; degrees of any real motion soon leave +-6.28) ...
ONE_TURN = 2.0 * math.pi
#: ... read as degrees no joint moves as much as this [rad] (5.7 deg), read as radians some joint does, and read as
#: radians it fits the joints' limits.
TINY_MOTION_RAD = 0.1


@dataclass(frozen=True)
class UnitsProblem:
    """A joint log that does not fit in its declared unit: the joint and 0-based frame to name, the message's
    body (what the log reads and what that leaves) and the unit it looks like (None: neither unit fits)."""

    joint: str
    frame: int
    text: str
    other: str | None


def _other(unit: str) -> str:
    return "deg" if unit == "rad" else "rad"


def _reads(value: float, unit: str) -> str:
    """``10.47 rad`` or ``0.87 deg (0.01518 rad)`` for messages."""
    if unit == "rad":
        return f"{value:.4g} rad"
    return f"{value:.4g} deg ({value * ANGLE_FACTORS[unit]:.4g} rad)"


def declared_units_problem(
    values: Mapping[str, np.ndarray], ranges: Mapping[str, JointRange], unit: str
) -> UnitsProblem | None:
    """Units check of a joint log whose unit is declared: the declaration is checked, not taken as given.

    The log is refused when, read in ``unit``:

    * a joint lies beyond its limits (+- :data:`LIMIT_MARGIN_RAD`), which no joint does, in either unit;
    * a joint strays beyond the task's start angle or commanded range (+- :data:`JOINT_MARGIN_RAD`) while read in
      the other unit the log fits (:data:`DEGREES_FIT_SHARE`, as for undeclared logs);
    * every joint commanded over :data:`MIN_COMMANDED_SPAN_RAD` or more moves less than
      :data:`SMALL_MOTION_SHARE` of its commanded span, while read in the other unit the log fits the task and
      moves some such joint :data:`OTHER_MOTION_SHARE` of it or more (radians declared as degrees).

    A log in the declared unit that follows the task never meets any of these.

    Args:
        values: per joint, its angles as logged (numbers in ``unit``), in frame order.
        ranges: per driven joint, what its angles should fit [rad]; joints without one are not checked.
        unit: the declared unit, ``"deg"`` or ``"rad"``.

    Returns:
        The problem, or None when the log fits in its declared unit.
    """
    names = [j for j in values if j in ranges]
    if not names:
        return None
    other = _other(unit)
    declared = {j: np.asarray(values[j], dtype=float) * ANGLE_FACTORS[unit] for j in names}
    alternative = {j: np.asarray(values[j], dtype=float) * ANGLE_FACTORS[other] for j in names}
    other_stray = max(ranges[j].stray(alternative[j])[0] for j in names)
    beyond = {j: ranges[j].beyond_limits(declared[j]) for j in names}
    joint = max(names, key=lambda j: beyond[j][0])
    if beyond[joint][0] <= 0:
        strays = {j: ranges[j].stray(declared[j]) for j in names}
        joint = max(names, key=lambda j: strays[j][0])
        if strays[joint][0] > 0 and other_stray <= DEGREES_FIT_SHARE * strays[joint][0]:
            beyond = strays  # beyond the commands and the other unit fits: that unit
    stray, frame, what = beyond[joint]
    if stray > 0:
        fits = other_stray <= DEGREES_FIT_SHARE * stray
        value = float(values[joint][frame])
        read = f"read as {UNIT_WORDS[other]} ({alternative[joint][frame]:.4g} rad)"
        if fits:
            text = (
                f"reads {_reads(value, unit)}, {what}; {read} the log fits the joints' limits and the task's start "
                f"pose and targets: it looks like {UNIT_WORDS[other]}"
            )
            return UnitsProblem(joint, frame, text, other)
        text = f"reads {_reads(value, unit)}, {what}; {read} it fits no better: neither unit fits the robot model"
        text += offset_words(declared[joint], ranges[joint])  # only the limits lead here: perhaps a zero, not a unit
        return UnitsProblem(joint, frame, text, None)
    return _small_motion(values, declared, alternative, ranges, unit, other_stray)


def _small_motion(
    values: Mapping[str, np.ndarray],
    declared: dict[str, np.ndarray],
    alternative: dict[str, np.ndarray],
    ranges: Mapping[str, JointRange],
    unit: str,
    other_stray: float,
) -> UnitsProblem | None:
    """The third rule of :func:`declared_units_problem`: a log that moves far too little in its declared unit."""
    share = _motion_shares(declared, ranges)
    if not share or other_stray > 0:
        return None
    other_share = max(_motion_shares(alternative, ranges).values())
    if max(share.values()) >= SMALL_MOTION_SHARE or other_share < OTHER_MOTION_SHARE:
        return None
    spans = {j: ranges[j].high - ranges[j].low for j in share}
    joint = max(share, key=lambda j: spans[j])
    frame = int(np.argmax(np.abs(declared[joint] - declared[joint][0])))
    other = _other(unit)
    moved = float(np.ptp(np.asarray(values[joint], dtype=float)))
    text = (
        f"moves {_reads(moved, unit)}, {share[joint]:.1%} of the {math.degrees(spans[joint]):.4g} deg the task "
        f"commands it over (no joint moves {SMALL_MOTION_SHARE:.0%} of its commanded span); read as "
        f"{UNIT_WORDS[other]} it moves {float(np.ptp(alternative[joint])):.4g} rad and fits the joints' limits and "
        f"the task's start pose and targets: it looks like {UNIT_WORDS[other]}"
    )
    return UnitsProblem(joint, frame, text, other)


def _motion_shares(angles: Mapping[str, np.ndarray], ranges: Mapping[str, JointRange]) -> dict[str, float]:
    """How far ``angles`` [rad] move each joint the task commands over :data:`MIN_COMMANDED_SPAN_RAD` or more, as a
    share of that span (the joints commanded less tell nothing), in ``angles``' order."""
    spans = {j: ranges[j].high - ranges[j].low for j in angles}
    return {j: float(np.ptp(angles[j])) / spans[j] for j in angles if spans[j] >= MIN_COMMANDED_SPAN_RAD}


def _moves_as_commanded(angles: Mapping[str, np.ndarray], ranges: Mapping[str, JointRange]) -> bool | None:
    """Whether ``angles`` [rad] move some joint the task commands over :data:`MIN_COMMANDED_SPAN_RAD` or more by
    :data:`SMALL_MOTION_SHARE` of its span, as an arm that follows its commands does; None where no joint is
    commanded that far (nothing to tell by).

    What keeps a log in radians whose arm overshoots its commands from being called degrees: read as degrees any
    log of small numbers fits the task's range, but moves 57 times too little.  A synthetic Panda with hidden servo
    gains (Drake, 2026-11-27) took joint 5 20.1 deg past its targets, beyond the check's margin."""
    shares = _motion_shares(angles, ranges)
    return max(shares.values()) >= SMALL_MOTION_SHARE if shares else None


def schedule_units_problem(
    values: Mapping[str, np.ndarray], limits: Mapping[str, tuple[float | None, float | None]], unit: str
) -> UnitsProblem | None:
    """Units check of a schedule stated in a unit (a LeRobot episode's actions and first state), which has nothing
    of the task to be compared with: only the joints' limits and what angles in each unit look like.

    Refused: a value beyond its joint's limits (+- :data:`LIMIT_MARGIN_RAD`); and, stated in degrees, a schedule
    that looks like radians: every value within :data:`ONE_TURN` of 0, no joint moving :data:`TINY_MOTION_RAD`
    read as degrees but some joint moving that much read as radians, within the joints' limits.  A schedule in
    degrees that stays that close to 0 and moves that little cannot be told from radians.

    Args:
        values: per joint, its commanded angles as stated (numbers in ``unit``), in frame order.
        limits: per angular joint, its lower and upper limit [rad] (None, None: unlimited, a continuous joint);
            joints without an entry (a prismatic joint) are not checked.
        unit: the stated unit, ``"deg"`` or ``"rad"``.

    Returns:
        The problem, or None when the schedule fits in its stated unit.
    """
    other = _other(unit)
    ranges = {j: JointRange(0.0, 0.0, 0.0, *limits[j]) for j in values if j in limits}  # limits only
    raw = {j: np.asarray(q, dtype=float) for j, q in values.items() if j in ranges}
    if not raw:
        return None
    beyond = {j: ranges[j].beyond_limits(raw[j] * ANGLE_FACTORS[unit]) for j in raw}
    other_beyond = max(ranges[j].beyond_limits(raw[j] * ANGLE_FACTORS[other])[0] for j in raw)
    joint = max(raw, key=lambda j: beyond[j][0])
    stray, frame, what = beyond[joint]
    if stray > 0:
        value = float(raw[joint][frame])
        if other_beyond <= 0:
            text = (
                f"reads {_reads(value, unit)}, {what}; read as {UNIT_WORDS[other]} "
                f"({value * ANGLE_FACTORS[other]:.4g} rad) every value fits the joints' limits: "
                f"it looks like {UNIT_WORDS[other]}"
            )
            return UnitsProblem(joint, frame, text, other)
        text = f"reads {_reads(value, unit)}, {what}, in either unit"
        return UnitsProblem(joint, frame, text + offset_words(raw[joint] * ANGLE_FACTORS[unit], ranges[joint]), None)
    if unit != "deg" or other_beyond > 0:
        return None
    largest = max(float(np.max(np.abs(q))) for q in raw.values())
    moves = {j: float(np.ptp(q)) for j, q in raw.items()}
    joint = max(raw, key=lambda j: moves[j])
    if largest > ONE_TURN or not TINY_MOTION_RAD <= moves[joint] < TINY_MOTION_RAD / ANGLE_FACTORS["deg"]:
        return None
    frame = int(np.argmax(np.abs(raw[joint] - raw[joint][0])))
    text = (
        f"moves {_reads(moves[joint], unit)} and no joint more, every value within {ONE_TURN:.3g} of 0, as a "
        f"radians log's numbers are; read as radians it moves {moves[joint]:.4g} rad within the joints' limits: "
        "it looks like radians (a schedule in degrees this small cannot be told from one in radians)"
    )
    return UnitsProblem(joint, frame, text, "rad")
