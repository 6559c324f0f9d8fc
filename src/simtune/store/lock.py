"""One writer per run folder: an OS file lock that dies with the process holding it.

``tune``, ``resume`` and each unit of a grid hold ``RUN/run.lock`` (``fcntl.flock``,
exclusive, never waited for) while they write the run; the holder writes who it
is into the file (process id, host, command line, start time), so a second
process is refused at once with one line naming the holder.  The kernel drops
the lock when its process ends in any way (exit, crash, ``kill -9``), so a lock
is never stale.  The holder removes the file when it is done (one left by a
killed process is harmless: the next holder takes it over); a process that
locked a file which was removed meanwhile lets go and tries again, so two
processes never hold two different files of one folder.

Within one process the lock is re-entrant (``resume --rescore`` and grid units
hold it around ``start_run``/``resume_run``, which take it again).
"""

from __future__ import annotations

import json
import os
import socket
import sys
import time
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from simtune.errors import SimtuneError

try:
    import fcntl
except ImportError:  # Windows: no flock; runs there are not protected against a second writer
    fcntl = None  # type: ignore[assignment]

LOCK_FILE = "run.lock"
ACQUIRE_ATTEMPTS = 5

#: lock file path -> [file descriptor, how many times this process holds it]
_HELD: dict[str, list[int]] = {}


class RunBusy(SimtuneError):
    """Another process is writing this run folder."""


def _key(run_dir: Path) -> str:
    return os.path.realpath(Path(run_dir) / LOCK_FILE)


def _command_line() -> str:
    """This process's command as the user typed it (``python -m simtune.cli`` shown as ``simtune``)."""
    argv = list(sys.argv)
    if argv and (argv[0].endswith(("simtune/cli/__main__.py", "simtune")) or argv[0] == "-m"):
        argv[0] = "simtune"
    return " ".join(argv)


def describe_holder(path: Path) -> str:
    """Who holds the lock file ``path``, from what the holder wrote into it."""
    try:
        info = json.loads(Path(path).read_text() or "{}")
    except (OSError, ValueError):
        info = {}
    if not isinstance(info, dict) or "pid" not in info:
        return "another process"
    return (
        f"process {info.get('pid')} on {info.get('host', '?')} "
        f"(`{info.get('command', '?')}`, since {info.get('started', '?')})"
    )


def _busy(run_dir: Path, path: Path) -> RunBusy:
    return RunBusy(
        f"{run_dir} is in use by {describe_holder(path)}: one process writes a run at a time; "
        "wait for it to finish or stop it"
    )


def holds(run_dir: Path) -> bool:
    """Whether this process holds the lock of ``run_dir``."""
    return _key(run_dir) in _HELD


def check_free(run_dir: Path) -> None:
    """Raise :class:`RunBusy` if another process holds ``run_dir``'s lock; creates nothing."""
    path = Path(run_dir) / LOCK_FILE
    if fcntl is None or holds(run_dir) or not path.exists():
        return
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return  # unreadable: taking the lock will say why
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        raise _busy(run_dir, path) from None
    except OSError:
        pass  # a file system without flock: taking the lock warns
    finally:
        os.close(fd)  # also drops the probe's shared lock


@contextmanager
def run_lock(run_dir: Path) -> Iterator[None]:
    """Hold ``run_dir``'s lock (the folder must exist); :class:`RunBusy` at once if another process holds it."""
    run_dir = Path(run_dir)
    key = _key(run_dir)
    if key in _HELD:
        _HELD[key][1] += 1
        try:
            yield
        finally:
            _HELD[key][1] -= 1
        return
    fd = _acquire(run_dir)
    if fd is not None:
        _HELD[key] = [fd, 1]
    try:
        yield
    finally:
        if fd is not None:
            del _HELD[key]
            (run_dir / LOCK_FILE).unlink(missing_ok=True)  # while still holding it: see _acquire
            os.close(fd)


def _acquire(run_dir: Path) -> int | None:
    """The locked file descriptor of ``run_dir/run.lock``, holder details written; None where flock is unsupported."""
    path = run_dir / LOCK_FILE
    if fcntl is None:
        return None
    while True:
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise SimtuneError(f"cannot lock run folder {run_dir}: {exc.strerror}") from None
        try:
            _lock(fd)
        except BlockingIOError:
            os.close(fd)
            raise _busy(run_dir, path) from None
        except OSError as exc:
            os.close(fd)
            warnings.warn(
                f"{run_dir}: the file system cannot lock files ({exc.strerror}); "
                "make sure no other simtune process writes this run",
                stacklevel=4,
            )
            return None
        if _still_linked(fd, path):
            break
        os.close(fd)  # its holder removed it after we opened it: lock the file that is there now
    holder = {
        "pid": os.getpid(),
        "host": socket.gethostname(),
        "command": _command_line(),
        "started": time.strftime("%Y-%m-%d %H:%M:%S"),
    }
    os.ftruncate(fd, 0)
    os.pwrite(fd, (json.dumps(holder) + "\n").encode(), 0)
    return fd


def _lock(fd: int) -> None:
    """Exclusive flock without waiting (BlockingIOError: held elsewhere)."""
    for attempt in range(ACQUIRE_ATTEMPTS):
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return
        except BlockingIOError:
            # another process's check_free holds a shared lock for an instant; a writer holds it for long
            if attempt == ACQUIRE_ATTEMPTS - 1:
                raise
            time.sleep(0.05)


def _still_linked(fd: int, path: Path) -> bool:
    """Whether ``path`` still names the file open as ``fd``."""
    try:
        named = os.stat(path)
    except FileNotFoundError:
        return False
    opened = os.fstat(fd)
    return (named.st_ino, named.st_dev) == (opened.st_ino, opened.st_dev)
