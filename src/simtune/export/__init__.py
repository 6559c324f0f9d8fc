"""Export a tuned run as the engine's own model files, with provenance: the tuned simulator, taken home.

``export_run(run_dir, out_dir)`` writes, for the run's engine (with the exporter its registry
entry names: ``simtune/engines/<engine>/export.py``):

- MuJoCo: ``scene_<task>.xml`` (MJCF), one per task;
- PyBullet: ``robot.urdf``, ``floor.urdf``, ``object_<task>.urdf``, ``pybullet.json``
  (what URDF cannot hold) and ``load_pybullet.py`` (loads both);
- DART: ``robot.urdf``, ``object_<task>.urdf``, ``dart.json``, ``load_dart.py``;
- Drake: ``robot.urdf`` with Drake's own tags, ``scene_<task>.sdf`` (floor and
  object), ``drake.json``, ``load_drake.py``;
- ODE: ``ode.json`` only (ODE has no model file format);

and for every engine ``controller.yaml`` (how the run drove the model),
``provenance.json`` (where it all comes from, each file's SHA-256) and, with
``dr=True``, ``dr_ranges.yaml``.  docs/parameters.md says what each engine's
files hold and cannot hold.
"""

from __future__ import annotations

import contextlib
import json
import shutil
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from simtune.engines import ENGINES, load_part, make_engine
from simtune.engines.export_base import ExportContext, RobotDescription, exported_robot, hash_comment
from simtune.errors import ConfigError, SimtuneError
from simtune.export.common import CONTROLLER_FILE, PROVENANCE_FILE, controller_yaml, now_utc, provenance, sha256
from simtune.export.source import ExportWarning, TunedRun, read_run
from simtune.tasks import TaskSpec

DR_FILE = "dr_ranges.yaml"


@dataclass
class ExportResult:
    out: Path
    run: Path
    engine: str
    files: list[str]  # written into ``out``, provenance.json last


def export_run(
    run_dir: Path | str,
    out_dir: Path | str,
    engine: str | None = None,
    dr: bool = False,
    force: bool = False,
    robot: RobotDescription | None = None,
) -> ExportResult:
    """Export the finished run in ``run_dir`` into ``out_dir`` as ``engine``'s files (default: the run's engine).

    A SimtuneError (one line) for an unfinished run, one from another simtune or
    store version or without its store, an ``engine`` other than the run's, and
    a non-empty ``out_dir`` unless ``force`` (which replaces a previous export
    there: the files its provenance.json lists, and same-named files).
    """
    if engine is not None and engine not in ENGINES:
        raise ConfigError(f"--engine: unknown engine {engine!r} (known: {', '.join(ENGINES)})")
    run = read_run(run_dir)
    if engine is not None and engine != run.engine:
        raise ConfigError(
            f"{run_dir} was tuned with engine {run.engine!r}, not {engine!r}: its values are {run.engine}'s "
            f"(tune {engine} to export {engine})"
        )
    out = Path(out_dir)
    _prepare(out, force)
    ranges = _dr_ranges([run]) if dr else None
    return _export(run, out, robot or exported_robot(run.tasks[0].robot), ranges)


def export_runs(
    paths: Sequence[Path | str], out_dir: Path | str, dr: bool = False, force: bool = False
) -> tuple[list[ExportResult], list[tuple[Path, str]]]:
    """Export every run found in ``paths`` (run folders, or folders holding runs: a grid), each as its own engine's.

    Each run goes to ``out_dir/<its folder name>``.  A run that cannot be
    exported (unfinished, another version ...) is skipped and returned with
    the reason; (exported, skipped).  With ``dr``, each export's dr_ranges.yaml
    spans all the exported runs of its engine, as the report's does.
    """
    from simtune.report.collect import find_run_dirs

    dirs = find_run_dirs([Path(p) for p in paths])
    runs: list[TunedRun] = []
    skipped: list[tuple[Path, str]] = []
    for d in dirs:
        try:
            runs.append(read_run(d))
        except SimtuneError as exc:
            skipped.append((d, str(exc)))
    if not runs:
        reasons = "; ".join(f"{why}" for _, why in skipped[:3])
        raise SimtuneError(f"no run to export in {', '.join(str(p) for p in paths)} ({reasons})")
    names = [r.path.name for r in runs]
    clashes = sorted({n for n in names if names.count(n) > 1})
    if clashes:
        raise SimtuneError(f"several runs are named {clashes[0]!r}: export them one at a time (--out per run)")
    out = Path(out_dir)
    _prepare(out, force, children=names)
    ranges = _dr_ranges(runs) if dr else None
    return [_export(run, out / run.path.name, exported_robot(run.tasks[0].robot), ranges) for run in runs], skipped


# --------------------------------------------------------------------------------------------------


def _prepare(out: Path, force: bool, children: list[str] | None = None) -> None:
    """Refuse a non-empty folder unless ``force``; with it, remove the previous export(s) there."""
    targets = [out] if children is None else [out / c for c in children]
    if out.exists() and not out.is_dir():
        raise SimtuneError(f"{out} is a file, not a folder")
    for target in targets:
        if target.exists() and any(target.iterdir()):
            if not force:
                raise SimtuneError(f"{target} is not empty: export never overwrites it without --force")
            _remove_previous(target)


