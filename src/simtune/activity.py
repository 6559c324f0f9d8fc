"""Which parameters can change a task's rollout: measured, with the reason for each that cannot.

A parameter that moves no sample of any rollout cannot be tuned, only wandered over: it
enlarges the search (differential evolution's population grows with D), gets ranked by the
spread of its tuned values, and widens domain-randomisation ranges to its bounds.

The probe (:func:`measure_activity`): from the generic point and :data:`PROBE_POINTS`
random points of the space (uniform within the middle half of each range, seeded, so the
probe is repeatable), each parameter goes to its lower and then its upper bound, all other
values held; the rollout's *visible track* (the marker, a point 10 cm out along each hand
axis so that turning the hand shows, and the object) is compared with the base rollout's.
A parameter is active as soon as one comparison moves a sample by more than
:data:`TOLERANCE` [m]: far above what rounding in any engine produces (their rollouts of
one parameter set are bit-identical), far below what the fitness can resolve.  Base points
that blow up are skipped; a perturbation that makes a stable base blow up counts as a change.

An inactive parameter's reason is the engine's own (``Engine.inactive_parameters``: "task
'cube' has no wood object", "the velocity servo's force ... never reaches 100 N m") where
it declared one; otherwise the measurement itself.  A parameter the engine declares
inactive but that the probe sees moving stays active (the measurement decides).

Results are cached per engine x task x space in a small JSON file (:func:`simtune.common.cache.cache_root`), keyed by
what the outcome depends on (:func:`cache_key`): simtune's and the engine's versions, the task as the
engine runs it with its robot by content (mesh and MJCF files by their bytes, never by their paths),
the space's names and bounds, and the probe's settings.  So a second checkout of a project, in
another folder, reads the first one's results instead of probing again.  The bundled project's probes ship
with simtune (:data:`SHIPPED_PROBES`): a fresh machine's first run of a bundled task reads them.  A shipped entry is
keyed like the cache but without the engine's version (:func:`shipped_name`), and carries the version it was
measured on and a *witness*: the probe's first base rollouts, sampled (:func:`witness_tracks`).  On that version it
is read as it is; on another one (a patch release of the engine) it answers only where today's engine rolls the
witness out within :data:`WITNESS_TOLERANCE` of the stored one - a few rollouts instead of hundreds - and is measured
again, saying why, where it does not.  (Measured for MuJoCo 4.0.0 and 4.0.1: bit-identical rollouts,
``benchmarks/engine_versions.py``.)  A probe that is neither cached nor shipped says so in one line on stderr where
someone watches (:func:`announcing`): the first run of an own robot on a fresh machine spends its first seconds on it.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import signal
import sys
import tempfile
import time
import warnings
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import numpy as np

import simtune
from simtune.common.cache import cache_root
from simtune.common.spawn_guard import (
    adopt_environment,
    check_main_guarded,
    leave_robot_notes_to_parent,
    worker_context,
)
from simtune.engines import engine_class, make_engine
from simtune.engines.base import Rollout
from simtune.engines.controller import CONTROL_PERIOD
from simtune.errors import EngineVersionWarning, RecordingWarning
from simtune.fitness import marker_positions
from simtune.params import ParameterSpace
from simtune.params.space import is_supported
from simtune.robot.description import Mesh, RobotDescription
from simtune.tasks import TaskSpec
from simtune.tasks.spec import FINGERPRINT

#: A parameter that moves no sample of the visible track by more than this [m] is inactive.
TOLERANCE = 1e-6
#: Random base points besides the generic one.
PROBE_POINTS = 3
#: Changes whenever the probe's method changes, so that no cached result of an older method is read.
PROBE_VERSION = 2
#: Seed of the random base points.
PROBE_SEED = 0
#: How far out along each hand axis the probe watches a point [m] (turns of the hand about the wrist).
HAND_ARM_M = 0.1
#: A shipped probe's witness: the rollouts of the probe's first base points (the generic one and the first random
#: one), every :data:`WITNESS_STRIDE`-th sample of their visible tracks.
WITNESS_POINTS = 2
WITNESS_STRIDE = 20
#: A shipped probe measured on another engine version answers for today's where its witness rolls out within this
#: [m]: a hundredth of :data:`TOLERANCE`, so that no parameter's verdict can hinge on the difference.
WITNESS_TOLERANCE = TOLERANCE / 100


def measured_reason(change: float, points: int = PROBE_POINTS) -> str:
    """Why a parameter neither the engine nor the schedule explains is inactive: the measurement itself."""
    return (
        f"moves no sample by more than {TOLERANCE:g} m (at most {change:.1e} m) from the generic point "
        f"or {points} random points (measured)"
    )


def schedule_reasons(task: TaskSpec) -> dict[str, str]:
    """Controller parameters the task's schedule leaves idle: the velocity clamp of a joint it never moves."""
    _, table = task.schedule
    return {
        f"max_velocity_joint_{i}": f"task {task.name!r} never commands joint {i} away from its start angle"
        for i in range(1, table.shape[1] + 1)
        if np.all(table[:, i - 1] == table[0, i - 1])
    }


