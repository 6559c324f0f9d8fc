"""Worker processes and the user's script: refuse, in one line, to start processes that would run it again.

simtune's worker processes share no engine with their parent (engines hold native handles that must not be
shared through fork): they are spawned, or forked from a clean fork server (:func:`worker_context`), and either
way a worker imports the main script again before it takes any work: a script that calls
simtune at its top level, outside ``if __name__ == "__main__":``, would start the same tune again in
every worker.  Python's own check then fails inside the worker, where the parent cannot see it: the pool
reports its workers expired, or - when what is sent to a worker is larger than a pipe holds (a real
recording's objective is) - the parent waits for ever on a worker that has died.  So the parent looks
first: where the call comes from the main script's top level, it says which line to guard.
"""

from __future__ import annotations

import ast
import multiprocessing
import os
import signal
import sys
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from multiprocessing.context import BaseContext
from pathlib import Path

from simtune.errors import RobotWarning, SimtuneError


def unguarded_call(source: str, line: int) -> bool:
    """Whether ``line`` of the module ``source`` runs at import: in a top-level statement that is not an
    ``if __name__ == "__main__":`` block (or in that block's ``else``)."""
    for node in ast.parse(source).body:
        if node.lineno <= line <= (node.end_lineno or node.lineno):
            if not (isinstance(node, ast.If) and _is_main_test(node.test)):
                return True
            return not any(s.lineno <= line <= (s.end_lineno or s.lineno) for s in node.body)
    return False  # a line no statement holds (a comment): nothing runs there


def _is_main_test(test: ast.expr) -> bool:
    """``__name__ == "__main__"``, either way round."""
    if not (isinstance(test, ast.Compare) and len(test.ops) == 1 and isinstance(test.ops[0], ast.Eq)):
        return False
    sides = [test.left, test.comparators[0]]
    names = [s.id for s in sides if isinstance(s, ast.Name)]
    values = [s.value for s in sides if isinstance(s, ast.Constant)]
    return names == ["__name__"] and values == ["__main__"]


def main_call_site() -> tuple[Path, int] | None:
    """The main script's file and the line of its top level that led here, where a spawned process would
    run that script again; None where it would not (an interactive session, ``python -c``, a notebook)."""
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if main is None or not path:
        return None
    # what multiprocessing.spawn runs again: a module by its name, unless it is a package's __main__; else the
    # script by its path, unless it is named __main__ or ipython
    name = getattr(main.__spec__, "name", None)
    if (name or Path(path).stem) in ("__main__", "ipython") or (name or "").endswith(".__main__"):
        return None
    frame = sys._getframe(1)
    while frame is not None and not (frame.f_globals is main.__dict__ and frame.f_code.co_name == "<module>"):
        frame = frame.f_back  # type: ignore[assignment]
    return (Path(path), frame.f_lineno) if frame is not None else None


def check_main_guarded(what: str) -> None:
    """Raise a one-line SimtuneError where starting ``what`` (worker processes) would run the user's script again."""
    site = main_call_site()
    if site is None:
        return
    path, line = site
    try:
        unguarded = unguarded_call(path.read_text(encoding="utf-8"), line)
    except (OSError, SyntaxError, ValueError, UnicodeDecodeError):
        return  # a main module we cannot read is not one we can point into
    if unguarded:
        raise SimtuneError(
            f"{path}, line {line}: {what} would run this script again from its top (each worker process "
            f'imports it again): put the simtune call under `if __name__ == "__main__":`, or use one worker'
        )


#: what the fork server imports once, before it forks any worker: what every worker imports to run an evaluation
#: (the evaluator pulls in simtune's objective, fitness and engine registry, NumPy and SciPy; MuJoCo is the default
#: engine), with Ctrl-C ignored meanwhile (:mod:`simtune.worker_preload`).  Only imports: no engine is built
#: in the server, so a forked worker holds no native handle of another.
PRELOAD = ["simtune.worker_preload"]


def worker_context() -> BaseContext:
    """How simtune starts its worker processes: forked from a fork server where there is one (Linux), else spawned.

    A spawned worker starts a new interpreter and imports simtune, NumPy, SciPy and MuJoCo (about a second, per
    worker and per pool); the fork server imports them once (:data:`PRELOAD`) and forks each worker from that clean
    process, so a pool's workers start in milliseconds.  Either way a worker runs the main script again (as
    spawn does: :func:`check_main_guarded` applies to both) and shares no engine with the process that asked for
    it.  Other systems (macOS, where forking after some system libraries is unsafe; Windows, which has no fork)
    spawn.  :func:`start_worker_server` starts the server early, where a caller has other work to overlap it with.
    """
    if not sys.platform.startswith("linux") or "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(PRELOAD)
    return context


def start_worker_server() -> None:
    """Start the fork server of :func:`worker_context` now (where it has one), so that its imports run while this
    process does other work; a server already running is kept."""
    if worker_context().get_start_method() == "forkserver":
        from multiprocessing import forkserver

        with sigint_blocked():  # the server's workers inherit it (see sigint_blocked)
            forkserver.ensure_running()


def adopt_environment(environ: dict[str, str]) -> None:
    """In a worker: take ``environ``, its parent's environment when it asked for the worker.  A spawned worker
    inherits it; a forked one would have the fork server's, as it was when the server started."""
    os.environ.clear()
    os.environ.update(environ)


def leave_robot_notes_to_parent() -> None:
    """In a worker: let the robot's notes (:class:`RobotWarning`, e.g. DART's missing material files) go unsaid.
    Every worker builds the same robot in its engine again; the parent, which loaded it and built its engine
    before asking for workers, has said each note once, and a worker would say it again in Python's two-line
    format, once per worker."""
    warnings.filterwarnings("ignore", category=RobotWarning)


@contextmanager
def sigint_blocked() -> Iterator[None]:
    """Hold back Ctrl-C in this thread for a moment; a Ctrl-C meanwhile arrives when it ends.

    The pool's threads, which start worker processes later, inherit the blocked signal from the thread that starts
    them, so a Ctrl-C while a worker is still starting never reaches it: the coordinator alone handles Ctrl-C and
    stops the pool.  The fork server, an interpreter started anew, does not keep the mask (measured: an empty
    ``SigBlk``): it ignores SIGINT during its imports instead (:mod:`simtune.worker_preload`).
    """
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)
