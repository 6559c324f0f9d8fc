"""The options several commands share, declared once as ``Annotated`` aliases, and the checks of their values.

A value is checked where it enters: one line naming the option, exit status 2, nothing written yet.  Options
whose help differs from command to command (``--out``, ``--max-seconds`` ...) are made by a function taking
that help.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Annotated, Any

import typer

from simtune.common.limits import MAX_SEED, MAX_WORKERS
from simtune.data import REPEATS
from simtune.data.clock import REFERENCES
from simtune.data.formats import recording_kinds
from simtune.optimizers import optimizer_help
from simtune.tasks import LOADINGS, TARGETS

#: the longest file or folder name common file systems allow [bytes]
NAME_MAX = 255
PATH_MAX = 4095


def seconds(value: float | None) -> float | None:
    """A duration [s]: finite and above zero."""
    if value is not None and not (math.isfinite(value) and value > 0):
        raise typer.BadParameter(f"{value:g} is not a number of seconds above 0")
    return value


def not_negative(value: float | None) -> float | None:
    """A finite number, zero or more."""
    if value is not None and not (math.isfinite(value) and value >= 0):
        raise typer.BadParameter(f"{value:g} is not a finite number of 0 or more")
    return value


def finite(value: float | None) -> float | None:
    if value is not None and not math.isfinite(value):
        raise typer.BadParameter(f"{value:g} is not a finite number")
    return value


def path(value: Path | None) -> Path | None:
    """A path every file system can hold: no name in it over 255 bytes."""
    if value is None:
        return value
    for part in value.parts:
        size = len(os.fsencode(part))
        if size > NAME_MAX:
            raise typer.BadParameter(
                f"the name {part[:24]}... is {size} bytes long; file systems allow {NAME_MAX} bytes per name"
            )
    if len(os.fsencode(str(value))) > PATH_MAX:
        raise typer.BadParameter(f"the path is longer than {PATH_MAX} bytes")
    return value


def out_option(help: str, *, checked: bool = True, **more: Any) -> Any:
    """``--out``/``-o``, the folder a command writes, with that command's help (``checked``: its path checked)."""
    if checked:
        more["callback"] = path
    return typer.Option("--out", "-o", help=help, **more)


def max_seconds_option(help: str, **more: Any) -> Any:
    """A wall-time limit [s] with that command's help."""
    return typer.Option(help=help, callback=seconds, **more)


def max_generations_option(help: str) -> Any:
    return typer.Option(min=1, help=help)


def refine_option(help: str) -> Any:
    return typer.Option("--refine", help=help)


def seed_option(help: str) -> Any:
    return typer.Option(min=0, max=MAX_SEED, help=help)


SeedOpt = Annotated[int, seed_option("Random seed of the optimiser (same seed, same run).")]
EngineOpt = Annotated[str, typer.Option("--engine", "-e", help="Physics engine: see `simtune engines`.")]
TaskOpt = Annotated[
    str,
    typer.Option(
        "--task", "-t", help="Task name, or several joined by commas (their fitness is summed); see `simtune tasks`."
    ),
]
DataOpt = Annotated[
    Path | None,
    typer.Option(
        "--data",
        "-d",
        help=f"Folder with one sub-folder of recordings per task (`ROOT/<task>/{recording_kinds()}`). "
        "Default: the reference recordings shipped with simtune.",
        callback=path,
    ),
]
ProjectOpt = Annotated[
    Path | None,
    typer.Option(
        "--project",
        help="Project folder: simtune.toml, the robot and its task files (docs/task-files.md). "
        "Default: the bundled Kinova MICO project.",
        callback=path,
    ),
]
JsonOpt = Annotated[bool, typer.Option("--json", help="Print one JSON object instead of a table.")]
#: what ``--reference`` is, said once for every command that scores
REFERENCE_HELP = (
    "What a simulation is scored against: aligned (each repeat's clock shifted onto the task's median motion "
    "onset, refined by matching it to the other repeats, then averaged: docs/recordings.md) or mean (the repeats "
    "averaged as recorded: the paper's fitness). Default: aligned; mean with --paper-exact."
)


def one_of(choices: tuple[str, ...]):
    """A callback that passes None or one of ``choices`` and refuses anything else in one line."""
    named = (
        f"neither {choices[0]} nor {choices[1]}"
        if len(choices) == 2
        else f"not {', '.join(choices[:-1])} or {choices[-1]}"
    )

    def check(value: str | None) -> str | None:
        if value is not None and value not in choices:
            raise typer.BadParameter(f"{value!r} is {named}")
        return value

    return check


#: ``--reference``: aligned or mean
reference = one_of(REFERENCES)


ReferenceOpt = Annotated[str | None, typer.Option("--reference", help=REFERENCE_HELP, callback=reference)]
#: what ``--repeats`` is, said once for every command that scores
REPEATS_HELP = (
    "Which of each task's repeats build the reference, in sorted file order: all, even (the 1st, 3rd, 5th ...) or "
    "odd (the 2nd, 4th ...), chosen before their clocks are aligned and they are averaged: tune on even, score on "
    "odd (held-out repeats: docs/tuning.md). Default: all."
)


#: ``--repeats``: all, even or odd
repeats = one_of(REPEATS)


RepeatsOpt = Annotated[str | None, typer.Option("--repeats", help=REPEATS_HELP, callback=repeats)]
#: ``simtune grid``'s spelling of it: its ``--repeats`` is the number of seeds
RepeatSetOpt = Annotated[
    str | None,
    typer.Option(
        "--repeat-set",
        help=REPEATS_HELP.replace("Default: all.", "Default: all. (--repeats is the number of seeds here.)"),
        callback=repeats,
    ),
]