@dataclass(frozen=True)
class Activity:
    """Whether one parameter changes a task's rollout, the largest change seen [m], and why not."""

    name: str
    active: bool
    change: float
    reason: str = ""


def visible_track(rollout: Rollout, params: dict[str, float]) -> np.ndarray:
    """What a rollout shows, sample by sample: marker, three points on the hand's axes, object [m]."""
    n = len(rollout.times)
    parts = [marker_positions(rollout, params), rollout.wrist_rot.reshape(n, 9) * HAND_ARM_M]
    if rollout.object_pos is not None:
        parts.append(rollout.object_pos)
    return np.hstack(parts)


def task_samples(task: TaskSpec) -> int:
    """Samples of a rollout that spans the task (its duration at the control rate, both ends included)."""
    return int(round(task.duration / CONTROL_PERIOD)) + 1


def base_points(space: ParameterSpace, points: int = PROBE_POINTS, seed: int = PROBE_SEED) -> list[dict[str, float]]:
    """The generic point (empty: every parameter generic) and ``points`` seeded random points of ``space``."""
    rng = np.random.default_rng(seed)
    low = np.array([p.low for p in space.parameters])
    high = np.array([p.high for p in space.parameters])
    bases: list[dict[str, float]] = [{}]
    for _ in range(points):
        bases.append(space.to_dict(low + (high - low) * rng.uniform(0.25, 0.75, len(low))))
    return bases


def measure_activity(
    engine: str,
    task: TaskSpec,
    space: ParameterSpace,
    points: int = PROBE_POINTS,
    samples: int | None = None,
    workers: int = 1,
    on_rollouts: Callable[[int], None] | None = None,
) -> dict[str, Activity]:
    """Probe every parameter of ``space`` on ``task`` (see the module's notes): name -> Activity.

    With ``workers`` > 1 the rollouts of each round (every parameter still inactive at its lower bound,
    then those unmoved at their upper bound) run on that many worker processes: the same rollouts as one
    after the other, so the same outcome, in about 1 / ``workers`` of the time (minutes for a slow engine).
    ``on_rollouts(n)`` is told after each round how many rollouts it ran (a progress bar).
    """
    cls = engine_class(engine)
    declared = schedule_reasons(task) | cls.inactive_parameters(task)
    supported = cls.supported(task.robot)
    n = samples or task_samples(task)
    found: dict[str, Activity] = {}
    largest = dict.fromkeys(space.names, 0.0)
    with _Probe(engine, task, n, workers) as probe:
        pending = [p for p in space.parameters if is_supported(p.name, supported)]
        for p in space.parameters:
            if not is_supported(p.name, supported):
                found[p.name] = Activity(p.name, False, 0.0, f"engine {engine!r} has no such parameter")
        for base in base_points(space, points):
            if not pending:
                break
            (seen,) = probe.tracks([base])
            if on_rollouts is not None:
                on_rollouts(1)
            if seen is None:
                continue
            for bound in ("low", "high"):  # the upper bound only for what the lower one left unmoved
                unmoved = [p for p in pending if largest[p.name] <= TOLERANCE]
                moved = [{**base, p.name: getattr(p, bound)} for p in unmoved]
                tracks = probe.tracks(moved)
                if on_rollouts is not None:
                    on_rollouts(len(moved))
                for p, track in zip(unmoved, tracks):
                    change = float(np.abs(track - seen).max()) if track is not None else np.inf
                    largest[p.name] = max(largest[p.name], change)
            for p in pending:
                if largest[p.name] > TOLERANCE:
                    found[p.name] = Activity(p.name, True, largest[p.name])
            pending = [p for p in pending if largest[p.name] <= TOLERANCE]
        for p in pending:
            found[p.name] = Activity(
                p.name, False, largest[p.name], declared.get(p.name) or measured_reason(largest[p.name], points)
            )
    return {name: found[name] for name in space.names}


