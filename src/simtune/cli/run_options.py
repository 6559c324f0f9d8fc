"""The run settings as command-line options, derived from :class:`simtune.run_config.RunConfig`, the one list.

Each field of ``RunConfig`` that a user sets from the command line has one option here (its flag and help), in
:func:`_run_settings`'s signature; its default is ``RunConfig``'s (None where ``RunConfig`` resolves an empty
value: the defaults --paper-exact changes).  A command takes a chosen set of them with :func:`run_options` and
receives them in its ``**settings``, named as ``RunConfig`` names them, to hand to :mod:`simtune.api` as they
are: no command repeats the list, and none keeps a default of its own except those its study declares
(:data:`simtune.run_config.TRANSFER_DEFAULTS`, :data:`simtune.run_config.COMPARE_DEFAULTS`).
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Mapping
from typing import Annotated, Any, TypeVar

import typer

from simtune.cli.options import (
    OPTIMIZER_HELP,
    DataOpt,
    EngineOpt,
    EvalTimeoutOpt,
    JointTopicOpt,
    KeepInactiveOpt,
    KeepRepeatsOpt,
    LoadingOpt,
    MaxEvalsOpt,
    OnlyOpt,
    ProjectOpt,
    ReferenceOpt,
    RepeatsOpt,
    SeedOpt,
    TargetsOpt,
    TaskOpt,
    TuneSpaceOpt,
    WeightsOpt,
    WorkersOpt,
    max_generations_option,
    max_seconds_option,
    not_negative,
    refine_option,
)
from simtune.run_config import DEFAULTS

#: RunConfig's fields no command-line option sets: the API sets them (docs/api.md); a run made from the command
#: line takes their defaults
API_ONLY = ("task_delays", "residuals")

TuneOptimizerOpt = Annotated[
    str | None,
    typer.Option("--optimizer", help=f"Default auto (de with --paper-exact). {OPTIMIZER_HELP}", show_default=False),
]
RefineOpt = Annotated[
    bool,
    refine_option(
        "Afterwards, polish the best point with bounded least squares (SciPy) on the per-sample residuals; its "
        "evaluations are stored too."
    ),
]
ThreadsOpt = Annotated[
    bool,
    typer.Option(
        "--threads",
        help="Evaluate on --workers threads of this process instead of worker processes (MuJoCo; the same "
        "results; no --eval-timeout and no crash isolation).  Without it MuJoCo runs on threads until a large "
        "batch would take its simulation past 2 s, then on worker processes, which are faster on large batches "
        "(benchmarks/batch_threads.py).",
    ),
]
MaxSecondsOpt = Annotated[
    float | None,
    max_seconds_option(
        "A cap on the command's wall time [s]: the start-up (reading the recordings, the inactive-parameter probe) "
        "counts, the search stops at the first batch past it, and the uncertainty after the search is left out "
        "where the cap cannot hold it (`simtune uncertainty RUN` computes it). Without a cap auto stops when "
        "converged."
    ),
]
MaxGenerationsOpt = Annotated[
    int,
    max_generations_option(
        "Stop after this many generations (bo and random: D evaluations count as one; auto: each batch, a DE "
        "generation, a least-squares trial point or a Jacobian)."
    ),
]
TargetFitnessOpt = Annotated[
    float | None, typer.Option(help="Stop once the best fitness reaches this.", callback=not_negative)
]
#: the flag switches pruning off; without it RunConfig's default (on) holds
PruneOpt = Annotated[
    bool,
    typer.Option(
        " /--no-prune",
        help="Simulate every trial to the end (by default a DE trial that can no longer beat its parent stops "
        "early: same search, its stored fitness a lower bound).",
        show_default=False,
    ),
]
PriorOpt = Annotated[
    float | None,
    typer.Option(
        "--prior",
        help="Prior strength (a maximum a posteriori fit): each tuned parameter's distance from its generic value, "
        "over its kind's width (docs/parameters.md, Priors), costs this many noise floors per width squared, so that "
        "a task cannot bend what it barely sees. Default none (0 too): plain least squares. The fitness shown is "
        "the data's, the prior's part beside it.",
        callback=not_negative,
        show_default=False,
    ),
]
ValidateOpt = Annotated[
    str,
    typer.Option(
        "--validate",
        help="Hold tasks out of the search and score them with its best parameters afterwards: N, the last N of "
        "the tasks named (the last N episodes of a dataset's), or a comma-separated list of task names or episode "
        "numbers. The held-out fitness per task is printed beside the tuned tasks' and stored (--json: "
        "validation_fitness).",
        show_default=False,
    ),
]
PaperExactOpt = Annotated[
    bool,
    typer.Option(
        "--paper-exact",
        help="Differential evolution exactly as the paper ran SciPy: immediate updating, SciPy's polish, "
        "one worker, no pruning, the paper's whole parameter list (--space shared or individual; "
        "parameters the engine lacks are kept, without effect).",
    ),
]


def _run_settings(
    engine: EngineOpt,
    tasks: TaskOpt,
    data: DataOpt,
    space: TuneSpaceOpt,
    optimizer: TuneOptimizerOpt,
    refine: RefineOpt,
    seed: SeedOpt,
    workers: WorkersOpt,
    threads: ThreadsOpt,
    max_seconds: MaxSecondsOpt,
    max_generations: MaxGenerationsOpt,
    max_evaluations: MaxEvalsOpt,
    target_fitness: TargetFitnessOpt,
    prune: PruneOpt,
    only: OnlyOpt,
    keep_inactive: KeepInactiveOpt,
    eval_timeout: EvalTimeoutOpt,
    paper_exact: PaperExactOpt,
    weights: WeightsOpt,
    joint_topic: JointTopicOpt,
    project: ProjectOpt,
    reference: ReferenceOpt,
    repeats: RepeatsOpt,
    keep_repeats: KeepRepeatsOpt,
    targets: TargetsOpt,
    prior: PriorOpt,
    loading: LoadingOpt,
    validate: ValidateOpt,
) -> None:
    """Every run setting's option, in the order ``--help`` lists them (the signature is the table)."""