def _remove_previous(folder: Path) -> None:
    """Remove the files a previous export listed in its provenance.json (none where it holds no export of simtune's:
    the export then writes beside the folder's files and refuses to write over any, ``ExportContext.claim``)."""
    record = folder / PROVENANCE_FILE
    try:
        previous = json.loads(record.read_text())
        listed = previous.get("files", {})
        if not str(previous.get("exported_by", "")).startswith("simtune") or not isinstance(listed, dict):
            return  # the user's own provenance.json: kept, and the export refuses to write over it
    except (OSError, ValueError, AttributeError):
        return
    try:
        for name in listed:
            path = folder / name
            if path.is_file() and path.parent == folder:
                path.unlink()
        record.unlink(missing_ok=True)
    except OSError as exc:
        raise _cannot_write(folder, exc) from None
    shutil.rmtree(folder / "__pycache__", ignore_errors=True)


def _cannot_write(out: Path, exc: OSError) -> SimtuneError:
    """One line for a folder the export cannot write in (read-only, full, not ours)."""
    name = f" ({Path(exc.filename).name})" if exc.filename else ""
    return SimtuneError(
        f"cannot write the export into {out}: {exc.strerror or exc}{name}: export into a folder you can write"
    )


def _export(run: TunedRun, out: Path, robot: RobotDescription, ranges: dict | None) -> ExportResult:
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SimtuneError(f"cannot create export folder {out}: {exc.strerror}") from None
    engines = {task.name: make_engine(run.engine, task) for task in run.tasks}
    ctx = None
    try:
        values: dict[str, float] = {}
        for engine in engines.values():
            engine.reset(run.params)
            values.update({**engine.defaults(), **run.params})
        ctx = ExportContext(
            engine=run.engine,
            robot=robot,
            out=out,
            params=run.params,
            tasks=run.tasks,
            engines=engines,
            values=values,
            provenance=provenance(run, run.engine, now_utc()),
        )
        write_model = load_part(ENGINES[run.engine].exporter)  # the engine's own exporter, in its folder
        write_model(ctx)
        ctx.write(CONTROLLER_FILE, controller_yaml(ctx, _samples(run)))
        if ranges is not None:
            _write_dr(ctx, ranges)
        record = {**ctx.provenance, "files": {name: sha256(out / name) for name in ctx.files}}
        if (out / PROVENANCE_FILE).exists():  # the user's own (a previous export's was removed before)
            raise SimtuneError(
                f"{out / PROVENANCE_FILE} exists and is not a previous export's: export never overwrites it"
            )
        (out / PROVENANCE_FILE).write_text(json.dumps(record, indent=2) + "\n")
    except BaseException as exc:
        for name in ctx.files if ctx is not None else []:  # nothing half-written stays behind
            with contextlib.suppress(OSError):
                (out / name).unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise _cannot_write(out, exc) from None
        raise
    finally:
        for engine in engines.values():
            engine.close()
    return ExportResult(out, run.path, run.engine, [*ctx.files, PROVENANCE_FILE])


def _samples(run: TunedRun) -> dict[str, int]:
    """How many 20 Hz samples each task's recordings span (what the fitness compared); {} without the data."""
    from simtune.objective import load_references

    data = run.config.data
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the run warned about its recordings already
            keep = run.config.keep_repeats  # the repeats the run was scored against
            refs = load_references(None if data is None else Path(data), run.tasks, keep_repeats=keep)
    except SimtuneError as exc:
        missing = data is not None and not Path(data).is_dir()
        why = f"its data folder {data} was not found" if missing else f"its recordings cannot be read ({exc})"
        warnings.warn(
            f"{run.path}: {why}: controller.yaml gives no sample counts (samples: null)", ExportWarning, stacklevel=3
        )
        return {}
    return {name: len(ref.times) for name, ref in refs.items()}


def _dr_ranges(runs: list[TunedRun]) -> dict:
    """engine -> parameter -> range (the report's dr_ranges) over ``runs``, and the tasks behind each engine."""
    from simtune.report.collect import ReportedRun, group_runs, reported_run
    from simtune.report.dr import dr_ranges
    from simtune.report.simulate import nominal_values

    records = [r for r in (reported_run(run.record, str(run.path)) for run in runs) if isinstance(r, ReportedRun)]
    groups, _ = group_runs(records)
    specs: dict[str, dict[str, TaskSpec]] = {}
    for run in runs:
        for task in run.tasks:
            specs.setdefault(run.engine, {}).setdefault(task.name, task)
    tasks = {engine: list(by_name) for engine, by_name in specs.items()}
    nominal = {engine: nominal_values(engine, list(by_name.values())) for engine, by_name in specs.items()}
    return {"ranges": dr_ranges(groups, nominal), "tasks": tasks, "runs": len(records)}


def _write_dr(ctx: ExportContext, ranges: dict) -> None:
    import yaml

    engine = ctx.engine
    lines = ctx.header(f"dr_ranges.yaml: domain-randomisation ranges for {engine}")
    lines += [
        "",
        f"parameter -> min / max: what the tuned values span over the {ranges['runs']} run(s) exported together",
        "(one run: min = max = its tuned value; export a grid with --all-engines --dr for the spread over its",
        "repeats); nominal: the generic value; bounds: the tuning range; runs: how many runs tuned it.",
        f"{engine}: tasks {', '.join(ranges['tasks'][engine])}",
        "",
    ]
    body = yaml.safe_dump({engine: ranges["ranges"].get(engine, {})}, sort_keys=False, default_flow_style=None)
    ctx.write(DR_FILE, hash_comment(lines) + body)


__all__ = ["DR_FILE", "ExportResult", "ExportWarning", "RobotDescription", "export_run", "export_runs"]