class _Probe:
    """The probe's rollouts: each parameter dict's visible track (None where the rollout blew up), here or on
    ``workers`` processes (:func:`~simtune.common.spawn_guard.worker_context`: none shares an engine with this one).

    Here, each round goes to the engine as one batch (:meth:`~simtune.engines.Engine.rollout_batch`): MuJoCo runs
    it in lockstep control periods with the controller and the checks as NumPy over the batch, bit for bit the
    rollouts one at a time, in less time (the cube's probe, 2026-11-27: see docs/performance.md); an engine
    without a batch path runs them one after the other as before.
    """

    def __init__(self, engine: str, task: TaskSpec, samples: int, workers: int):
        self.engine, self.task, self.samples, self.workers = engine, task, samples, workers
        self.pool: ProcessPoolExecutor | None = None

    def __enter__(self) -> _Probe:
        if self.workers > 1:
            check_main_guarded(f"the activity probe's {self.workers} workers")
            self.pool = ProcessPoolExecutor(
                self.workers,
                mp_context=worker_context(),
                initializer=_start_worker,
                initargs=(self.engine, self.task, self.samples, dict(os.environ)),
            )
        else:
            _build_engine(self.engine, self.task, self.samples)
        return self

    def __exit__(self, *exc) -> None:
        if self.pool is not None:
            self.pool.shutdown(cancel_futures=True)
        else:
            _close_engine()

    def tracks(self, params: list[dict[str, float]]) -> list[np.ndarray | None]:
        if self.pool is None:
            return _tracks(params)
        return list(self.pool.map(_track, params))


#: this process's probe engine and rollout length (a worker's, or the caller's own while it probes)
_SIM: list = []


def _start_worker(engine: str, task: TaskSpec, samples: int, environ: dict[str, str]) -> None:
    adopt_environment(environ)
    leave_robot_notes_to_parent()
    # Ctrl-C is the coordinating process's to handle (the run stops, saying how to resume); a worker would
    # only print a traceback
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _build_engine(engine, task, samples)


def _build_engine(engine: str, task: TaskSpec, samples: int) -> None:
    _SIM[:] = [make_engine(engine, task), samples]


def _close_engine() -> None:
    if _SIM:
        _SIM[0].close()
        _SIM.clear()


def _track(params: dict[str, float]) -> np.ndarray | None:
    sim, samples = _SIM
    rollout = sim.rollout(params, samples)
    return visible_track(rollout, params) if rollout.stable else None


def _tracks(params: list[dict[str, float]]) -> list[np.ndarray | None]:
    """:func:`_track` of each parameter dict, as one batch of this process's engine; a member whose rollout raised
    raises here, as it would alone."""
    sim, samples = _SIM
    found: list[np.ndarray | None] = [None] * len(params)
    for i, rollout in sim.rollout_batch(params, samples):
        if isinstance(rollout, Exception):
            raise rollout
        found[i] = visible_track(rollout, params[i]) if rollout.stable else None
    return found


def cache_key(engine: str, task: TaskSpec, space: ParameterSpace, points: int, engine_version: bool = True) -> str:
    """What a probe's outcome depends on, hashed: simtune's and the engine's versions, the task and its robot by
    content (:func:`task_content`), the space's names and bounds, the probe's settings.

    No path enters it: the same project in two folders (two clones, a copy) has the same key.

    Args:
        engine: the engine's registry name.
        task: the task probed.
        space: the parameters probed.
        points: random base points besides the generic one.
        engine_version: whether the installed engine's version enters it (False: a shipped probe's key, whose
            entry names its version and carries its witness instead).

    Returns:
        20 hex digits.
    """
    what = {
        "simtune": simtune.__version__,
        "engine": f"{engine} {engine_class(engine).version()}" if engine_version else engine,
        "task": task_content(task, engine),
        "space": [space.name, space.names, space.bounds],
        "probe": [PROBE_VERSION, TOLERANCE, points, PROBE_SEED],
    }
    return hashlib.sha256(json.dumps(what, sort_keys=True, default=str).encode()).hexdigest()[:20]