def cli_default(name: str) -> Any:
    """A run setting's default on the command line: RunConfig's, None where RunConfig resolves an empty value
    (the option then shows no default: --paper-exact chooses it)."""
    default = DEFAULTS[name]
    return None if default == "" else default


def setting_options() -> dict[str, inspect.Parameter]:
    """The run settings' options by RunConfig name, each with its flag, help and command-line default."""
    template = inspect.signature(_run_settings, eval_str=True).parameters
    return {
        name: p.replace(kind=inspect.Parameter.KEYWORD_ONLY, default=cli_default(name)) for name, p in template.items()
    }


Command = TypeVar("Command", bound=Callable[..., Any])


def run_options(
    *names: str, defaults: Mapping[str, Any] | None = None, options: Mapping[str, Any] | None = None
) -> Callable[[Command], Command]:
    """A command takes the run settings ``names`` (all with none named) as options, before its own, with
    RunConfig's defaults except a study's; it receives them in its ``**settings`` by RunConfig's names.

    Args:
        names: RunConfig field names; none: every setting the command line has.
        defaults: a study's own defaults for some of them (its declared constants).
        options: the option (an ``Annotated`` alias) of a setting whose help a study words otherwise (its
            defaults), instead of ``tune``'s.

    Returns:
        A decorator that gives the command its full signature (Typer reads ``__signature__``).
    """
    known = setting_options()
    defaults, options = dict(defaults or {}), dict(options or {})
    chosen = list(names) or list(known)
    unknown = [n for n in [*chosen, *defaults, *options] if n not in known]
    if unknown:  # a programming error in a command's declaration, caught when the CLI is imported
        raise ValueError(f"not run settings: {unknown}")
    added = [
        known[n].replace(default=defaults.get(n, known[n].default), annotation=options.get(n, known[n].annotation))
        for n in chosen
    ]

    def decorate(command: Command) -> Command:
        own = inspect.signature(command, eval_str=True).parameters.values()
        kept = [p.replace(kind=inspect.Parameter.KEYWORD_ONLY) for p in own if p.kind is not p.VAR_KEYWORD]
        setattr(command, "__signature__", inspect.Signature([*added, *kept]))  # noqa: B010 (not a declared attribute)
        return command

    return decorate
