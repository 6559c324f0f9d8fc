"""Worker processes and the user's script: refuse, in one line, to start processes that would run it again.

simtune's worker processes are spawned (engines hold native handles that must not be shared through fork),
and a spawned process imports the main script again before it takes any work: a script that calls
simtune at its top level, outside ``if __name__ == "__main__":``, would start the same tune again in
every worker.  Python's own check then fails inside the worker, where the parent cannot see it: the pool
reports its workers expired, or - when what is sent to a worker is larger than a pipe holds (a real
recording's objective is) - the parent waits for ever on a worker that has died.  So the parent looks
first: where the call comes from the main script's top level, it says which line to guard.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

from simtune.errors import SimtuneError


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
            f"{path}, line {line}: {what} would run this script again from its top (worker processes are "
            f'spawned): put the simtune call under `if __name__ == "__main__":`, or use one worker'
        )