def task_content(task: TaskSpec, engine: str) -> dict:
    """The task as the engine runs it, as plain values: its fields without the catalogue entries that change no
    simulation (description, recordings folder ...: ``tasks.spec.FINGERPRINT`` "never") and without the run
    settings it carries ("run": its loading) where ``engine`` does not read them and without the fields added since
    the shipped probes were measured while they hold their default ("added": so those probes still answer), its
    robot by content (:func:`robot_content`).

    Args:
        task: any task.
        engine: the engine's registry name (its content differs by the loading where it reads it: PyBullet).

    Returns:
        A JSON-serialisable dict (tuples as lists) that holds no file path.
    """
    content = asdict(task)
    reads_loading = engine_class(engine).reads_loading
    for f in fields(task):
        kind = f.metadata.get(FINGERPRINT)
        at_default = getattr(task, f.name) == f.default
        if kind == "never" or (kind == "run" and not reads_loading) or (kind == "added" and at_default):
            content.pop(f.name)
    content["robot"] = robot_content(task.robot)
    return content


def robot_content(robot: RobotDescription) -> dict:
    """The robot as the engines build it: every value of its description, each mesh file by the hash of its bytes
    and an MJCF by :func:`mjcf_content`, without where it was read from (``source``) or what is not part of its
    identity (fields left out of comparisons: the loader's notes).

    Args:
        robot: any robot description.

    Returns:
        A JSON-serialisable dict that holds no file path.
    """
    content = asdict(robot)
    for f in fields(robot):
        if not f.compare:
            content.pop(f.name)
    content.pop("source")  # a path (or "bundled"): what was read from it is in the other values
    # fields added later: a robot without them keeps its key
    for added in ("estimated_masses", "placeholder_masses", "max_velocity_range"):
        if not content.get(added):
            content.pop(added, None)
    for joint in content["joints"]:  # likewise a joint's armature (an MJCF file's): 0 keeps the joint's key
        if not joint.get("armature"):
            joint.pop("armature", None)
    if robot.mjcf is not None:
        content["mjcf"] = mjcf_content(robot.mjcf)
    for link, stored in zip(robot.links, content["links"]):
        for shape, values in zip(link.shapes, stored["shapes"]):
            values["kind"] = type(shape).__name__  # asdict drops the class: a sphere and a box differ by keys only
            if isinstance(shape, Mesh):
                values["path"] = file_digest(shape.path)
    return content


def file_digest(path: str | Path) -> str:
    """SHA-256 of a file's bytes (read once per process while its modification time and size stay).

    Args:
        path: the file.

    Returns:
        64 hex digits; ``"missing <name>"`` for a file that cannot be read (the engine will say so when it builds
        the robot; the key stays free of the folder).
    """
    try:
        stat = os.stat(path)
        return _file_digest(str(path), stat.st_mtime_ns, stat.st_size)
    except OSError:
        return f"missing {Path(path).name}"


@functools.lru_cache(maxsize=1024)
def _file_digest(path: str, mtime_ns: int, size: int) -> str:
    with open(path, "rb") as fh:
        return hashlib.file_digest(fh, "sha256").hexdigest()


def mjcf_content(path: str | Path) -> dict:
    """An MJCF robot as MuJoCo reads it: the model's XML as MuJoCo writes it back (includes inlined, file names as
    the file gives them) and the bytes of every asset file it reads (meshes, textures, height fields).

    Compiled at most once per process while the file's modification time and size stay (an edited include is seen
    by the next process).

    Args:
        path: the MJCF file (``RobotDescription.mjcf``).

    Returns:
        ``{"xml": digest, "assets": [digest, ...]}``; where MuJoCo cannot say that much (a version without
        ``MjSpec.to_xml`` or ``MjModel.paths``), ``{"file": digest}`` of the file alone.
    """
    try:
        stat = os.stat(path)
    except OSError:
        return {"file": file_digest(path)}
    xml, assets = _mjcf_read(str(path), stat.st_mtime_ns, stat.st_size)
    if xml is None:
        return {"file": file_digest(path)}
    # the assets' paths are absolute (MuJoCo resolves them against the file's folder): only their bytes count
    return {"xml": xml, "assets": [file_digest(asset) for asset in assets]}


