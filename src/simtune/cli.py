"""The ``simtune`` command line.

Every command explains itself with ``--help``.  Errors in the user's input
print one line (``error: ...``) and exit with status 2; warnings about data
that was still usable print ``warning: ...`` and the command goes on.
"""

from __future__ import annotations

import json
import sys
import time
import warnings
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console
from rich.table import Table

from simtune.errors import SimtuneError
from simtune.report.command import report

app = typer.Typer(
    help="Tune physics-engine parameters until a simulated robot reproduces its motion-capture recordings.\n\n"
    "Start with `simtune demo`; then `simtune evaluate` and `simtune tune` on your own recordings "
    "(--data ROOT, one sub-folder of recordings per task, e.g. ROOT/cube/*.tsv).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
err = Console(stderr=True)
out = Console()

EngineOpt = Annotated[str, typer.Option("--engine", "-e", help="Physics engine: see `simtune engines`.")]
TaskOpt = Annotated[str, typer.Option("--task", "-t", help="Task name, or several joined by commas (their fitness is "
                                      "summed); see `simtune tasks`.")]
DataOpt = Annotated[Optional[Path], typer.Option(
    "--data", "-d", help="Folder with one sub-folder of recordings per task (ROOT/<task>/*.tsv or *.csv). "
    "Default: the reference recordings shipped with simtune.")]
JsonOpt = Annotated[bool, typer.Option("--json", help="Print one JSON object instead of a table.")]


def _data_root(data: Path | None) -> Path:
    from simtune.reference import REFERENCE_DIR

    return data if data is not None else REFERENCE_DIR


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    err.print(f"[yellow]warning:[/] {message}", highlight=False, soft_wrap=True)


def _fmt(value: float | None) -> str:
    return "-" if value is None else f"{value:.4f}"


@app.command()
def evaluate(
    engine: EngineOpt = "mujoco",
    task: TaskOpt = "cube",
    data: DataOpt = None,
    params_file: Annotated[Optional[Path], typer.Option(
        "--params-file", "-p", help="JSON of parameter values (e.g. a run's best_params.json); "
        "default: the engine's generic values.")] = None,
    as_json: JsonOpt = False,
) -> None:
    """Fitness of an engine's generic parameters (or of --params-file) on recorded tasks."""
    from simtune.engines import engine_class
    from simtune.objective import Objective, load_references
    from simtune.params import read_params_file, validate_params
    from simtune.tasks import parse_tasks

    tasks = parse_tasks(task)
    cls = engine_class(engine)
    params = {}
    if params_file is not None:
        params = validate_params(read_params_file(params_file), cls.supported(), engine, where=str(params_file))
    objective = Objective(engine, tasks, load_references(_data_root(data), tasks))
    t0 = time.perf_counter()
    score = objective.score(params)
    wall = time.perf_counter() - t0
    generic = score if not params else objective.score({})
    result = {
        "engine": engine, "task": task, "space": None, "fitness": score.fitness,
        "wrist_error": score.wrist_error, "object_error": score.object_error,
        "generic_fitness": generic.fitness, "stable": score.stable, "wall_s": wall,
        "tasks": [t.__dict__ for t in score.tasks],
    }
    if as_json:
        print(json.dumps(result))
        return
    table = Table(title=f"{engine} on {task}" + (f" with {params_file}" if params_file else " (generic parameters)"))
    for col in ("task", "fitness", "wrist error [m]", "object error [m]", "note"):
        table.add_column(col)
    for t in score.tasks:
        table.add_row(t.task, _fmt(t.fitness), _fmt(t.wrist_error), _fmt(t.object_error), t.message)
    if len(score.tasks) > 1:
        table.add_row("all", _fmt(score.fitness), _fmt(score.wrist_error), _fmt(score.object_error), "")
    out.print(table)
    if params:
        out.print(f"generic fitness: {generic.fitness:.4f}")


def _report_tune(result, run_dir: Path, config, store_generic: dict, as_json: bool) -> None:
    from simtune.runs import BEST_PARAMS_FILE

    payload = {
        "engine": config.engine, "task": config.tasks, "space": config.space,
        "fitness": result.score.fitness, "wrist_error": result.score.wrist_error,
        "object_error": result.score.object_error, "generic_fitness": store_generic["fitness"],
        "evaluations": result.evaluations, "generations": result.generations, "wall_s": result.wall_s,
        "best_params_file": str(run_dir / BEST_PARAMS_FILE), "message": result.message,
    }
    if as_json:
        print(json.dumps(payload))
        return
    out.print(f"[bold]{config.engine}[/] on [bold]{config.tasks}[/], space {config.space}: "
              f"fitness {store_generic['fitness']:.4f} (generic) -> [bold green]{result.score.fitness:.4f}[/] (tuned)")
    out.print(f"  wrist error {_fmt(result.score.wrist_error)} m, object error {_fmt(result.score.object_error)} m; "
              f"{result.evaluations} evaluations, {result.generations} generations, {result.wall_s:.0f} s "
              f"({result.message})")
    out.print(f"  best parameters: {payload['best_params_file']}")


@app.command()
def tune(
    engine: EngineOpt = "mujoco",
    task: TaskOpt = "cube",
    data: DataOpt = None,
    space: Annotated[str, typer.Option("--space", "-s", help="Parameter space: shared (31, the paper's), "
                                       "individual (57, the paper's), or extended (individual + command delay "
                                       "and marker offset).")] = "extended",
    seed: Annotated[int, typer.Option(help="Random seed of the optimiser (same seed, same run).")] = 0,
    workers: Annotated[int, typer.Option("--workers", "-w", min=1, help="Processes evaluating the population.")] = 1,
    max_seconds: Annotated[Optional[float], typer.Option(help="Stop after this much wall time [s].")] = None,
    max_generations: Annotated[int, typer.Option(min=1, help="Stop after this many generations.")] = 1000,
    target_fitness: Annotated[Optional[float], typer.Option(help="Stop once the best fitness reaches this.")]
    = None,
    no_prune: Annotated[bool, typer.Option("--no-prune", help="Simulate every trial to the end (by default a "
                                           "trial that can no longer beat its parent stops early: same search, "
                                           "its stored fitness a lower bound).")] = False,
    only: Annotated[Optional[str], typer.Option(help="Tune only these parameters of the space (comma-separated); "
                                                "the rest keep their generic values.")] = None,
    eval_timeout: Annotated[float, typer.Option(help="With --workers 2+: an evaluation still running after this "
                                                "many seconds is abandoned, stored as failed, its worker replaced.")]
    = 600.0,
    out_dir: Annotated[Path, typer.Option("--out", "-o", help="Run folder to create (store, best_params.json).")]
    = Path("runs/latest"),
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")] = False,
    as_json: JsonOpt = False,
) -> None:
    """Tune an engine's parameters to recorded tasks with differential evolution.

    Every evaluation is stored in OUT/run.sqlite as it finishes; if the run is
    killed, `simtune resume OUT` continues it without redoing any evaluation.
    """
    from simtune.runs import RunConfig, start_run
    from simtune.store import RunStore

    config = RunConfig(engine=engine, tasks=task, space=space, data=str(_data_root(data)), seed=seed,
                       workers=workers, max_seconds=max_seconds, max_generations=max_generations,
                       only=_split(only) if only else None, eval_timeout=eval_timeout,
                       target_fitness=target_fitness, prune=not no_prune)
    result = start_run(config, out_dir, show_progress=not quiet and not as_json)
    _report_tune(result, out_dir, config, RunStore(out_dir).get("generic"), as_json)


@app.command()
def resume(
    run_dir: Annotated[Path, typer.Argument(help="A run folder made by `simtune tune`.")],
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")] = False,
    as_json: JsonOpt = False,
) -> None:
    """Continue a tuning run that was stopped or killed, keeping every finished evaluation."""
    from simtune.runs import RunConfig, resume_run
    from simtune.store import RunStore

    result = resume_run(run_dir, show_progress=not quiet and not as_json)
    store = RunStore(run_dir)
    _report_tune(result, run_dir, RunConfig(**store.get("config")), store.get("generic"), as_json)


@app.command()
def demo(
    out_dir: Annotated[Path, typer.Option("--out", "-o", help="Run folder for the demo's tuning run.")]
    = Path("runs/demo"),
    workers: Annotated[int, typer.Option("--workers", "-w", min=1)] = 2,
    max_seconds: Annotated[float, typer.Option(help="Time budget of the tuning run [s].")] = 120.0,
) -> None:
    """Tune MuJoCo to the shipped reference recording and print generic vs tuned error (about a minute)."""
    from simtune.reference import run_demo

    run_demo(out_dir, workers=workers, max_seconds=max_seconds, console=out)


def _split(text: str) -> list[str]:
    return [part.strip() for part in text.split(",") if part.strip()]


@app.command()
def grid(
    engines: Annotated[str, typer.Option(help="Engines, comma-separated.")] = "mujoco,pybullet",
    tasks: Annotated[str, typer.Option(help="Experiments, comma-separated; join tasks tuned together with '+' "
                                       "(single+cube), or name a group (seed-11).")] = "single,cube",
    spaces: Annotated[str, typer.Option(help="Parameter spaces, comma-separated.")] = "shared,individual",
    repeats: Annotated[int, typer.Option(min=1, help="Optimisations per engine x task x space (seeds 0..N-1).")]
    = 10,
    data: DataOpt = None,
    out_dir: Annotated[Path, typer.Option("--out", "-o", help="Grid folder: grid.sqlite index and runs/.")]
    = Path("runs/grid"),
    executor: Annotated[str, typer.Option(help="local (process pool here) or dask (a distributed cluster).")]
    = "local",
    scheduler: Annotated[Optional[str], typer.Option(help="Dask scheduler address (tcp://host:8786); "
                                                     "default: a LocalCluster on this machine.")] = None,
    workers: Annotated[int, typer.Option("--workers", "-w", min=1, help="Local processes / LocalCluster workers "
                                         "(one optimisation each, one core each).")] = 2,
    max_seconds_per_run: Annotated[Optional[float], typer.Option(help="Wall-time limit of each optimisation [s].")]
    = None,
    max_generations: Annotated[int, typer.Option(min=1, help="Generation limit of each optimisation.")] = 1000,
    only: Annotated[Optional[str], typer.Option(help="Tune only these parameters (comma-separated).")] = None,
    plan: Annotated[bool, typer.Option("--plan", help="Print the grid's size and cost estimate; run nothing.")]
    = False,
    cluster_cores: Annotated[int, typer.Option(help="With --plan: cores of the cluster to estimate for.")] = 100,
) -> None:
    """Run an experiment grid (engines x tasks x spaces x repeats), resumably, locally or on Dask.

    Running the same command again skips finished optimisations and resumes
    unfinished ones; `--plan` prints the grid's size and its estimated
    core-hours from measured evaluation costs.
    """
    import os

    from rich.live import Live

    from simtune.grid import GridSpec, iter_best, plan_grid, run_grid

    spec = GridSpec(engines=_split(engines), tasks=_split(tasks), spaces=_split(spaces), repeats=repeats,
                    data=str(_data_root(data)), max_seconds_per_run=max_seconds_per_run,
                    max_generations=max_generations, only=_split(only) if only else None)
    if plan:
        rows = plan_grid(spec)
        table = Table(title=f"grid plan: {len(spec.units())} optimisations")
        for col in ("engine", "tasks", "space", "params", "s / eval", "evals / run", "h / run", "core-hours"):
            table.add_column(col)
        for r in rows:
            table.add_row(r["engine"], r["tasks"], r["space"], str(r["parameters"]), f"{r['eval_s']:.3f}",
                          str(r["evaluations_per_run"]), f"{r['run_hours']:.2f}", f"{r['core_hours']:.1f}")
        out.print(table)
        total = sum(r["core_hours"] for r in rows)
        here = os.cpu_count() or 1
        out.print(f"total {total:.1f} core-hours (upper bound: {max_generations} generations per run unless "
                  f"--max-seconds-per-run caps it): {total / here:.1f} h on this machine ({here} cores), "
                  f"{total / cluster_cores:.1f} h on a {cluster_cores}-core cluster")
        return

    started = time.time()

    def view(index) -> Table:
        counts = index.counts()
        done, total = counts.get("done", 0), sum(counts.values())
        elapsed = time.time() - started
        eta = f"{elapsed / done * (total - done) / 60:.1f} min" if done else "-"
        table = Table(title=f"grid {out_dir}: {done}/{total} done, {counts.get('running', 0)} running, "
                      f"{counts.get('failed', 0)} failed, {counts.get('pending', 0)} pending; ETA {eta}")
        table.add_column("engine")
        table.add_column("tasks")
        table.add_column("best fitness")
        for engine_name, task_names, best in iter_best(index):
            table.add_row(engine_name, task_names, f"{best:.4f}")
        return table

    with Live(console=err, auto_refresh=False) as live:
        index = run_grid(spec, out_dir, executor=executor, workers=workers, scheduler=scheduler,
                         on_event=lambda idx: live.update(view(idx), refresh=True))
    counts = index.counts()
    out.print(f"{counts.get('done', 0)} done, {counts.get('failed', 0)} failed; index: {out_dir / 'grid.sqlite'}")
    for row in index.rows():
        if row["status"] == "failed":
            err.print(f"[red]failed:[/] {row['id']}: {row['error']}", soft_wrap=True)
    if counts.get("failed"):
        raise typer.Exit(1)


@app.command()
def engines() -> None:
    """List the physics engines, their versions, and how to install a missing one."""
    import importlib

    from rich.markup import escape

    from simtune.engines import ENGINES

    table = Table(title="physics engines")
    for col in ("engine", "version", "installed", "install"):
        table.add_column(col)
    for name, (module, cls, hint) in ENGINES.items():
        version = getattr(importlib.import_module(module), cls).version()
        installed = version != "not installed"
        table.add_row(name, version if installed else "-", "yes" if installed else "[red]no[/]", escape(hint))
    out.print(table)


@app.command()
def tasks() -> None:
    """List the tasks: duration, object and whether public recordings exist."""
    from simtune.tasks import GROUPS, TASKS

    table = Table(title="tasks")
    for col in ("task", "duration [s]", "object", "public recordings", "description"):
        table.add_column(col)
    for t in TASKS.values():
        obj = f"{t.object.material} {t.object.shape} {t.object.mass:g} kg" if t.object else "-"
        table.add_row(t.name, f"{t.duration:g}", obj, "qrg2019" if t.has_public_recordings else "-", t.description)
    for name, members in GROUPS.items():
        table.add_row(name, "-", "-", "-", f"all of {members[0]} .. {members[-1]}, fitness summed")
    out.print(table)


@app.command()
def params(
    space: Annotated[str, typer.Option("--space", "-s", help="shared, individual or extended.")] = "extended",
    engine: Annotated[Optional[str], typer.Option("--engine", "-e", help="Only what this engine supports.")] = None,
) -> None:
    """List a parameter space: names, ranges, units."""
    from simtune.engines import engine_class
    from simtune.params import get_space

    supported = engine_class(engine).supported() if engine else None
    sp = get_space(space, supported)
    table = Table(title=f"space {space}" + (f" in {engine}" if engine else "") + f": {len(sp)} parameters")
    for col in ("parameter", "low", "high", "unit", "meaning"):
        table.add_column(col)
    for p in sp.parameters:
        table.add_row(p.name, f"{p.low:g}", f"{p.high:g}", p.unit, p.description)
    out.print(table)


app.command()(report)  # defined beside the report package it drives


def main() -> None:
    warnings.showwarning = _show_warning
    try:
        app()
    except SimtuneError as exc:
        err.print(f"[red]error:[/] {exc}", highlight=False, soft_wrap=True)
        sys.exit(2)
    except KeyboardInterrupt:
        err.print("interrupted: finished evaluations are in the run store; `simtune resume RUN_DIR` continues")
        sys.exit(130)


if __name__ == "__main__":
    main()
