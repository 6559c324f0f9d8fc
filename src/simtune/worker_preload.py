"""What the fork server of the worker processes imports before it forks any worker (``spawn_guard.PRELOAD``):
what every worker imports to run an evaluation, with Ctrl-C ignored meanwhile.

The server is started with SIGINT blocked (``spawn_guard.sigint_blocked``), but it is an interpreter started anew
and its signal mask does not survive that start (measured on Linux, CPython 3.11: an empty ``SigBlk``), so a Ctrl-C
during its second of imports raised KeyboardInterrupt there and printed a traceback beside the coordinator's one line.
A Ctrl-C is the coordinator's to handle (it stops its pool, and the server ends with it); the server ignores SIGINT
itself from the moment its imports are done.  This module sits at the package's top, whose ``__init__`` imports
nothing: inside ``simtune.optimize`` its package's imports would run before it could ignore anything.
"""

import signal

_before = signal.signal(signal.SIGINT, signal.SIG_IGN)
try:
    import simtune.activity
    import simtune.engines.mujoco.engine
    import simtune.optimize.evaluator  # noqa: F401
finally:
    signal.signal(signal.SIGINT, _before)