@functools.lru_cache(maxsize=64)
def _mjcf_read(path: str, mtime_ns: int, size: int) -> tuple[str | None, tuple[str, ...]]:
    """The digest of the MJCF's XML as MuJoCo writes it back, and the asset files it reads (None, () if it
    cannot say)."""
    try:
        import mujoco

        spec = mujoco.MjSpec.from_file(path)
        model = spec.compile()
        xml = spec.to_xml()
        paths = bytes(model.paths)
    except Exception:  # an old MuJoCo, or a file it refuses now: the engine says why when it builds the robot
        return None, ()
    assets = tuple(os.fsdecode(p) for p in paths.split(b"\0") if p)
    return hashlib.sha256(xml.encode()).hexdigest(), assets


#: whether a probe not cached says so on stderr: None (unset) where stderr is a terminal
_ANNOUNCE: ContextVar[bool | None] = ContextVar("simtune_activity_announce", default=None)


@contextmanager
def announcing(enabled: bool) -> Iterator[None]:
    """Within it, a probe that is not cached says so on stderr (``enabled``) or not, whatever stderr is.

    Outside any, it says so only where stderr is a terminal: someone watches a first run's start there, while
    a pipe or a log (scripts, tests that read stderr line by line) gets nothing.  A command's ``--quiet`` or
    ``--json`` belongs inside ``announcing(False)``.

    Args:
        enabled: whether to say so.

    Yields:
        Nothing: the setting holds until the block ends.
    """
    token = _ANNOUNCE.set(enabled)
    try:
        yield
    finally:
        _ANNOUNCE.reset(token)


def announce(line: str) -> None:
    """Say on stderr what a long step before the search does (a terminal's, or within ``announcing(True)``), so that
    the first seconds of a command are never silent.

    Args:
        line: what the step does, e.g. ``reading the recordings of cube ...``.
    """
    if _announces():
        print(line, file=sys.stderr, flush=True)


def _announces() -> bool:
    enabled = _ANNOUNCE.get()
    if enabled is not None:
        return enabled
    try:
        return sys.stderr is not None and sys.stderr.isatty()
    except (AttributeError, ValueError):  # replaced by an object without isatty, or closed
        return False


def probe_size(engine: str, task: TaskSpec, space: ParameterSpace, points: int) -> tuple[int, int]:
    """How many parameters a probe measures (those the engine has) and at most how many rollouts it runs: each base
    point its own rollout, then each parameter at its lower and (if unmoved) its upper bound - what the first line of
    a fresh machine can promise (active parameters drop out after one point).

    Args:
        engine: the engine's registry name.
        task: the task probed.
        space: the parameters probed.
        points: random base points besides the generic one.

    Returns:
        ``(parameters, rollouts)``.
    """
    supported = engine_class(engine).supported(task.robot)
    probed = sum(is_supported(name, supported) for name in space.names)
    return probed, (points + 1) * (1 + 2 * probed)


def probe_note(
    engine: str, task: TaskSpec, space: ParameterSpace, points: int, workers: int, cached: bool, why: str = ""
) -> str:
    """The line that announces a probe: what it measures, on which engine, at most how many rollouts of what length,
    and why it runs.

    Args:
        engine: the engine's registry name.
        task: the task probed.
        space: the parameters probed.
        points: random base points besides the generic one.
        workers: worker processes the rollouts run on.
        cached: whether the outcome is stored for the next run.
        why: why no stored outcome answers (:func:`shipped_activity`'s); empty: none was stored (with ``cached``:
            not measured on this machine before).

    Returns:
        One line, without its newline.
    """
    probed, rollouts = probe_size(engine, task, space, points)
    on = f" on {workers} workers" if workers > 1 else ""
    after = "; cached afterwards" if cached else ""
    if why:
        after += f"; {why}"
    elif cached:
        after += "; not measured on this machine before"
    return (
        f"measuring which of {probed} parameters change the rollouts of task {task.name!r} ({engine}: up to "
        f"{rollouts} rollouts of {task.duration:g} s{on}{after}) ..."
    )


#: probes already read or measured by this process (a run reads them several times while it starts)
_MEMORY: dict[Path, dict[str, Activity]] = {}

#: The probes of the bundled projects' tasks, measured by ``scripts/seed_probes.py`` and shipped with simtune: a
#: fresh machine's first run of a bundled task reads its outcome here instead of spending half a minute or more on
#: it (issue 44, a cold start).  Entries are named like the cache's files, but keyed without the engine's version
#: (:func:`shipped_name`), so an entry is read only for the task, robot, space and probe it was measured with; each
#: holds ``engine_version``, ``witness`` (:func:`witness_tracks`) and ``activity`` (name -> Activity's fields), and
#: answers for another engine version only where its witness replays (:func:`shipped_activity`).  A test re-measures
#: one and checks that every bundled task and space of the default engine has one that answers today.
SHIPPED_PROBES = Path(__file__).resolve().parent / "projects" / "probes.json.gz"


