"""The ``simtune`` command line.

Every command explains itself with ``--help``.  Errors in the user's input
print one line (``error: ...``) and exit with status 2; warnings about data
that was still usable print ``warning: ...`` and the command goes on.

Each command is a thin call into :mod:`simtune.api`, in one module per family (run, data, study, grid,
information, export and report commands); the options several share are declared once in :mod:`simtune.cli.options`.
"""

from __future__ import annotations

import functools
import sys
import warnings

import typer
from rich.markup import escape

from simtune.cli import (
    data_commands,
    design_command,
    export_command,
    grid_command,
    info_commands,
    init_command,
    report_command,
    run_commands,
    study_commands,
)
from simtune.cli.output import err, show_warning
from simtune.errors import SimtuneError

app = typer.Typer(
    help="Tune physics-engine parameters until a simulated robot reproduces its motion-capture recordings.\n\n"
    "Start with `simtune demo`; then `simtune evaluate` and `simtune tune` on your own recordings "
    "(--data ROOT, one sub-folder of recordings per task, e.g. ROOT/cube/*.tsv).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    # help texts carry units in brackets ([s], [mm]) and extras ('simtune[opt]'): Markdown keeps them
    rich_markup_mode="markdown",
)

#: every command, in the order `simtune --help` lists them
COMMANDS = (
    run_commands.evaluate,
    run_commands.tune,
    run_commands.uncertainty,
    data_commands.check,
    run_commands.resume,
    info_commands.demo,
    grid_command.grid,
    info_commands.engines,
    info_commands.tasks,
    info_commands.params,
    data_commands.synth,
    init_command.init,
    study_commands.compare,
    study_commands.transfer,
    study_commands.generalise,
    study_commands.sensitivity,
    design_command.design,
    export_command.export,
    report_command.report,
)

#: the exception class of the Click that Typer runs on (Typer may bundle its own copy)
_CLICK_ERROR: type[Exception] = next(c for c in typer.BadParameter.__mro__ if c.__name__ == "ClickException")


def _say_interrupted(exc: BaseException) -> None:
    run_dir = getattr(exc, "run_dir", None)
    message = "interrupted" if run_dir is None else f"interrupted - resume with: simtune resume {run_dir}"
    err.print(message, markup=False, highlight=False, soft_wrap=True)


def _interruptible(command):
    """Ctrl-C inside a command: say how to resume and exit 130 (Typer itself would exit 130 without a word)."""

    @functools.wraps(command)
    def run(*args, **kwargs):
        try:
            return command(*args, **kwargs)
        except KeyboardInterrupt as exc:
            _say_interrupted(exc)
            if kwargs.get("as_json"):  # a script reads stdout: it gets its one object, stop_reason "interrupted"
                _print_interrupted_json(exc)
            raise SystemExit(130) from None

    return run


def _print_interrupted_json(exc: BaseException) -> None:
    """``--json``'s object for a run stopped by Ctrl-C: why, where it is, how to go on, what it has so far."""
    from simtune.cli.output import print_json

    run_dir = getattr(exc, "run_dir", None)
    payload: dict = {"stop_reason": "interrupted", "run_dir": None if run_dir is None else str(run_dir)}
    if run_dir is not None:
        payload["resume"] = f"simtune resume {run_dir}"
        try:
            from simtune.runs import read_run_record

            record = read_run_record(run_dir)
            payload["evaluations"] = record.evaluations
            payload["fitness"] = None if record.best is None else record.best["score"]["fitness"]
        except (SimtuneError, OSError, ValueError):
            pass  # the run folder cannot be read now: where it is and how to resume still stand
    print_json(payload)


for _command in COMMANDS:
    app.command()(_interruptible(_command))


def _usage_error(exc) -> int:
    """A command-line mistake (an option's value, an unknown option) as one line; its exit status."""
    ctx = getattr(exc, "ctx", None)
    message = exc.format_message()
    if not message and ctx is not None:  # `simtune` alone: the help is the answer
        ctx.get_help()
        return exc.exit_code
    command = f"simtune {ctx.info_name} --help" if ctx is not None and ctx.parent is not None else "simtune --help"
    err.print(f"[red]error:[/] {escape(message)} (see `{command}`)", highlight=False, soft_wrap=True)
    return exc.exit_code


def main() -> None:
    warnings.showwarning = show_warning
    try:
        code = app(standalone_mode=False)
    except SimtuneError as exc:
        err.print(f"[red]error:[/] {escape(str(exc))}", highlight=False, soft_wrap=True)
        sys.exit(2)
    except _CLICK_ERROR as exc:
        sys.exit(_usage_error(exc))
    except KeyboardInterrupt as exc:  # before or after a command
        _say_interrupted(exc)
        sys.exit(130)
    sys.exit(code if isinstance(code, int) else 0)


__all__ = ["app", "main"]
