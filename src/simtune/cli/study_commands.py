"""Studies: ``compare`` (optimisers), ``transfer`` (to unseen tasks), ``sensitivity`` and ``grid``, each a call
into :mod:`simtune.api`."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from simtune.cli.options import (
    DataOpt,
    EngineOpt,
    EvalTimeoutOpt,
    JsonOpt,
    OnlyOpt,
    OptimizerOpt,
    QuietOpt,
    SpaceOpt,
    TaskOpt,
    WorkersOpt,
    not_negative,
    out_option,
    path,
    seed_option,
)
from simtune.cli.output import err, fmt, only_names, out, print_json, print_whole_table, split
from simtune.cli.run_options import run_options, setting_options
from simtune.common.console import text_table
from simtune.run_config import COMPARE_DEFAULTS, TRANSFER_DEFAULTS

CompareOutOpt = Annotated[
    Path,
    out_option("Folder for the runs (`OUT/<optimizer>/seed-<s>`) and compare.json; existing finished runs are reused."),
]
TargetOpt = Annotated[
    float | None,
    typer.Option(
        help="Fitness to reach: the table gives the evaluations each optimiser needed (median over seeds).",
        callback=not_negative,
    ),
]


@run_options(
    "engine",
    "tasks",
    "data",
    "space",
    "workers",
    "only",
    "eval_timeout",
    "reference",
    "repeats",
    defaults=COMPARE_DEFAULTS,
    options={"space": SpaceOpt},
)
def compare(
    optimizers: Annotated[
        str, typer.Option(help="Optimisers to compare, comma-separated: any that `simtune tune --optimizer` takes.")
    ] = "de,cmaes,bo,random",
    budget_evals: Annotated[int, typer.Option("--budget-evals", min=1, help="Evaluations each run may use.")] = 300,
    seeds: Annotated[int, typer.Option(min=1, help="Runs per optimiser (seeds 0..N-1); medians are over them.")] = 3,
    target: TargetOpt = None,
    out_dir: CompareOutOpt = Path("runs/compare"),
    as_json: JsonOpt = False,
    **settings: Any,
) -> None:
    """Compare optimisers on the same budget of evaluations: best fitness at 25/50/100 % of it, evaluations to a target.

    Every optimiser x seed is an ordinary run; the table reads each run store's
    evaluations in the order they were stored (the first --budget-evals of them).
    Running the command again reuses finished runs and resumes unfinished ones.

    Example: simtune compare --engine mujoco --task cube --data DATA --budget-evals 300 --seeds 3 --target 0.05
    """
    from simtune import api
    from simtune.studies.compare import markdown_table

    def note(name: str, seed: int, what: str) -> None:
        if not as_json:
            err.print(f"{what} {name} seed {seed} ...", highlight=False)

    result = api.compare(
        out=out_dir,
        optimizers=split(optimizers),
        seeds=seeds,
        budget=budget_evals,
        target=target,
        on_run=note,
        **settings,
    )
    if as_json:
        print_json({k: v for k, v in result.items() if k != "runs"})
        return
    text = markdown_table(result)
    print(
        f"{result['engine']} on {result['tasks']}, space {result['space']}: {budget_evals} evaluations x {seeds} "
        "seeds (median over seeds)\n"
    )
    print(text)
    (out_dir / "compare.md").write_text(text)
    out.print(f"runs and compare.json, compare.md in {out_dir}", highlight=False, soft_wrap=True)


TransferAlignOpt = Annotated[
    bool,
    typer.Option(
        "--align-clock/--no-align-clock",
        help="Also score each test task with its own recording clock aligned: its command delay estimated "
        "from its recordings with the tuned physics held fixed (so the transfer measures the physics, not "
        "the clocks).",
    ),
]
TransferOutOpt = Annotated[Path, out_option("Folder for the tuning run (OUT/run) and transfer.json.")]


@run_options(
    "engine",
    "data",
    "space",
    "optimizer",
    "refine",
    "seed",
    "workers",
    "max_seconds",
    "max_generations",
    "max_evaluations",
    "only",
    "eval_timeout",
    "reference",
    "repeats",
    "project",
    defaults=TRANSFER_DEFAULTS,
    options={"space": SpaceOpt, "optimizer": OptimizerOpt},
)
def transfer(
    train: Annotated[str, typer.Option(help="Tasks to tune on together (comma-separated).")] = "single,cube",
    test: Annotated[str, typer.Option(help="Unseen tasks to evaluate the tuned parameters on.")] = "double",
    test_data: Annotated[
        Path | None, typer.Option(help="Data root of the test tasks (default: --data).", callback=path)
    ] = None,
    out_dir: TransferOutOpt = Path("runs/transfer"),
    align_clock: TransferAlignOpt = True,
    quiet: QuietOpt = False,
    as_json: JsonOpt = False,
    **settings: Any,
) -> None:
    """Tune on some tasks, then test the tuned parameters on tasks never tuned on, against generic.

    The tuning run is an ordinary run (resumable; OUT/run/best_params.json works
    with `simtune evaluate --params-file` on any task). Running the command again
    resumes or reuses it.

    Example: simtune transfer --engine mujoco --train single,cube --test double --data DATA --max-evaluations 500
    """
    from simtune import api

    result = api.transfer(
        train=train,
        test=test,
        out=out_dir,
        test_data=test_data,
        align_clock=align_clock,
        show_progress=not quiet and not as_json,
        **settings,
    )
    if as_json:
        print_json({k: v for k, v in result.items() if k != "params"})
        return
    out.print(
        _transfer_table(
            result,
            f"{settings['engine']}: tuned on {train} ({settings['space']}, {settings['optimizer']}), tested on {test}",
        )
    )
    for r in result["tasks"]:
        if r["delay_s"] is not None:
            out.print(
                f"clock aligned: {r['task']}'s command delay {r['delay_s']:.2f} s, estimated from its recordings "
                f"with the tuned physics held fixed: tuned fitness {r['tuned']:.4f} -> {r['tuned_aligned']:.4f} "
                "(--no-align-clock leaves clocks alone)"
            )
    out.print(f"tuned parameters: {result['best_params_file']}; result: {out_dir / 'transfer.json'}")


def _transfer_table(result: dict, title: str):
    table = text_table(
        title,
        ("task", "set", "generic", "tuned", "change", "wrist [m]", "object [m]"),
        right=("generic", "tuned", "change", "wrist [m]", "object [m]"),
    )
    for r in result["tasks"]:
        table.add_row(
            r["task"],
            r["role"],
            fmt(r["generic"]),
            fmt(r["tuned"]),
            f"{r['change'] * 100:+.0f} %",
            fmt(r["tuned_wrist"]),
            fmt(r["tuned_object"]),
        )
    for role, t in result["totals"].items():
        table.add_row(
            f"[bold]all {role}[/]", role, fmt(t["generic"]), fmt(t["tuned"]), f"{t['change'] * 100:+.0f} %", "", ""
        )
        if "tuned_aligned" in t:
            table.add_row(
                f"[bold]all {role}, clock aligned[/]",
                role,
                fmt(t["generic"]),
                fmt(t["tuned_aligned"]),
                f"{t['change_aligned'] * 100:+.0f} %",
                "",
                "",
            )
    return table


GeneraliseOutOpt = Annotated[
    Path,
    out_option(
        "Folder for the study's runs (`OUT/alone/<task>`, `OUT/joint`, `OUT/without/<task>`) and generalise.json; "
        "finished runs are reused, unfinished ones resumed."
    ),
]


# every run setting but --validate: the study holds tasks out itself (leave-one-task-out)
@run_options(*(name for name in setting_options() if name != "validate"), defaults={"tasks": "single,cube"})
def generalise(
    out_dir: GeneraliseOutOpt = Path("runs/generalise"),
    quiet: QuietOpt = False,
    as_json: JsonOpt = False,
    **settings: Any,
) -> None:
    """Is the tuned simulator one of the robot or of the task it saw? Tune each task alone, all together and
    leaving each out; one table of each task's fit against its floor.

    For each task: its floor (the real arm against its own repeats), its fit tuned alone, its part of the fit
    tuned on every task together (joint / alone: the joint-fit penalty, 1 where one parameter set is right for
    every task) and its fit tuned on the other tasks only, its own clock aligned (held out: a motion never
    recorded). Every run is an ordinary run: `simtune report OUT/joint`, `simtune evaluate --params-file`.

    Example: simtune generalise --engine mujoco --task single,cube --data DATA --seed 0 --workers 2
    """
    from simtune import api

    def on_run(number: int, count: int, label: str, folder: Path) -> None:
        if not as_json:
            out.print(f"[{number}/{count}] {label}: {folder}", highlight=False, soft_wrap=True)

    result = api.generalise(out=out_dir, show_progress=not quiet and not as_json, on_run=on_run, **settings)
    if as_json:
        print_json(result)
        return
    print_whole_table(
        f"{result['engine']}: {', '.join(result['tasks'])} ({result['space']}, {result['optimizer']}, "
        f"seed {result['seed']}); each fitness (x its floor)",
        GENERALISE_HEADERS,
        generalise_rows(result),
    )
    out.print(
        f"joint-fit penalty (median over tasks) {result['joint_penalty']:.2f}, held out over alone "
        f"{result['transfer']:.2f} (1: one simulator of the robot fits every task as well as each alone)",
        highlight=False,
        soft_wrap=True,
    )
    out.print(f"result: {out_dir / 'generalise.json'}", highlight=False, soft_wrap=True)


def generalise_rows(result: dict) -> list[list[str]]:
    """The study's table as text, a row per task: its floor, its fit alone, joint and held out (each with its
    ratio to the floor), the joint-fit penalty, held out over alone, and the tasks it was held out from."""

    def cell(fitness: float, over_floor: float | None) -> str:
        return fmt(fitness) if over_floor is None else f"{fmt(fitness)} ({over_floor:.1f}x)"

    return [
        [
            r["task"],
            "none (1 repeat)" if r["floor"] is None else fmt(r["floor"]),
            cell(r["alone"]["fitness"], r["alone_over_floor"]),
            cell(r["joint"]["fitness"], r["joint_over_floor"]),
            f"{r['penalty']:.2f}",
            cell(r["held_out"]["fitness"], r["held_out_over_floor"]),
            f"{r['transfer']:.2f}",
            ", ".join(r["held_out_from"]),
        ]
        for r in result["rows"]
    ]


#: the study table's headers: (x floor) follows each fitness
GENERALISE_HEADERS = ("task", "floor", "alone", "joint", "joint/alone", "held out", "held/alone", "tuned on")


SamplesOpt = Annotated[
    int,
    typer.Option(
        min=2,
        help="morris: trajectories (N (D+1) evaluations); sobol: base samples, a power of two (N (D+2) evaluations).",
    ),
]
MethodOpt = Annotated[
    str, typer.Option(help="morris (elementary effects, cheap screening) or sobol (variance shares S1 and ST).")
]
SensitivityOutOpt = Annotated[Path, out_option("Folder for sensitivity.json/.csv/.md/.png and the evaluation cache.")]


def sensitivity(
    engine: EngineOpt = "mujoco",
    task: TaskOpt = "cube",
    data: DataOpt = None,
    space: SpaceOpt = "extended",
    samples: SamplesOpt = 10,
    method: MethodOpt = "morris",
    seed: Annotated[int, seed_option("Seed of the sampling.")] = 0,
    workers: WorkersOpt = 1,
    only: OnlyOpt = None,
    eval_timeout: EvalTimeoutOpt = 600.0,
    out_dir: SensitivityOutOpt = Path("runs/sensitivity"),
    as_json: JsonOpt = False,
) -> None:
    """Global sensitivity of the fitness to each parameter (SALib Morris or Sobol), most influential first.

    Evaluations run through the same process pool as tuning and are cached in
    OUT/sensitivity.sqlite. `simtune report` picks up OUT/sensitivity.json when
    OUT is under or next to its input folders.

    Example: simtune sensitivity --engine mujoco --task cube --data DATA --samples 20 --workers 2 --out runs/sens
    """
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from simtune import api
    from simtune.studies.sensitivity import sensitivity_table

    total = api.sensitivity_evaluations(engine, space, method, samples, only_names(only))
    columns = (TextColumn("[bold]sensitivity[/]"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn())
    with Progress(*columns, console=err, disable=as_json) as bar:
        job = bar.add_task("evaluate", total=total)
        result = api.sensitivity(
            engine,
            task,
            out=out_dir,
            data=data,
            space=space,
            samples=samples,
            method=method,
            only=only_names(only),
            seed=seed,
            workers=workers,
            eval_timeout=eval_timeout,
            on_evaluation=lambda score, reused: bar.advance(job),
        )
    if as_json:
        print_json(result)
        return
    table = sensitivity_table(result)
    view = text_table(
        table.title,
        [col.name for col in table.columns],
        right=[col.name for col in table.columns if col.name != "parameter"],
    )
    for row in table.rows:
        view.add_row(*(table.cell(v, c) for v, c in zip(row, table.columns)))
    out.print(view)
    out.print(table.note, highlight=False, markup=False)
    out.print(f"{result['new_evaluations']} new evaluations; files in {out_dir}: sensitivity.json, .csv, .md, .png")