@functools.cache
def shipped_probes() -> dict[str, dict]:
    """The shipped probe outcomes (:data:`SHIPPED_PROBES`): cache file name -> parameter name -> Activity's fields.

    Returns:
        The entries; empty where the file is missing or unreadable (a probe then runs, as without it).
    """
    import gzip

    try:
        entries = json.loads(gzip.decompress(SHIPPED_PROBES.read_bytes()))
    except (OSError, ValueError, EOFError):
        return {}
    return entries if isinstance(entries, dict) else {}


def cache_name(
    engine: str, task: TaskSpec, space: ParameterSpace, points: int = PROBE_POINTS, engine_version: bool = True
) -> str:
    """The file name of a probe's outcome in the cache (without the engine's version: of its entry in
    :data:`SHIPPED_PROBES`, :func:`shipped_name`).

    Args:
        engine: the engine's registry name.
        task: the task probed.
        space: the parameters probed.
        points: random base points besides the generic one.
        engine_version: whether the key holds the installed engine's version (:func:`cache_key`).

    Returns:
        ``<engine>-<task>-<space>-<key>.json``, the key :func:`cache_key`'s.
    """
    return f"{engine}-{task.name}-{space.name}-{cache_key(engine, task, space, points, engine_version)}.json"


def shipped_name(engine: str, task: TaskSpec, space: ParameterSpace, points: int = PROBE_POINTS) -> str:
    """The name of a probe's entry in :data:`SHIPPED_PROBES`: :func:`cache_name` keyed without the engine's version."""
    return cache_name(engine, task, space, points, engine_version=False)


def witness_tracks(
    engine: str, task: TaskSpec, space: ParameterSpace, points: int = PROBE_POINTS
) -> list[np.ndarray | None]:
    """What a shipped probe keeps to show which engine versions it answers for: the visible tracks of the probe's
    first :data:`WITNESS_POINTS` base points, every :data:`WITNESS_STRIDE`-th sample (None for a rollout that blew up).

    Args:
        engine: the engine's registry name.
        task: the task probed.
        space: the parameters probed.
        points: random base points besides the generic one (the seeded points depend on it only through the space).

    Returns:
        One ``(samples, columns)`` array (or None) per witness point.
    """
    bases = base_points(space, points)[:WITNESS_POINTS]
    with _Probe(engine, task, task_samples(task), 1) as probe:
        tracks = probe.tracks(bases)
    return [None if track is None else track[::WITNESS_STRIDE] for track in tracks]


def shipped_entry(
    engine: str, task: TaskSpec, space: ParameterSpace, found: dict[str, Activity], points: int = PROBE_POINTS
) -> dict:
    """A probe's outcome as :data:`SHIPPED_PROBES` holds it: the installed engine's version, the witness, the outcome.

    Args:
        engine: the engine's registry name.
        task: the task probed.
        space: the parameters probed.
        found: the probe's outcome on the installed engine (:func:`measure_activity`).
        points: random base points besides the generic one.

    Returns:
        ``{"engine_version", "witness", "activity"}``, JSON-serialisable (the witness rounded to 0.1 nm).
    """
    witness = witness_tracks(engine, task, space, points)
    return {
        "engine_version": engine_class(engine).version(),
        "witness": [None if track is None else np.round(track, 10).tolist() for track in witness],
        "activity": {name: asdict(value) for name, value in found.items()},
    }


def witness_difference(entry: dict, engine: str, task: TaskSpec, space: ParameterSpace, points: int) -> float:
    """How far today's engine rolls a shipped entry's witness out from the stored one [m] (inf where one of them blew
    up and the other did not, or their shapes differ).

    Args:
        entry: a :data:`SHIPPED_PROBES` entry.
        engine: the engine's registry name.
        task: the task probed.
        space: the parameters probed.
        points: random base points besides the generic one.

    Returns:
        The largest difference of any witness sample.
    """
    stored = entry.get("witness")
    if not isinstance(stored, list) or not stored:
        return float("inf")
    largest = 0.0
    for was, now in zip(stored, witness_tracks(engine, task, space, points)):
        if (was is None) != (now is None):
            return float("inf")
        if was is None or now is None:
            continue
        was = np.asarray(was, dtype=float)
        if was.shape != now.shape:
            return float("inf")
        largest = max(largest, float(np.abs(was - now).max()))
    return largest


