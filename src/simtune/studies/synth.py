"""``simtune synth``: recordings with a known ground truth, for checking that tuning recovers it.

One engine simulates each task with chosen "true" parameter values; each
repeat gets motion-capture-like noise and a little start-time jitter
(:func:`simtune.reference.make.synthesize`) and is written to
``OUT/<task>/<task>NNNN<ending>`` by one of :data:`simtune.data.formats.WRITERS`: by default as a
Qualisys 6D TSV with header, the format real recordings come in, so tuning
reads them through the same loader; or as joint logs (the arm's joint angles
with encoder-like noise), beside the markers in simtune CSV or instead of
them in a CSV, an MCAP file or a rosbag2 folder; or each task's repeats as the
episodes of one LeRobot dataset ``OUT/<task>/`` (joint angles and the commanded
targets, at 30 frames per second).  ``OUT/truth-<task>.json`` holds each task's
truth and settings and each repeat's start (its jitter), and ``OUT/truth.json`` the truth of every task synthesised
into ``OUT`` with the same truth and settings; each is also a parameter file
(``simtune evaluate --params-file OUT/truth.json``).  Synthesising into a folder
that holds another truth is refused unless ``force``: no truth is overwritten
without it, and none is lost with it (each task keeps its own file).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

import simtune
from simtune.common.limits import MAX_SYNTH_REPEATS
from simtune.data.fingerprint import task_files
from simtune.data.formats import WRITERS, writer
from simtune.engines import engine_class, make_engine
from simtune.engines.contact import floor_touches
from simtune.errors import ConfigError, SimtuneError
from simtune.fitness import rollout_joint_names
from simtune.params import read_params_file, validate_params
from simtune.project import Project, get_project
from simtune.reference.make import RATE, synthesize
from simtune.robot.description import RobotDescription
from simtune.tasks import TaskSpec, parse_tasks
from simtune.tasks.episodes import check_stream, command_stream, episode_task_name

TRUTH_FILE = "truth.json"
#: the most marker noise [m] and encoder noise [deg] synth writes: beyond them the recordings' own checks (a
#: coordinate beyond 10 m, the units and degrees checks) would refuse what it wrote
MAX_NOISE_M = 0.1
MAX_JOINT_NOISE_DEG = 2.0
DEFAULT_DELAY_S = 1.5  # the real qrg2019 recordings start 1.2-2.3 s before the arm moves
#: encoder noise of synthetic joint logs [deg]: an arm's encoders read to about a tenth of a degree
DEFAULT_JOINT_NOISE_DEG = 0.05
#: how synth's one-line errors name its settings: the command line's options (the Python API passes its own
#: argument names, :data:`API_NAMES`, so that each caller reads the name it typed)
OPTION_NAMES = {
    "noise_m": "--noise-mm",
    "jitter_s": "--jitter-s",
    "joint_noise_rad": "--joint-noise-deg",
    "repeats": "--repeats",
    "delay_s": "--delay-s",
    "episodes": "--episodes",
}
API_NAMES = {key: key for key in OPTION_NAMES}


@dataclass
class SynthResult:
    out: Path
    truth: dict[str, float]
    files: dict[str, list[Path]]  # task -> written recordings
    joint_noise_rad: float = 0.0  # of the joint logs written


def load_truth(
    path: Path | None,
    engine: str,
    delay_s: float | None,
    robot: RobotDescription | None = None,
    delay_name: str = OPTION_NAMES["delay_s"],
) -> dict[str, float]:
    """The true parameter values: the file's (validated for ``engine`` and ``robot``, default the MICO),
    with ``delay_s`` as command delay (named ``delay_name`` where out of range).

    No file: the engine's generic values and a command delay (``delay_s`` or
    :data:`DEFAULT_DELAY_S`).
    """
    supported = engine_class(engine).supported(robot)
    truth: dict[str, float] = {}
    if path is not None:
        values = read_params_file(path, engine, robot)
        truth = validate_params(values, supported, engine, where=str(path), robot=robot)
    if delay_s is not None:
        truth["command_delay"] = delay_s
    elif path is None:
        truth["command_delay"] = DEFAULT_DELAY_S
    return validate_params(truth, supported, engine, where=delay_name, robot=robot)


def run_synth(
    engine: str,
    tasks: str,
    out: Path,
    *,
    truth_file: Path | None,
    delay_s: float | None,
    project: Project | Path | None = None,
    names: Mapping[str, str] = OPTION_NAMES,
    **settings,
) -> SynthResult:
    """``simtune synth`` and :func:`simtune.api.synth`: the truth of ``truth_file`` and ``delay_s``
    (:func:`load_truth`), checked against the ranges of ``project``'s robot, recorded by :func:`make_synthetic`
    with ``settings``; errors of range name the settings as ``names`` does (the command line's options or the API's
    arguments)."""
    robot = get_project(project).robot.description
    truth = load_truth(truth_file, engine, delay_s, robot, delay_name=names["delay_s"])
    return make_synthetic(engine, tasks, out, truth=truth, project=project, names=names, **settings)


def make_synthetic(
    engine: str,
    tasks: str,
    out: Path,
    *,
    truth: dict[str, float],
    noise_m: float = 0.002,
    repeats: int = 10,
    seed: int = 0,
    jitter_s: float = 0.05,
    fmt: str = "tsv",
    joint_noise_rad: float = math.radians(DEFAULT_JOINT_NOISE_DEG),
    project: Project | Path | str | None = None,
    force: bool = False,
    names: Mapping[str, str] = OPTION_NAMES,
    episodes: int | None = None,
) -> SynthResult:
    """Write ``repeats`` synthetic recordings of each task in ``tasks`` (names, groups, comma-separated) of
    ``project`` (default: the bundled MICO project), and each task's truth (:func:`truth_file`).

    ``fmt`` is a key of :data:`simtune.data.formats.WRITERS`; joint angles get Gaussian noise of
    ``joint_noise_rad`` per sample.  ``OUT/truth.json`` holding another truth is refused unless ``force``.
    A setting out of range is a ConfigError naming it as ``names`` does (default: the command line's options).
    With ``episodes`` (a dataset format) each task's dataset holds that many different episodes instead of
    repeats: each its own seeded command stream (:func:`episode_tasks`), one recording each, all on one clock (the
    truth's command delay, no start jitter).
    """
    specs = parse_tasks(tasks, project)
    write = writer(fmt)  # a known --format, checked first
    _check_settings(joint_noise_rad, repeats, noise_m, jitter_s, names)
    if episodes is not None:
        _check_episodes(episodes, fmt, write.episodes is not None, names)
        jitter_s = 0.0  # the episodes of one log share its clock: one delay, the robot's
    for spec in specs:
        _check_delay(spec.name, spec.duration, truth.get("command_delay", 0.0), jitter_s, names)
    out = Path(out)
    meta = {
        "engine": engine,
        "tasks": [s.name for s in specs],
        "noise_m": noise_m,
        "jitter_s": jitter_s,
        "format": fmt,
        "joint_noise_rad": joint_noise_rad if write.joints else None,
        "repeats": repeats,
        **({} if episodes is None else {"episodes": episodes}),
        "seed": seed,
        "simtune": simtune.__version__,
        "parameters": list(truth),
        "params": truth,
    }
    for spec in specs:
        folder = out / spec.name
        if write.check is not None:
            write.check(spec)  # before any simulation: e.g. a dataset's unit must be the one its task reads
        if folder.is_dir() and task_files(folder):
            raise SimtuneError(
                f"{folder} already holds recordings: choose another --out (new files would be averaged with them)"
            )
    _check_truths(out, meta, force)  # before any simulation: no truth is overwritten without force
    files: dict[str, list[Path]] = {}
    starts: dict[str, list[dict]] = {}  # task -> each repeat's start (its jitter), for its truth file
    for spec in specs:
        folder = out / spec.name
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise SimtuneError(f"--out {out}: cannot create {folder} ({exc.strerror})") from None
        delays: list[float] = []
        if episodes is not None:
            ran = episode_tasks(engine, spec, truth, episodes, hash_seed(seed, spec.name), write.rate or RATE)
            recordings = [
                synthesize(
                    engine,
                    ep,
                    truth,
                    repeats=1,
                    noise_m=noise_m,
                    jitter_s=0.0,
                    seed=hash_seed(seed, ep.name),
                    suffix=write.ending,
                    rate=write.rate or RATE,
                    joint_names=rollout_joint_names(ep),
                    joint_noise_rad=joint_noise_rad,
                    delays=delays,
                )[0]
                for ep in ran
            ]
            assert write.episodes is not None, "checked by _check_episodes"
            files[spec.name] = write.episodes(folder, recordings, ran)
            episode_names = [f"episode_{k:06d}" for k in range(len(recordings))]
            starts[spec.name] = repeat_starts(episode_names, delays, truth.get("command_delay", 0.0))
            continue
        # each task its own noise stream, so adding a task leaves the others' recordings unchanged
        recordings = synthesize(
            engine,
            spec,
            truth,
            repeats=repeats,
            noise_m=noise_m,
            jitter_s=jitter_s,
            seed=hash_seed(seed, spec.name),
            suffix=write.ending,
            rate=write.rate or RATE,
            joint_names=rollout_joint_names(spec) if write.joints else None,
            joint_noise_rad=joint_noise_rad,
            delays=delays,
        )
        files[spec.name] = write.write(folder, recordings, spec)
        repeat_names = [f"episode_{k:06d}" if write.dataset else rec.source.name for k, rec in enumerate(recordings)]
        starts[spec.name] = repeat_starts(repeat_names, delays, truth.get("command_delay", 0.0))
    _write_truths(out, meta, force, starts)
    return SynthResult(out, truth, files, joint_noise_rad)


def _check_episodes(episodes: int, fmt: str, writes_episodes: bool, names: Mapping[str, str]) -> None:
    """One line for an episode count out of range, or a format that cannot hold different episodes."""
    option = names.get("episodes", "--episodes")
    if not writes_episodes:
        known = ", ".join(w.name for w in WRITERS.values() if w.episodes is not None)
        raise ConfigError(f"{option}: format {fmt!r} holds repeats, not different episodes: choose one of {known}")
    if not 1 <= episodes <= MAX_SYNTH_REPEATS:
        raise ConfigError(f"{option} must be from 1 to {MAX_SYNTH_REPEATS}, got {episodes}")


#: how many command streams an episode draws before giving up on one clear of the floor
FLOOR_DRAWS = 20


def episode_tasks(
    engine: str, task: TaskSpec, truth: Mapping[str, float], count: int, seed: int, fps: float
) -> list[TaskSpec]:
    """``count`` different episodes of ``task``: each ``task`` with its own drawn command stream
    (:func:`simtune.tasks.episodes.command_stream`, seeded by ``seed`` and the episode), named
    :func:`~simtune.tasks.episodes.episode_task_name`.

    Args:
        engine: the engine whose simulation with ``truth`` must keep the arm clear of the floor (a stream that
            touches it is drawn again; an engine that cannot tell, or a task with an object, is not asked).
        task: the task whose robot, joints, start pose, duration and controller the episodes keep.
        truth: the true parameter values.
        count: how many episodes.
        seed: the stream's seed (same seed, same episodes).
        fps: the frame rate of the dataset the commands are written at.

    Returns:
        The episodes' tasks, in order.

    Raises:
        SimtuneError: no stream of :data:`FLOOR_DRAWS` keeps an episode clear of the floor.
    """
    rng = np.random.default_rng(seed)
    ran = []
    for k in range(count):
        for _ in range(FLOOR_DRAWS):
            ep = replace(task, name=episode_task_name(task.name, k), phases=command_stream(task, rng, fps))
            check_stream(ep, ep.phases)
            if task.object is not None:
                break
            sim = make_engine(engine, ep)
            try:
                touches = floor_touches(sim, dict(truth))
            except NotImplementedError:
                touches = []
            finally:
                sim.close()
            if not touches:
                break
        else:
            raise SimtuneError(
                f"task {task.name}: episode {k}: none of {FLOOR_DRAWS} drawn command streams keeps the arm clear of "
                "the floor: start the task from a pose further from it"
            )
        ran.append(ep)
    return ran


def _check_settings(
    joint_noise_rad: float, repeats: int, noise_m: float, jitter_s: float, names: Mapping[str, str]
) -> None:
    """One line naming the setting (as ``names`` calls it) for a noise, jitter or repeat count no recording can
    hold, or a repeat count that would simulate for hours."""
    if not joint_noise_rad >= 0:
        raise ConfigError(f"{names['joint_noise_rad']} must be zero or more, got {joint_noise_rad:g} rad")
    if not 1 <= repeats <= MAX_SYNTH_REPEATS:
        raise ConfigError(f"{names['repeats']} must be from 1 to {MAX_SYNTH_REPEATS}, got {repeats}")
    if not noise_m >= 0:
        raise ConfigError(f"{names['noise_m']} must be zero or more, got {noise_m * 1000:g} mm")
    if not jitter_s >= 0:
        raise ConfigError(f"{names['jitter_s']} must be zero or more, got {jitter_s:g} s")
    _check_noise(noise_m, joint_noise_rad, names)


def truth_file(task: str) -> str:
    """The name of ``task``'s truth file in a synthetic data root: ``truth-<task>.json``."""
    return f"truth-{task}.json"


def _check_noise(noise_m: float, joint_noise_rad: float, names: Mapping[str, str]) -> None:
    """Noise the recordings' own checks would refuse (markers beyond 10 m, angles beyond two turns) is refused
    before anything is simulated."""
    if noise_m > MAX_NOISE_M:
        raise ConfigError(
            f"{names['noise_m']}: {noise_m * 1000:g} mm of marker noise would put the markers where the recordings' "
            f"checks refuse them (and no motion capture is that far off): at most {MAX_NOISE_M * 1000:g} mm"
        )
    if math.degrees(joint_noise_rad) > MAX_JOINT_NOISE_DEG:
        raise ConfigError(
            f"{names['joint_noise_rad']}: {math.degrees(joint_noise_rad):g} deg of encoder noise would make joint logs "
            f"the recordings' checks refuse (no encoder is that far off): at most {MAX_JOINT_NOISE_DEG:g} deg"
        )


def _check_delay(task: str, duration: float, delay: float, jitter_s: float, names: Mapping[str, str]) -> None:
    """Every repeat's command delay (the truth's, moved by up to the jitter) must start the motion within the task."""
    if delay >= duration:
        raise ConfigError(
            f"{names['delay_s']}: a command delay of {delay:g} s starts the motion after the task's end ({task} lasts "
            f"{duration:g} s): the recordings would hold no motion"
        )
    if delay + jitter_s >= duration:
        raise ConfigError(
            f"{names['jitter_s']}: {jitter_s:g} s of jitter on the command delay of {delay:g} s starts some repeats' "
            f"motion after the task's end ({task} lasts {duration:g} s): at most {duration - delay:.3g} s"
        )


def _same_truth(a: dict, b: dict) -> bool:
    """Whether two truth files hold the same truth and settings (whatever their tasks)."""
    settled = ("tasks", "simtune")
    return {k: v for k, v in a.items() if k not in settled} == {k: v for k, v in b.items() if k not in settled}


def _read_truth(path: Path) -> dict | None:
    """A truth file's content; None when it is not one (unreadable, not an object with ``params``)."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and isinstance(data.get("params"), dict) else None


def _check_truths(out: Path, meta: dict, force: bool) -> dict | None:
    """Refuse (unless ``force``) to overwrite a truth: a task's own truth file, or an ``OUT/truth.json`` holding
    another truth or not simtune's.  Returns what truth.json holds now (None: nothing to keep)."""
    for task in meta["tasks"]:
        path = out / truth_file(task)
        if path.exists() and not force:
            what = (
                f"holds the truth of an earlier synth of {task}"
                if _read_truth(path) is not None
                else "is not a truth file simtune synth wrote (no JSON object with params): it is left as it is"
            )
            raise SimtuneError(f"{path} {what}: choose another --out, or --force to replace it")
    path = out / TRUTH_FILE
    if not path.exists():
        return None
    earlier = _read_truth(path)
    if earlier is not None and _same_truth(earlier, meta):
        return earlier
    if not force:
        tasks = ", ".join(map(str, (earlier or {}).get("tasks") or [])) or "other tasks"
        what = "is not a truth file of simtune synth" if earlier is None else f"holds another truth (of {tasks})"
        raise SimtuneError(
            f"{path} {what}: choose another --out, or --force to replace it (each task's truth stays in its own "
            f"{truth_file('<task>')})"
        )
    return earlier


def repeat_starts(names: list[str], delays: list[float], delay: float) -> list[dict]:
    """Each repeat's start as its task's truth file records it.

    Args:
        names: the repeats' recordings (file names, or a dataset's ``episode_NNNNNN``), in repeat order.
        delays: the command delay [s] each repeat was simulated with, in the same order.
        delay: the truth's command delay [s].

    Returns:
        Per repeat ``{"repeat": name, "start_jitter_s": its delay - the truth's, "command_delay": its delay}``: the
        jitter as simulated (a delay jittered below 0 starts at 0).
    """
    return [
        {"repeat": name, "start_jitter_s": round(d - delay, 9), "command_delay": round(d, 9)}
        for name, d in zip(names, delays)
    ]


def _write_truths(out: Path, meta: dict, force: bool, starts: dict[str, list[dict]] | None = None) -> None:
    """Each task's truth file (with ``starts``' repeats of the task, :func:`repeat_starts`), and ``truth.json``:
    the truth of every task synthesised into ``out`` with it."""
    earlier = _check_truths(out, meta, force)
    if earlier is not None and not _same_truth(earlier, meta):
        # replaced (force): an earlier truth.json's tasks without their own file get one first, so none is lost
        for task in earlier.get("tasks") or []:
            own = out / truth_file(str(task))
            if isinstance(task, str) and not own.exists():
                own.write_text(json.dumps({**earlier, "tasks": [task]}, indent=2) + "\n")
        earlier = None
    for task in meta["tasks"]:
        content = {**meta, "tasks": [task], "repeat_starts": (starts or {}).get(task, [])}
        (out / truth_file(task)).write_text(json.dumps(content, indent=2) + "\n")
    tasks = [t for t in (earlier or {}).get("tasks", []) if t not in meta["tasks"]] + meta["tasks"]
    (out / TRUTH_FILE).write_text(json.dumps({**meta, "tasks": tasks}, indent=2) + "\n")


def hash_seed(seed: int, name: str) -> int:
    """A seed for one task's noise: stable across runs and Python versions (no salted ``hash``)."""
    return (int(seed) * 1_000_003 + sum((i + 1) * ord(c) for i, c in enumerate(name))) % (2**32)
