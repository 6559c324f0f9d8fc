"""``simtune synth``: recordings with a known ground truth, for checking that tuning recovers it.

One engine simulates each task with chosen "true" parameter values; each
repeat gets motion-capture-like noise and a little start-time jitter
(:func:`simtune.reference.make.synthesize`) and is written as a Qualisys 6D
TSV with header to ``OUT/<task>/<task>NNNN.tsv``, the format real recordings
come in, so tuning reads them through the same loader.  ``OUT/truth.json``
holds the truth and the settings; it is also a parameter file
(``simtune evaluate --params-file OUT/truth.json``).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import simtune
from simtune.data import write_qualisys_tsv
from simtune.data.loaders import is_recording_file
from simtune.engines import engine_class
from simtune.errors import ConfigError, SimtuneError
from simtune.params import read_params_file, validate_params
from simtune.project import Project
from simtune.reference.make import synthesize
from simtune.robot.description import RobotDescription
from simtune.tasks import parse_tasks

TRUTH_FILE = "truth.json"
DEFAULT_DELAY_S = 1.5  # the real qrg2019 recordings start 1.2-2.3 s before the arm moves


@dataclass
class SynthResult:
    out: Path
    truth: dict[str, float]
    files: dict[str, list[Path]]  # task -> written recordings


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
    project: Project | Path | str | None = None,
) -> SynthResult:
    """Write ``repeats`` synthetic recordings of each task in ``tasks`` (names, groups, comma-separated) of
    ``project`` (default: the bundled MICO project)."""
    specs = parse_tasks(tasks, project)
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
            suffix=".tsv",
        )
        files[spec.name] = []
        for rec in recordings:
            write_qualisys_tsv(folder / rec.source.name, rec, header=True)
            files[spec.name].append(folder / rec.source.name)
    meta = {
        "engine": engine,
        "tasks": [s.name for s in specs],
        "noise_m": noise_m,
        "jitter_s": jitter_s,
        "repeats": repeats,
        "seed": seed,
        "simtune": simtune.__version__,
        "parameters": list(truth),
        "params": truth,
    }
    (out / TRUTH_FILE).write_text(json.dumps(meta, indent=2) + "\n")
    return SynthResult(out, truth, files)


def hash_seed(seed: int, name: str) -> int:
    """A seed for one task's noise: stable across runs and Python versions (no salted ``hash``)."""
    return (int(seed) * 1_000_003 + sum((i + 1) * ord(c) for i, c in enumerate(name))) % (2**32)