#: what ``--targets`` is, said once for every command that runs a task's schedule
TARGETS_HELP = (
    "Which joint targets the tasks' phases carry: task (the task files' targets_deg: what the robot ran) or "
    "published (a phase's published_targets_deg where its task file corrects the published schedule, as the "
    "bundled cube's phase 2: docs/calibration.md). Default: task; published with --paper-exact."
)
TargetsOpt = Annotated[str | None, typer.Option("--targets", help=TARGETS_HELP, callback=one_of(TARGETS))]

#: what ``--loading`` is, said once for every command that simulates a run's tasks
LOADING_HELP = (
    "How the engines load the robot: description (as its file says: in PyBullet the file's inertias and no link "
    "damping of Bullet's own) or paper (as the seed paper loaded it: PyBullet's inertias from the collision shapes "
    "and link damping 0.04). Only PyBullet loads the two differently. Default: description; paper with --paper-exact."
)
LoadingOpt = Annotated[str | None, typer.Option("--loading", help=LOADING_HELP, callback=one_of(LOADINGS))]


QuietOpt = Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")]
WeightsOpt = Annotated[
    str | None,
    typer.Option(
        "--weights",
        help="Weights of the fitness's parts, e.g. joint=0.1,wrist=1,object=1 (keys left out keep their "
        "defaults: wrist 1, object 1, joint 0.5 m/rad); a part the recordings lack counts nothing.",
    ),
]
JointTopicOpt = Annotated[
    str | None,
    typer.Option(
        "--joint-topic",
        help="ROS 2 joint logs: the sensor_msgs/msg/JointState topic to read (default: each log's only one).",
    ),
]
SPACE_HELP = (
    "Parameter space: shared (31, the paper's), individual (57, the paper's), extended (individual + command delay "
    "and marker offset; for an own robot also each joint's armature, Coulomb friction, controller gain and servo "
    "gain), calibrated (extended + encoder offsets and joint compliance), gains (calibrated + the MICO's controller "
    "and servo gains) or drivetrain (gains + the MICO's armature and friction); for an own robot gains and drivetrain "
    "are its calibrated, whose extended holds the whole drive train (armature, friction and both gains: 4 per "
    "joint); an engine's lacks what it cannot map."
)
SpaceOpt = Annotated[str, typer.Option("--space", "-s", help=SPACE_HELP)]
#: ``tune``'s: its default depends on --paper-exact
TuneSpaceOpt = Annotated[
    str | None,
    typer.Option(
        "--space",
        "-s",
        help=f"{SPACE_HELP} Default: calibrated (shared with --paper-exact): docs/tuning.md says why.",
        show_default=False,
    ),
]
AlignClockOpt = Annotated[
    bool | None,
    typer.Option(
        "--align-clock/--no-align-clock",
        help="Align each task's recording clock first: its command delay estimated from its recordings "
        "(motion onset, then a 1-D search over the delay with the physics held fixed). Default: the tasks "
        "a run's --params-file was not tuned on (its 'tasks' field), which carry another recording's delay.",
        show_default=False,
    ),
]
KeepRepeatsOpt = Annotated[
    bool,
    typer.Option(
        "--keep-repeats",
        help="Keep a repeat far from the others by the aligned floor (a marker glitch, a mirrored or body-swapped "
        "take, an object never touched), which is otherwise left out with a warning naming its file "
        "(docs/recordings.md, the repeat check).",
    ),
]
KeepInactiveOpt = Annotated[
    bool,
    typer.Option(
        "--keep-inactive",
        help="Keep parameters that change no rollout of the tasks (measured before the search, see "
        "`simtune params --task T`) in the search: the paper's full D. --paper-exact implies it.",
    ),
]


def parameter_names(text: str | None) -> str | None:
    """--only's text: None, or one naming at least one parameter (an --only that names none is an error, never the
    whole space)."""
    if text is not None and not [name for name in text.split(",") if name.strip()]:
        raise typer.BadParameter(f"no parameter named in {text!r}: name one or more, e.g. --only command_delay")
    return text


OnlyOpt = Annotated[
    str | None,
    typer.Option(
        help="Only these parameters of the space (comma-separated); the rest keep their generic values.",
        callback=parameter_names,
    ),
]
WorkersOpt = Annotated[
    int,
    typer.Option(
        "--workers", "-w", min=1, max=MAX_WORKERS, help=f"Processes evaluating in parallel (1-{MAX_WORKERS})."
    ),
]
#: what each optimiser is, said once for every command's --optimizer (from the optimisers' table)
OPTIMIZER_HELP = optimizer_help()
OptimizerOpt = Annotated[str, typer.Option("--optimizer", help=OPTIMIZER_HELP)]
MaxEvalsOpt = Annotated[
    int | None,
    typer.Option(
        "--max-evaluations",
        min=1,
        help="Stop once this many evaluations were used (checked after each batch; DE finishes its generation).",
    ),
]
EvalTimeoutOpt = Annotated[
    float,
    typer.Option(
        help="With --workers 2+: an evaluation still running after this "
        "many seconds (while simtune runs: a paused or sleeping machine does not count) is abandoned, stored as "
        "failed, its worker replaced; `simtune resume` retries it once.  (MuJoCo's workers run a chunk of a batch at "
        "once: a chunk past it goes out again one evaluation at a time.)",
        callback=seconds,
    ),
]