def shipped_activity(
    engine: str, task: TaskSpec, space: ParameterSpace, points: int = PROBE_POINTS
) -> tuple[dict[str, Activity] | None, str]:
    """The shipped probe of ``task`` x ``space``, where it answers for the installed engine: as it is on the version
    it was measured on, on another one where its witness replays within :data:`WITNESS_TOLERANCE`.

    Args:
        engine: the engine's registry name.
        task: the task probed.
        space: the parameters probed.
        points: random base points besides the generic one.

    Returns:
        ``(outcome, "")`` where it answers; ``(None, why)`` where none does (``why`` empty where none is shipped:
        an own task; else why the shipped one cannot answer).
    """
    entry = shipped_probes().get(shipped_name(engine, task, space, points))
    if not isinstance(entry, dict):
        return None, ""
    try:
        found = {name: Activity(**entry["activity"][name]) for name in space.names}
        measured_on = str(entry["engine_version"])
    except (KeyError, TypeError):
        return None, ""
    installed = engine_class(engine).version()
    if measured_on == installed:
        return found, ""
    moved = witness_difference(entry, engine, task, space, points)
    if moved <= WITNESS_TOLERANCE:
        return found, ""
    by = "blow up where they did not" if moved == float("inf") else f"move by up to {moved:.2g} m"
    return None, (
        f"the probe simtune ships for task {task.name!r} ({space.name} space) was measured on {engine} {measured_on}; "
        f"{engine} {installed}'s rollouts of it {by}, so it is measured again"
    )


def task_activity(
    engine: str,
    task: TaskSpec,
    space: ParameterSpace,
    points: int = PROBE_POINTS,
    use_cache: bool = True,
    workers: int = 1,
    measure: bool = True,
) -> dict[str, Activity] | None:
    """:func:`measure_activity` (on ``workers`` processes), from the cache when it holds this engine x task x
    space (and into it after); a probe it runs says so first (:func:`probe_note`, see :func:`announcing`).

    Args:
        engine: the engine's registry name.
        task: the task probed.
        space: the parameters probed.
        points: random base points besides the generic one.
        use_cache: read and write the cache (False: measure, and keep nothing).
        workers: worker processes for a probe that runs.
        measure: run the probe where neither the cache nor the shipped probes hold it (False: None then).

    Returns:
        Parameter name -> its :class:`Activity`, in the space's order; None where it was not held and not measured.
    """
    path = cache_root() / "activity" / cache_name(engine, task, space, points)
    if use_cache and path in _MEMORY:
        return _MEMORY[path]
    why = ""
    if use_cache:
        try:
            stored = json.loads(path.read_text())
            _MEMORY[path] = {name: Activity(**stored[name]) for name in space.names}
            return _MEMORY[path]
        except (OSError, ValueError, KeyError, TypeError):
            pass  # not cached yet, or a damaged entry: the shipped one, else measure again
        shipped, why = shipped_activity(engine, task, space, points)
        if shipped is not None:
            _write_cache(path, {name: asdict(a) for name, a in shipped.items()})  # the next run reads it at once
            _MEMORY[path] = shipped
            return shipped
    if not measure:
        return None
    if _announces():
        print(probe_note(engine, task, space, points, workers, use_cache, why), file=sys.stderr, flush=True)
        found = _measured_with_a_bar(engine, task, space, points, workers)
    elif why:  # nobody watches the start, but a fast start that is lost is said, in a log too
        at_most = probe_size(engine, task, space, points)[1]
        warnings.warn(f"{why} ({at_most} rollouts at most)", EngineVersionWarning, stacklevel=2)
        found = measure_activity(engine, task, space, points, workers=workers)
    else:
        found = measure_activity(engine, task, space, points, workers=workers)
    if use_cache:
        _write_cache(path, {name: asdict(a) for name, a in found.items()})
        _MEMORY[path] = found
    return found


