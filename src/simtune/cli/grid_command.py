"""``simtune grid``: an experiment grid, run (a live table of its progress) or planned (--plan), through
:mod:`simtune.api`."""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Annotated, Any

import typer

from simtune.cli.options import (
    RepeatSetOpt,
    max_seconds_option,
    out_option,
)
from simtune.cli.output import err, out, split
from simtune.cli.run_options import run_options
from simtune.common.console import text_table

ExperimentsOpt = Annotated[
    str,
    typer.Option(
        help="Experiments, comma-separated; join tasks tuned together with '+' "
        "(single+cube), or name a group (seed-11)."
    ),
]
RepeatsOpt = Annotated[int, typer.Option(min=1, help="Optimisations per engine x task x space (seeds 0..N-1).")]
GridOutOpt = Annotated[Path, out_option("Grid folder: grid.sqlite index and runs/.")]
ExecutorOpt = Annotated[str, typer.Option(help="local (process pool here) or dask (a distributed cluster).")]
SchedulerOpt = Annotated[
    str | None,
    typer.Option(help="Dask scheduler address (tcp://host:8786); default: a LocalCluster on this machine."),
]
GridWorkersOpt = Annotated[
    int,
    typer.Option(
        "--workers",
        "-w",
        min=1,
        help="Local processes / LocalCluster workers (one optimisation each, one core each).",
    ),
]
IndexOpt = Annotated[
    str | None,
    typer.Option(
        "--index",
        help="PostgreSQL URL (postgresql://user@host/db) for a long-lived index shared by many grids; "
        "default: GRID/grid.sqlite. Needs pip install 'simtune[postgres]'.",
    ),
]
PlanOpt = Annotated[bool, typer.Option("--plan", help="Print the grid's size and cost estimate; run nothing.")]
ClusterCoresOpt = Annotated[int, typer.Option(min=1, help="With --plan: cores of the cluster to estimate for.")]


@run_options("data", "max_generations", "only", "keep_inactive", "reference")
def grid(
    engines: Annotated[str, typer.Option(help="Engines, comma-separated.")] = "mujoco,pybullet",
    tasks: ExperimentsOpt = "single,cube",
    spaces: Annotated[str, typer.Option(help="Parameter spaces, comma-separated.")] = "shared,individual",
    repeats: RepeatsOpt = 10,
    out_dir: GridOutOpt = Path("runs/grid"),
    executor: ExecutorOpt = "local",
    scheduler: SchedulerOpt = None,
    workers: GridWorkersOpt = 2,
    index_url: IndexOpt = None,
    max_seconds_per_run: Annotated[
        float | None, max_seconds_option("Wall-time limit of each optimisation [s].")
    ] = None,
    repeat_set: RepeatSetOpt = None,
    plan: PlanOpt = False,
    cluster_cores: ClusterCoresOpt = 100,
    **settings: Any,
) -> None:
    """Run an experiment grid (engines x tasks x spaces x repeats), resumably, locally or on Dask.

    Running the same command again skips finished optimisations and resumes
    unfinished ones; `--plan` prints the grid's size and its estimated
    core-hours from measured evaluation costs.
    """
    from simtune import api

    spec = api.grid_spec(
        split(engines),
        split(tasks),
        split(spaces),
        repeats=repeats,
        max_seconds_per_run=max_seconds_per_run,
        repeat_set=repeat_set,
        **settings,  # the run settings a grid's units share (data, generations, only, inactive, reference)
    )
    if plan:
        _print_plan(spec, settings["max_generations"], cluster_cores)
        return
    _run(spec, out_dir, executor=executor, workers=workers, scheduler=scheduler, index_url=index_url)


def _print_plan(spec, max_generations: int, cluster_cores: int) -> None:
    from simtune import api

    rows = api.plan_grid(spec)
    table = text_table(
        f"grid plan: {len(spec.units())} optimisations",
        ("engine", "tasks", "space", "params", "s / eval", "evals / run", "h / run", "core-hours"),
    )
    for r in rows:
        table.add_row(
            r["engine"],
            r["tasks"],
            r["space"],
            str(r["parameters"]),
            f"{r['eval_s']:.3f}",
            str(r["evaluations_per_run"]),
            f"{r['run_hours']:.2f}",
            f"{r['core_hours']:.1f}",
        )
    out.print(table)
    total = sum(r["core_hours"] for r in rows)
    here = os.cpu_count() or 1
    out.print(
        f"total {total:.1f} core-hours (upper bound: {max_generations} generations per run unless "
        f"--max-seconds-per-run caps it): {total / here:.1f} h on this machine ({here} cores), "
        f"{total / cluster_cores:.1f} h on a {cluster_cores}-core cluster"
    )


def _run(spec, out_dir: Path, **execution) -> None:
    """Run the grid under a live table of its progress; exit 1 if an optimisation failed."""
    from rich.live import Live

    from simtune import api

    started = time.time()

    def view(index):
        counts = index.counts()
        done, total = counts.get("done", 0), sum(counts.values())
        elapsed = time.time() - started
        eta = f"{elapsed / done * (total - done) / 60:.1f} min" if done else "-"
        table = text_table(
            f"grid {out_dir}: {done}/{total} done, {counts.get('running', 0)} running, "
            f"{counts.get('failed', 0)} failed, {counts.get('pending', 0)} pending; ETA {eta}",
            ("engine", "tasks", "best fitness"),
        )
        for engine_name, task_names, best in index.best():
            table.add_row(engine_name, task_names, f"{best:.4f}")
        return table

    with Live(console=err, auto_refresh=False) as live:
        index = api.grid(spec, out_dir, on_event=lambda idx: live.update(view(idx), refresh=True), **execution)
    counts = index.counts()
    out.print(f"{counts.get('done', 0)} done, {counts.get('failed', 0)} failed; index: {index.location}")
    for row in index.rows():
        if row["status"] == "failed":
            err.print(f"[red]failed:[/] {row['id']}: {row['error']}", soft_wrap=True)
    if counts.get("failed"):
        raise typer.Exit(1)
