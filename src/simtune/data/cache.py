"""A cache of what a run computes from its inputs before it searches, keyed by content (issue 44, start-up).

A warm start of ``simtune tune`` read and aligned the same recordings, searched the same command delay and
scored the same generic point as the run before it: seconds of work whose result is fixed by its inputs.
:func:`cached` keeps such a result in a file under :func:`simtune.common.cache.cache_root`
(``$SIMTUNE_CACHE_DIR``, the folder the inactive-parameter probe caches in) and reads it back on the next start.

The key (:func:`content_key`) is a SHA-256 of what the result depends on, as the caller states it (the
recordings' bytes, the task and its robot by content, the engine's version ...), and of simtune's own source
code and the versions of Python, NumPy and SciPy (:func:`code_digest`): any edit to simtune, or another NumPy,
makes every entry a miss, so a stale entry can never stand in for a result the code would now compute
differently.  The cost of a miss is the computation it would have run anyway.

The warnings the computation raised (a repeat left out, a late clock) are kept with the entry and raised again
on every read, from where they were raised first: a cached start says what an uncached one says.

Entries are pickles of the caller's values, written atomically; an unreadable or foreign entry is a miss, a
folder that cannot be written leaves the result uncached.  They hold the caller's objects (NumPy arrays,
dataclasses) exactly: a value read back is bit for bit the one computed.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import pickle
import platform
import sys
import tempfile
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from simtune.common.cache import cache_root

#: Changes whenever an entry's layout changes, so that no entry of an older layout is read.
LAYOUT = 1
#: Entries kept of each kind: writing one removes the least recently used beyond this many, so that the entries of
#: older code and older recordings do not pile up (a ``cube`` reference is a quarter of a megabyte).
MAX_ENTRIES = 32

T = TypeVar("T")


@functools.cache
def code_digest() -> str:
    """SHA-256 of every Python source file of the simtune package (names and bytes) and of the versions of Python,
    NumPy and SciPy it runs on (their arithmetic makes the references and the scores), read once per process."""
    import scipy  # the package alone: its modules are imported where they are used

    root = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256(f"{platform.python_version()} {np.__version__} {scipy.__version__}".encode())
    for path in sorted(root.rglob("*.py")):
        digest.update(path.relative_to(root).as_posix().encode() + b"\0")
        digest.update(path.read_bytes())
    return digest.hexdigest()


def _plain(value: Any) -> Any:
    """What :func:`content_key` hashes for a value JSON cannot write: an array by its dtype, shape and bytes
    (its text would elide the middle of a large one), anything else by its ``repr``."""
    if isinstance(value, np.ndarray):
        data = np.ascontiguousarray(value)
        return ["ndarray", data.dtype.str, list(data.shape), hashlib.sha256(data.tobytes()).hexdigest()]
    if isinstance(value, np.generic):
        return repr(value.item())
    return repr(value)


def content_key(what: Any) -> str:
    """The key of a result that depends on ``what`` (plain values, arrays, paths) and on simtune's code."""
    text = json.dumps([LAYOUT, code_digest(), what], sort_keys=True, default=_plain)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def value_digest(value: Any) -> str:
    """SHA-256 of ``value`` as pickled: for a result (a reference of arrays) that a later key depends on."""
    return hashlib.sha256(pickle.dumps(value, protocol=4)).hexdigest()


@dataclass(frozen=True)
class _Warned:
    """One warning the computation raised, as :func:`warnings.warn_explicit` raises it again."""

    category: type[Warning]
    message: str
    filename: str
    lineno: int

    def again(self) -> None:
        # with the registry of the file it names, as a warning raised there has: the "default" action then shows
        # it once per location in a process, not on every read (an API user's loop of evaluations)
        registry = _REGISTRIES.setdefault(self.filename, {})
        warnings.warn_explicit(self.message, self.category, self.filename, self.lineno, registry=registry)


#: the warning registries of the files cached warnings name (file -> what :func:`warnings.warn_explicit` records)
_REGISTRIES: dict[str, dict] = {}


def cached(kind: str, what: Any, compute: Callable[[], T], valid: Callable[[T], bool] | None = None) -> T:
    """``compute()``, or what it returned before for the same ``what`` (see the module's notes).

    Args:
        kind: the cache's sub-folder (``references``, ``delay`` ...).
        what: everything the result depends on besides simtune's code, as plain values.
        compute: makes the result; its warnings are kept and raised again on every read.
        valid: whether a value read back still holds (files it points to that the key cannot cover); one that
            does not is computed again and replaced.

    Returns:
        The result, computed now or read back.
    """
    path = cache_root() / kind / f"{content_key(what)}.pickle"
    entry = _read(path)
    if entry is not None and valid is not None and not valid(entry[0]):
        entry = None
    if entry is None:
        caller = sys._getframe(1)
        entry = _computed(compute, (caller.f_code.co_filename, caller.f_lineno))
        _write(path, entry)
        _prune(path.parent)
    else:
        _used(path)
    value, said = entry
    for warned in said:
        warned.again()
    return value


def _computed(compute: Callable[[], T], caller: tuple[str, int]) -> tuple[T, list[_Warned]]:
    """``compute()`` and the warnings it raised.  Every one is recorded, whatever the filters say now, and raised
    again later through them: the entry must hold one that a filter hides in this process (a warning shown once)
    for the next process.  A computation that fails raises its warnings, then its error, as it would uncached.

    A warning whose ``stacklevel`` names the computation's caller would name this module (the frame that calls
    ``compute``): it names ``caller`` (the file and line that called :func:`cached`) instead."""
    caught: list[warnings.WarningMessage] = []

    def said(w: warnings.WarningMessage) -> _Warned:
        here = Path(w.filename).resolve() == Path(__file__).resolve()
        filename, lineno = caller if here else (w.filename, w.lineno)
        return _Warned(w.category, str(w.message), filename, lineno)

    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            value = compute()
    except BaseException:
        for w in caught:
            said(w).again()
        raise
    return value, [said(w) for w in caught]


def _read(path: Path) -> tuple[Any, list[_Warned]] | None:
    try:
        with open(path, "rb") as fh:
            entry = pickle.load(fh)
    except Exception:  # none yet, or a truncated, foreign or outdated entry: a miss, never an error
        return None
    if not (isinstance(entry, tuple) and len(entry) == 2 and isinstance(entry[1], list)):
        return None
    return entry


def _write(path: Path, entry: tuple[Any, list[_Warned]]) -> None:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, temp = tempfile.mkstemp(dir=path.parent, prefix=path.stem, suffix=".tmp")
        try:
            with os.fdopen(fd, "wb") as fh:
                pickle.dump(entry, fh, protocol=4)
            os.replace(temp, path)  # a reader sees the whole entry or none
        except BaseException:
            os.unlink(temp)
            raise
    except (OSError, pickle.PicklingError, TypeError, AttributeError):
        pass  # a cache that cannot be written only costs the next start the same work again


def _used(path: Path) -> None:
    """Mark an entry as read now: :func:`_prune` removes the least recently used first."""
    try:
        os.utime(path)
    except OSError:
        pass


def _prune(folder: Path) -> None:
    """Remove the least recently used entries of ``folder`` beyond :data:`MAX_ENTRIES`."""
    try:
        entries = sorted(folder.glob("*.pickle"), key=lambda p: p.stat().st_mtime_ns)
        for old in entries[: max(0, len(entries) - MAX_ENTRIES)]:
            old.unlink(missing_ok=True)
    except OSError:
        pass  # another process pruned or wrote meanwhile: the next write prunes again