def _measured_with_a_bar(
    engine: str, task: TaskSpec, space: ParameterSpace, points: int, workers: int
) -> dict[str, Activity]:
    """:func:`measure_activity` with a progress bar on stderr over its rollouts (at most the bound
    :func:`probe_note` gives; the bar completes when the probe ends early, its parameters all found active), where
    stderr is a terminal (a pipe or a log gets the note alone)."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    console = Console(stderr=True)
    if not console.is_terminal:
        return measure_activity(engine, task, space, points, workers=workers)

    _, bound = probe_size(engine, task, space, points)
    columns = (TextColumn("[bold]probe[/]"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn())
    with Progress(*columns, console=console, transient=True) as progress:
        bar = progress.add_task("probe", total=bound)
        found = measure_activity(
            engine, task, space, points, workers=workers, on_rollouts=lambda n: progress.advance(bar, n)
        )
        progress.update(bar, completed=bound)
    return found


def _write_cache(path: Path, data: dict) -> None:
    """Best effort: a cache that cannot be written costs only a repeated probe."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
        with os.fdopen(fd, "w") as fh:
            json.dump(data, fh, indent=1)
        os.replace(tmp, path)
    except OSError:
        pass


def inactive_parameters(
    engine: str,
    tasks: list[TaskSpec],
    space: ParameterSpace,
    use_cache: bool = True,
    workers: int = 1,
    deadline: float | None = None,
) -> dict[str, str]:
    """Parameters of ``space`` that change no rollout of any of ``tasks``: name -> why (per task where they differ).

    A probe not cached yet runs on ``workers`` processes, until ``deadline`` (``time.monotonic()``; None: none):
    past it a task's probe that is not held is not run, and that task's parameters count as active but for those
    the engine and its schedule rule out without a rollout (:func:`declared_inactive`), said in one warning.  A run
    under ``--max-seconds`` so spends at most one task's probe past it; a later run reads the probes measured."""
    per_task: dict[str, dict[str, Activity]] = {}
    skipped: list[str] = []
    for task in tasks:
        measure = deadline is None or time.monotonic() < deadline
        found = task_activity(engine, task, space, use_cache=use_cache, workers=workers, measure=measure)
        if found is None:
            declared = declared_inactive(engine, [task], space)
            found = {n: Activity(n, n not in declared, 0.0, declared.get(n, "")) for n in space.names}
            skipped.append(task.name)
        per_task[task.name] = found
    if skipped:
        shown = ", ".join(skipped[:3]) + (f" and {len(skipped) - 3} more" if len(skipped) > 3 else "")
        warnings.warn(
            f"the probe of which parameters change a rollout was cut short by the time cap: {len(skipped)} of "
            f"{len(tasks)} tasks not probed ({shown}); their parameters stay in the search (a later run reads the "
            "probes measured, and probes the rest)",
            RecordingWarning,
            stacklevel=2,
        )
    inactive = {}
    for name in space.names:
        if all(not found[name].active for found in per_task.values()):
            reasons = {found[name].reason for found in per_task.values()}
            if len(reasons) == 1:
                inactive[name] = reasons.pop()
            else:
                inactive[name] = "; ".join(f"{task}: {found[name].reason}" for task, found in per_task.items())
    return inactive


def declared_inactive(engine: str, tasks: list[TaskSpec], space: ParameterSpace) -> dict[str, str]:
    """The parameters of ``space`` that the engine (``Engine.inactive_parameters``), the schedules (a joint never
    moved) or the engine's parameter list rule out in every one of ``tasks``: name -> why, without a rollout.

    What a run that keeps every parameter (``--keep-inactive``, ``--paper-exact``) records instead of the
    probe, whose rollouts such a run has no use for (for a slow engine, minutes before the search)."""
    cls = engine_class(engine)
    per_task = []
    for task in tasks:
        supported = cls.supported(task.robot)
        reasons = {
            name: f"engine {engine!r} has no such parameter"
            for name in space.names
            if not is_supported(name, supported)
        }
        per_task.append(schedule_reasons(task) | cls.inactive_parameters(task) | reasons)
    return {
        name: "; ".join(dict.fromkeys(reasons[name] for reasons in per_task))
        for name in space.names
        if all(name in reasons for reasons in per_task)
    }


def active_space(space: ParameterSpace, inactive: dict[str, str], keep: list[str] | None = None) -> ParameterSpace:
    """``space`` without its ``inactive`` parameters (those named in ``keep`` stay)."""
    kept = set(keep or ())
    return ParameterSpace(space.name, tuple(p for p in space.parameters if p.name not in inactive or p.name in kept))
