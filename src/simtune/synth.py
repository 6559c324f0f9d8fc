"""``simtune synth``: recordings with a known ground truth, for checking that tuning recovers it.

One engine simulates each task with chosen "true" parameter values; each
repeat gets motion-capture-like noise and a little start-time jitter
(:func:`simtune.reference.make.synthesize`) and is written to
``OUT/<task>/<task>NNNN<ending>`` in one of :data:`FORMATS`: by default as a
Qualisys 6D TSV with header, the format real recordings come in, so tuning
reads them through the same loader; or as joint logs (the arm's joint angles
with encoder-like noise), beside the markers in simtune CSV or instead of
them in a CSV, an MCAP file or a rosbag2 folder.  ``OUT/truth.json`` holds the
truth and the settings; it is also a parameter file (``simtune evaluate
--params-file OUT/truth.json``).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import simtune
from simtune.data import Recording, write_csv, write_joint_bag, write_qualisys_tsv
from simtune.data.loaders import is_recording_file
from simtune.engines import engine_class
from simtune.errors import ConfigError, SimtuneError
from simtune.fitness import rollout_joint_names
from simtune.params import read_params_file, validate_params
from simtune.project import Project
from simtune.reference.make import synthesize
from simtune.robot.description import RobotDescription
from simtune.tasks import parse_tasks

TRUTH_FILE = "truth.json"
DEFAULT_DELAY_S = 1.5  # the real qrg2019 recordings start 1.2-2.3 s before the arm moves
#: encoder noise of synthetic joint logs [deg]: an arm's encoders read to about a tenth of a degree
DEFAULT_JOINT_NOISE_DEG = 0.05

#: ``--format``: what each repeat holds and where it goes (file ending; "" is a rosbag2 folder)
FORMATS = {
    "tsv": "markers in a Qualisys 6D TSV with header (as real recordings come)",
    "csv": "markers and joint angles in one simtune CSV",
    "joints-csv": "joint angles alone in a simtune CSV",
    "mcap": "joint angles alone as sensor_msgs/JointState in an MCAP file",
    "rosbag2": "joint angles alone as sensor_msgs/JointState in a rosbag2 folder (SQLite 3 storage)",
}
_ENDINGS = {"tsv": ".tsv", "csv": ".csv", "joints-csv": ".csv", "mcap": ".mcap", "rosbag2": ""}


@dataclass
class SynthResult:
    out: Path
    truth: dict[str, float]
    files: dict[str, list[Path]]  # task -> written recordings
    joint_noise_rad: float = 0.0  # of the joint logs written


def load_truth(
    path: Path | None, engine: str, delay_s: float | None, robot: RobotDescription | None = None
) -> dict[str, float]:
    """The true parameter values: the file's (validated for ``engine`` and ``robot``, default the MICO),
    with ``delay_s`` as command delay.

    No file: the engine's generic values and a command delay (``delay_s`` or
    :data:`DEFAULT_DELAY_S`).
    """
    supported = engine_class(engine).supported(robot)
    truth: dict[str, float] = {}
    if path is not None:
        truth = validate_params(read_params_file(path, engine), supported, engine, where=str(path), robot=robot)
    if delay_s is not None:
        truth["command_delay"] = delay_s
    elif path is None:
        truth["command_delay"] = DEFAULT_DELAY_S
    return validate_params(truth, supported, engine, where="--delay-s", robot=robot)


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
) -> SynthResult:
    """Write ``repeats`` synthetic recordings of each task in ``tasks`` (names, groups, comma-separated) of
    ``project`` (default: the bundled MICO project).

    ``fmt`` is a key of :data:`FORMATS`; joint angles get Gaussian noise of
    ``joint_noise_rad`` per sample.
    """
    specs = parse_tasks(tasks, project)
    if fmt not in FORMATS:
        raise ConfigError(f"--format: unknown format {fmt!r} (known: {', '.join(FORMATS)})")
    if not joint_noise_rad >= 0:
        raise ConfigError(f"--joint-noise-deg must be zero or more, got {joint_noise_rad:g} rad")
    if repeats < 1:
        raise ConfigError(f"--repeats must be at least 1, got {repeats}")
    if not noise_m >= 0:
        raise ConfigError(f"--noise-mm must be zero or more, got {noise_m * 1000:g}")
    if not jitter_s >= 0:
        raise ConfigError(f"--jitter-s must be zero or more, got {jitter_s:g}")
    out = Path(out)
    for spec in specs:
        folder = out / spec.name
        if folder.is_dir() and any(is_recording_file(p) for p in folder.iterdir()):
            raise SimtuneError(
                f"{folder} already holds recordings: choose another --out (new files would be averaged with them)"
            )
    files: dict[str, list[Path]] = {}
    for spec in specs:
        folder = out / spec.name
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise SimtuneError(f"--out {out}: cannot create {folder} ({exc.strerror})") from None
        # each task its own noise stream, so adding a task leaves the others' recordings unchanged
        recordings = synthesize(
            engine,
            spec,
            truth,
            repeats=repeats,
            noise_m=noise_m,
            jitter_s=jitter_s,
            seed=hash_seed(seed, spec.name),
            suffix=_ENDINGS[fmt],
            joint_names=None if fmt == "tsv" else rollout_joint_names(spec),
            joint_noise_rad=joint_noise_rad,
        )
        files[spec.name] = [write_recording(folder / rec.source.name, rec, fmt) for rec in recordings]
    meta = {
        "engine": engine,
        "tasks": [s.name for s in specs],
        "noise_m": noise_m,
        "jitter_s": jitter_s,
        "format": fmt,
        "joint_noise_rad": joint_noise_rad if fmt != "tsv" else None,
        "repeats": repeats,
        "seed": seed,
        "simtune": simtune.__version__,
        "parameters": list(truth),
        "params": truth,
    }
    (out / TRUTH_FILE).write_text(json.dumps(meta, indent=2) + "\n")
    return SynthResult(out, truth, files, joint_noise_rad)


def write_recording(path: Path, rec: Recording, fmt: str) -> Path:
    """Write one synthetic repeat in format ``fmt``; returns the file or folder written."""
    if fmt == "tsv":
        write_qualisys_tsv(path, rec, header=True)
    elif fmt == "csv":
        write_csv(path, rec)
    elif fmt == "joints-csv":
        write_csv(path, Recording(rec.source, rec.time, joints=rec.joints))
    else:
        return write_joint_bag(path, rec, storage="mcap" if fmt == "mcap" else "sqlite3")
    return path


def hash_seed(seed: int, name: str) -> int:
    """A seed for one task's noise: stable across runs and Python versions (no salted ``hash``)."""
    return (int(seed) * 1_000_003 + sum((i + 1) * ord(c) for i, c in enumerate(name))) % (2**32)
