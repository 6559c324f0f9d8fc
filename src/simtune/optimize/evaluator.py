"""What every optimiser shares: its settings, its result, and the Evaluator that scores batches.

The :class:`Evaluator` takes finished evaluations from the run store and
simulates the rest, in this process or in a pool of worker processes (each
builds its engines once).  In worker processes an evaluation that crashes its
process (a segfault inside an engine) or runs past ``eval_timeout`` seconds
costs only itself: the worker is replaced, the evaluation is stored as failed
with a penalty fitness, and the run goes on.

With ``threads`` (``TuneSettings.threads``) there is no pool: each batch goes
whole to :meth:`~simtune.objective.Objective.score_batch` in this process, whose
engine may run it on ``workers`` threads (MuJoCo does: its members in lockstep
control periods, the controller, sampling and checks as NumPy over the batch),
with the same results bit for bit.  That path has no crash isolation or time-out:
an engine that segfaults ends the run (finished evaluations are kept; resume
continues).  ``threads`` left at None picks it where no processes are needed
(:func:`batch_on_threads`: MuJoCo on up to 2 workers, no ``eval_timeout``).
One process (``workers`` = 1) uses the same batch path on one thread.

Worker processes get the same gain where the engine has a batch path (:func:`has_batch_path`): a batch is
split into one chunk per worker (balanced by each member's physics steps, :func:`chunks`), and each worker
runs its chunk through the batch path on one thread.  A chunk's members run in lockstep, so each member's
running time is the chunk's: a chunk that runs past ``eval_timeout``, or whose worker dies, gives no
results, and its members go out again one at a time, each with its own time-out - the faulty one fails
alone and the others are simulated as usual (the same results: the batch path equals one at a time).

The time-out counts the seconds this (the coordinating) process was running
while the evaluation ran, not the clock on the wall: a coordinator that was
stopped (SIGSTOP, Ctrl-Z, a cluster's pre-emption) or a machine that slept
does not turn the evaluations that were running meanwhile into failures.
An evaluation that failed by time-out is retried once when the run is
resumed (:func:`timed_out`, :meth:`simtune.store.RunStore.release_failures`).

A search with a time cap (``--max-seconds``) hands the Evaluator its deadline (:attr:`Evaluator.seconds_left`):
a batch then goes out in slices of about :data:`SLICE_S` seconds each at this session's pace (on threads a
slice of the batch, in worker processes one chunk a worker at a time), and no slice starts that would end past
the cap; the batch is cut there (:attr:`Evaluator.on_cut`, which stops the search).  Every evaluation that
finished is in the store, so the search's path does not change: a slice's members are simulated as in the whole
batch (the batch path's results do not depend on the batch), and a cut batch is asked for again, whole, by a
resumed search.  Without a cap a batch goes out as one, as before.  A batch of one candidate's many tasks (or
episodes) takes 9 s and more: before slices a cap of 120 s ended a run after 323 s (probe 5; docs/tuning.md).

While it is open the Evaluator holds BLAS (OpenBLAS under NumPy and SciPy) to one thread in this process, and
its worker processes do for their lifetime: the optimisers' linear algebra is small (a least-squares SVD,
differential evolution's population, the replays of the least-squares solver), and BLAS's threads, left
spinning after each call, took a core from the worker processes' simulations (`auto` on `cube` with 2 workers:
56 s with the limit against 62-69 s without; benchmarks/results/auto-workers-blas-2026-11-26.txt).
"""

from __future__ import annotations

import os
import signal
import time
from collections import deque
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, CancelledError, Future, wait
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg  # noqa: F401  (loads SciPy's own BLAS, so that threadpool_limits holds it too)
from threadpoolctl import threadpool_limits

from simtune.common.spawn_guard import (
    adopt_environment,
    check_main_guarded,
    leave_robot_notes_to_parent,
    sigint_blocked,
    worker_context,
)
from simtune.engines import Engine, engine_class
from simtune.engines.controller import CONTROL_PERIOD
from simtune.errors import SimtuneError
from simtune.fitness import PENALTY, Score, TaskScore
from simtune.objective import Objective

if TYPE_CHECKING:
    from pebble import ProcessPool
from simtune.store import RunStore


@dataclass
class TuneSettings:
    """How an optimiser runs: seed, processes and budgets (the same for every optimiser).

    ``elapsed_before`` is the wall time earlier sessions of the same run spent
    (it counts against ``max_seconds`` when a run is resumed).  Budgets are
    checked after each batch (generation); ``max_evaluations`` counts the
    evaluations the search asked for, simulated or taken from the store, so a
    resumed run that replays its search stops where an uninterrupted one would.
    """

    seed: int = 0
    workers: int = 1
    max_seconds: float | None = None
    max_generations: int | None = 1000
    max_evaluations: int | None = None
    elapsed_before: float = 0.0
    eval_timeout: float | None = None
    prune: bool = True  # only differential evolution has parents to prune against
    #: differential evolution exactly as the seed paper ran SciPy's: immediate updating, polish, no pruning
    paper_exact: bool = False
    target_fitness: float | None = None
    on_evaluation: Callable[[Score, bool], None] | None = None  # (score, taken from the store)
    on_generation: Callable[[int, float], None] | None = None  # (generation, best fitness)
    #: points the search starts from (rows of parameter vectors; ``simtune resume --rescore``), scored anew
    initial_population: np.ndarray | None = None
    #: evaluate each batch in this process on ``workers`` threads (the engine's batch path) instead of processes;
    #: None: where that is the faster (:func:`batch_on_threads`)
    threads: bool | None = None
    #: with worker processes (``threads`` False), this many seconds of simulation on threads first, where the
    #: engine has the threaded batch path (:attr:`Evaluator.threads_first_s`); None: processes from the start
    threads_first_s: float | None = None


@dataclass
class TuneResult:
    """The outcome of a tuning run, in the spirit of SciPy's ``OptimizeResult``."""

    x: np.ndarray
    params: dict[str, float]
    score: Score
    generations: int
    evaluations: int  # evaluations in the store (all sessions of this run)
    new_evaluations: int  # evaluations simulated in this session
    wall_s: float  # elapsed over all sessions of this run
    message: str
    converged: bool
    history: list[float] = field(default_factory=list)  # best fitness per generation
    pruned_evaluations: int = 0  # evaluations of this session stopped early (could not beat their parent)
    steps: int = 0  # physics steps simulated in this session
    used_evaluations: int = 0  # evaluations the search asked for (reused or simulated): what budgets count
    #: why the search stopped, as a code (simtune.optimize.base.STOP_REASONS: converged, max-seconds ...)
    stop_reason: str = "finished"

    @property
    def fitness(self) -> float:
        return self.score.fitness


def failed_score(reason: str) -> Score:
    """The score recorded for an evaluation whose worker crashed or hung: a flagged penalty."""
    return Score(PENALTY, PENALTY, None, [TaskScore("all", PENALTY, PENALTY, None, False, reason)])


#: how the reason of an evaluation that ran past ``eval_timeout`` begins
TIMEOUT_REASON = "evaluation ran past "


def timed_out(score: Score) -> bool:
    """Whether ``score`` records an evaluation abandoned for running past the time-out (retried on resume)."""
    return not score.stable and any(t.message.startswith(TIMEOUT_REASON) for t in score.tasks)


#: how often the coordinator looks at its running evaluations [s]
POLL_S = 0.1
#: the most one look may add to an evaluation's running time [s]: a longer gap means this process was stopped
MAX_STEP_S = 1.0


class RunningClock:
    """Seconds this process ran, read at least every :data:`POLL_S`.

    A gap between two readings longer than :data:`MAX_STEP_S` is a pause (the
    process was stopped, or the machine slept) and counts as ``MAX_STEP_S``.
    """

    def __init__(self) -> None:
        self._last = time.monotonic()
        self.seconds = 0.0

    def read(self) -> float:
        now = time.monotonic()
        self.seconds += min(now - self._last, MAX_STEP_S)
        self._last = now
        return self.seconds


#: Engines whose batch path runs a batch on threads, which an Evaluator left to choose uses on up to
#: :data:`THREADS_WIN_UP_TO` workers: no processes to start (nor a ``__main__`` guard for a script to need), for
#: sensitivity and uncertainty's batches.  Since worker processes run chunks through the same batch path they are
#: the faster on large batches (``python benchmarks/batch_threads.py``, 14 members on 2 cores, 2026-11-26:
#: 2 processes 103.6 evaluations/s, 2 threads 60.3, one process 58.9), and ``simtune tune`` asks for them.
THREADED_ENGINES = frozenset({"mujoco"})
THREADS_WIN_UP_TO = 2
#: Seconds of simulation a tuning run that asks for worker processes spends on threads first
#: (:meth:`Evaluator._need_pool`): about what starting the pool costs over what threads lose to processes per second
#: (0.7 s / 0.4): a search that ends sooner never starts a pool.  Measured on the synthetic Panda `reach` (2 workers,
#: 29 rollouts): 1.6 s of search with the pool from the start, 0.8 s without one.
THREADS_FIRST_S = 2.0
#: Rollouts a worker in a batch before worker processes pay for their start (:meth:`Evaluator._need_pool`): the real
#: `single`'s batches (5 parameters: Jacobians of 5, trial points with 1) ran as fast on 2 threads as on 2 processes
#: (2026-11-27: search 2.2-2.8 s against 3.0-5.7 s with the pool's start); `cube`'s 41-point Jacobians run faster
#: on processes (a 14-member batch: 103.6 against 60.3 evaluations/s).
POOL_BATCH = 4
#: Seconds a slice of a batch runs at most, at this session's pace, where the search has a deadline (the module's
#: text): what a cap may be passed by.  A slice holds at least one member a thread (or a worker's one chunk).
SLICE_S = 3.0


def batch_on_threads(engine: str, workers: int, threads: bool | None, eval_timeout: float | None) -> bool:
    """Whether an :class:`Evaluator` runs its batches on threads: as ``threads`` says, and where it says nothing
    (None), for the engines with a threaded batch path on up to :data:`THREADS_WIN_UP_TO` workers, unless a
    time-out asks for worker processes."""
    if threads is not None:
        return threads
    return engine in THREADED_ENGINES and workers <= THREADS_WIN_UP_TO and eval_timeout is None


def has_batch_path(engine: str) -> bool:
    """Whether ``engine`` runs a batch otherwise than one member after the other (its class overrides
    :meth:`~simtune.engines.Engine.rollout_batch`): then worker processes get chunks, not single evaluations."""
    try:
        return engine_class(engine).rollout_batch is not Engine.rollout_batch
    except SimtuneError:  # not installed here: the workers will say so
        return False


def chunks(costs: list[float], n: int) -> list[list[int]]:
    """The indices of ``costs`` in ``n`` chunks of about equal total cost (the longest first, each to the
    chunk with the least so far), each chunk in index order; no empty chunk."""
    held = [0.0] * min(n, len(costs))
    parts: list[list[int]] = [[] for _ in held]
    for i in sorted(range(len(costs)), key=lambda i: -costs[i]):
        least = held.index(min(held))
        parts[least].append(i)
        held[least] += costs[i]
    return [sorted(part) for part in parts]


# --- what one evaluation computes, in this process or a worker ------------------------------------------
def _score(objective: Objective, x: np.ndarray, bound: float | None) -> tuple[None, Score]:
    return None, objective.score_vector(x, bound)


def _residuals(objective: Objective, x: np.ndarray) -> tuple[np.ndarray, Score]:
    return objective.residuals_and_score(objective.vector_space().to_dict(x))


def _batch_results(
    objective: Objective, work: Callable, jobs: dict[int, tuple], threads: int
) -> Iterator[tuple[int, object, Score | Exception, float]]:
    """``(i, payload, score, wall_s)`` for each job of ``work`` (:func:`_score` or :func:`_residuals`), the
    jobs run as one batch of the objective on ``threads`` threads; a member whose simulation raised gives the
    exception as its score.  ``wall_s`` of a result is the time since the previous one (they add up to the
    batch's)."""
    indices = list(jobs)
    space = objective.vector_space()
    params = [space.to_dict(jobs[i][0]) for i in indices]
    results: Iterator[tuple[int, object]]
    if work is _score:
        results = objective.score_batch(params, [jobs[i][1] for i in indices], threads)
    else:
        results = objective.residuals_batch(params, threads)
    last = time.perf_counter()
    for j, result in results:
        now = time.perf_counter()
        wall_s, last = now - last, now
        payload = None
        if isinstance(result, tuple):  # a member's residuals and score
            payload, result = result
        yield indices[j], payload, result, wall_s


_WORKER_OBJECTIVE: Objective | None = None


def _init_worker(objective: Objective, environ: dict[str, str]) -> None:
    global _WORKER_OBJECTIVE
    adopt_environment(environ)
    leave_robot_notes_to_parent()
    _WORKER_OBJECTIVE = objective
    threadpool_limits(1, user_api="blas")  # the worker's cores are the other workers' (see the module's text)
    # Ctrl-C reaches the whole process group: the coordinator stops the pool, workers must not print tracebacks
    # (SIGINT is blocked in them from the start, see sigint_blocked; ignored, a pending one is dropped)
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _in_worker(work: Callable, *args) -> tuple[object, dict, float]:
    t0 = time.perf_counter()
    payload, score = work(_WORKER_OBJECTIVE, *args)
    return payload, score.to_dict(), time.perf_counter() - t0


def _chunk_in_worker(work: Callable, jobs: dict[int, tuple]) -> list[tuple[int, object, dict | str, float]]:
    """A chunk of jobs as one batch of the worker's objective on one thread: ``(i, payload, score, wall_s)``
    each, the score as a dict, or the error of a member whose simulation raised as a line."""
    assert _WORKER_OBJECTIVE is not None
    done: list[tuple[int, object, dict | str, float]] = []
    for i, payload, result, wall_s in _batch_results(_WORKER_OBJECTIVE, work, jobs, 1):
        if isinstance(result, SimtuneError):
            raise result  # bad input or a full disk: the run stops
        if isinstance(result, Exception):
            done.append((i, None, f"{type(result).__name__}: {result}", wall_s))
        else:
            done.append((i, payload, result.to_dict(), wall_s))
    return done


def _twins(vectors: list[np.ndarray]) -> dict[int, int]:
    """Index of each repeated vector of a batch -> index of its first occurrence."""
    first: dict[bytes, int] = {}
    twins = {}
    for i, x in enumerate(vectors):
        j = first.setdefault(x.tobytes(), i)
        if j != i:
            twins[i] = j
    return twins


class Evaluator:
    """Scores batches of vectors, from the store or by simulating; a map-like callable for SciPy.

    ``evaluate`` (or calling it, as SciPy's differential evolution does with its
    ``workers`` map) gives the fitness of each vector; ``residuals`` gives each
    vector's residual vector and score for a least-squares solver, keeping the
    residuals in the store as well.  ``requested`` counts the vectors asked for
    in this session, reused or simulated: on a deterministic replay it is the
    same at the same point of the search, which is what an evaluation budget
    must count.  ``on_evaluation(score, reused)`` is called for every result.
    With ``prune``, trial i of a batch the size of ``parent_energies`` stops as
    soon as it cannot beat parent i (differential evolution's selection).
    """

    def __init__(
        self,
        objective: Objective,
        store: RunStore,
        workers: int = 1,
        on_evaluation: Callable[[Score, bool], None] | None = None,
        eval_timeout: float | None = None,
        prune: bool = True,
        threads: bool | None = None,
        threads_first_s: float | None = None,
    ):
        self.objective = objective
        self.store = store
        self.workers = max(1, int(workers))
        self.threads = batch_on_threads(objective.engine, self.workers, threads, eval_timeout)
        #: worker processes asked for, but this many seconds of simulation on threads first (:meth:`_need_pool`)
        self.threads_first_s = (
            threads_first_s
            if threads_first_s is not None
            and self.workers > 1
            and not self.threads
            and objective.engine in THREADED_ENGINES
            else None
        )
        if self.threads_first_s is not None:
            self.threads = True
        self.on_evaluation = on_evaluation
        self.eval_timeout = eval_timeout
        self.generation = 0
        self.requested = 0
        self.new_evaluations = 0
        self.failed_evaluations = 0
        self.pruned_evaluations = 0
        self.steps = 0
        #: fitness of each trial's parent, in SciPy's population order (None: no pruning)
        self.parent_energies: np.ndarray | None = None
        self.prune = prune
        self._pool: ProcessPool | None = None
        self._blas_limit: threadpool_limits | None = None
        self._batch_failures: list[str] = []
        #: worker processes get chunks of a batch (one per worker) where the engine has a batch path
        self.chunked = self.workers > 1 and not self.threads and has_batch_path(objective.engine)
        #: called with a batch's count of rollouts to simulate before they start (not for one at a time, nor for a
        #: batch the store serves whole); it may raise to stop the search there (a deadline inside a long batch)
        self.before_simulating: Callable[[int], None] | None = None
        #: wall time of this session's simulated batches and their rollouts: the pace a deadline predicts from
        self.simulated_seconds = 0.0
        self.simulated_jobs = 0
        #: seconds left before the search's deadline (None: no deadline, or no cap): batches then go out in slices
        #: checked against it (the module's text)
        self.seconds_left: Callable[[], float | None] | None = None
        #: called, where a deadline cut a batch, with the vectors of the batch that have their fitness (from the
        #: store or simulated), that fitness, and the batch's size; it must raise to stop the search
        self.on_cut: Callable[[list[np.ndarray], list[float], int], None] | None = None
        #: results given in this session (from the store or simulated): the first is never cut away
        self.answered = 0
        self._cut = False
        #: per mode (worker processes: True, this process: False), seconds and members simulated: the seconds one
        #: member of a slice costs there (:meth:`_member_seconds`)
        self._paced: dict[bool, list[float]] = {True: [0.0, 0], False: [0.0, 0]}

    def __enter__(self) -> Evaluator:
        self._blas_limit = threadpool_limits(1, user_api="blas")  # lifted on exit (see the module's text)
        if self.threads_first_s is not None:
            check_main_guarded(f"{self.workers} workers")  # now, not when the pool starts seconds later
        elif self.workers > 1 and not self.threads:
            self._start_pool()
        return self

    def _start_pool(self) -> None:
        from pebble import ProcessPool  # here: pebble imports asyncio, dear to a start that needs no pool

        check_main_guarded(f"{self.workers} workers")
        # worker_context: forked from a clean fork server, or spawned - no worker shares an engine with this process
        self._pool = ProcessPool(
            self.workers,
            initializer=_init_worker,
            initargs=(self.objective, dict(os.environ)),
            context=worker_context(),
        )
        self.threads = False
        self.chunked = has_batch_path(self.objective.engine)

    def _need_pool(self, count: int, pace: float | None = None) -> bool:
        """Whether the worker processes start before a batch of ``count`` rollouts: where they were asked for with
        :attr:`threads_first_s`, before a large batch (:data:`POOL_BATCH` rollouts a worker or more) once the
        session's simulation on threads, with this batch at its pace so far, would run past that many seconds
        (``pace``: seconds a rollout, else this session's so far).

        Starting the pool costs about 0.7 s (a fork server, each worker building its engines); once started,
        processes run large batches about 1.7 times as fast as threads (see :data:`THREADED_ENGINES`), and small
        ones (a Jacobian of a handful of parameters) no faster.  A search of small batches, or one that ends within
        a few seconds, never pays for them; a longer one pays about as much as the threads lost before the switch
        (:data:`THREADS_FIRST_S`)."""
        if self.threads_first_s is None or self._pool is not None or count < POOL_BATCH * self.workers:
            return False
        if pace is None:
            pace = self.simulated_seconds / self.simulated_jobs if self.simulated_jobs else 0.0
        return self.simulated_seconds + count * pace > self.threads_first_s

    def __exit__(self, *exc) -> None:
        if self._pool is not None:
            self._pool.stop()
            self._pool.join()
            self._pool = None
        self.objective.close()
        if self._blas_limit is not None:
            self._blas_limit.restore_original_limits()
            self._blas_limit = None

    def _failed(self, reason: str) -> Score:
        self.failed_evaluations += 1
        self._batch_failures.append(reason)
        return failed_score(reason)

    def _record(self, x, score: Score, wall_s: float, residuals: np.ndarray | None = None) -> None:
        self.store.record_evaluation(x, score, self.generation, wall_s, residuals)
        self.new_evaluations += 1
        self.answered += 1
        self.pruned_evaluations += score.pruned
        self.steps += sum(t.steps for t in score.tasks)
        if self.on_evaluation:
            self.on_evaluation(score, False)

    def _run(self, work: Callable, jobs: dict[int, tuple]) -> Iterator[tuple[int, object, Score, float]]:
        """``(i, payload, score, wall_s)`` of ``work(objective, *jobs[i])`` for each job, as each finishes.

        A failure of one evaluation (an engine error at a corner of the space, a
        dead or hung worker) gives a failed score and no payload; a SimtuneError
        (bad input, full disk) stops the run.  Without a pool the jobs go to the
        objective as one batch (``work`` says which kind); with one, one chunk per
        worker where the engine has a batch path (:attr:`chunked`), else one job at
        a time.  A chunk that fails as a whole goes out again one job at a time.
        With a deadline (:attr:`seconds_left`) the jobs go in slices, and where the
        next slice would end past it the rest is left out (:attr:`_cut` set).
        """
        if not jobs:
            return
        for i, payload, score, wall_s in self._run_units(work, jobs):
            if score.stable or score.pruned:  # a failed evaluation's seconds are no pace
                paced = self._paced[self._pool is not None]
                paced[0] += wall_s
                paced[1] += 1
            yield i, payload, score, wall_s

    def _deadline(self) -> bool:
        """Whether the search has a deadline now (a cap, and seconds left to count)."""
        return self.seconds_left is not None and self.seconds_left() is not None

    def _member_seconds(self) -> float | None:
        """Seconds a member of a slice has cost in this mode so far (in this process: a member of a batch on its
        threads, in a worker: one member of its chunk); None before the first."""
        seconds, members = self._paced[self._pool is not None]
        return seconds / members if members else None

    def _past_deadline(self, members: int) -> bool:
        """Whether a slice of ``members`` would end past the deadline at this mode's pace (with no pace yet: whether
        the deadline has passed); never before this session's first result."""
        if self.seconds_left is None or not self.answered:
            return False
        left = self.seconds_left()
        return left is not None and left < members * (self._member_seconds() or 0.0)

    def _groups(self, jobs: dict[int, tuple]) -> list[list[int]]:
        """The indices of ``jobs`` grouped by what they simulate (:meth:`_simulation_groups`)."""
        indices = list(jobs)
        return [[indices[j] for j in group] for group in self._simulation_groups([jobs[i][0] for i in indices])]

    def _next_slice(self, groups: list[list[int]], least: int, take: bool = True) -> list[int]:
        """The next slice of a batch under a deadline (on this process's threads, or a worker's chunk), from the
        front of ``groups`` (taken off it with ``take``): about :data:`SLICE_S` seconds at this mode's pace, fewer
        where the deadline is nearer (``least`` members at least; ``least`` before the pace is known), whole
        groups."""
        pace = self._member_seconds()
        size = least
        if pace is not None:
            left = self.seconds_left() if self.seconds_left is not None else None
            fits = SLICE_S if left is None else min(SLICE_S, left)
            size = max(least, int(fits / pace))
        part: list[int] = []
        taken = 0
        while taken < len(groups) and (not part or len(part) + len(groups[taken]) <= size):
            part.extend(groups[taken])
            taken += 1
        if take:
            del groups[:taken]
        return sorted(part)

    def _run_units(self, work: Callable, jobs: dict[int, tuple]) -> Iterator[tuple[int, object, Score, float]]:
        """:meth:`_run`'s work, its results as they come."""
        pool = self._pool
        deadline = self._deadline()
        if pool is None:
            if not deadline:
                yield from self._run_batch(work, jobs)
                return
            groups = self._groups(jobs)
            while groups:
                part = self._next_slice(groups, self.workers if self.threads else 1)
                if self._past_deadline(len(part)):
                    self._cut = True
                    return
                yield from self._run_batch(work, {i: jobs[i] for i in part})
            return
        indices = list(jobs)
        # under a deadline the units are cut from the batch's simulations as workers come free (:meth:`_next_slice`)
        groups = self._groups(jobs) if deadline else []
        if deadline:
            units = []
        elif self.chunked:
            # the members that share a simulation (they differ in the marker offset only: Objective._rollout_batch)
            # go to one worker together, the group weighing what one of them costs
            shared = self._simulation_groups([jobs[i][0] for i in indices])
            costs = self._costs([jobs[indices[group[0]]][0] for group in shared])
            units = [sorted(indices[j] for g in part for j in shared[g]) for part in chunks(costs, self.workers)]
        else:
            units = [[i] for i in indices]
        futures: dict[Future, list[int]] = {}
        pending: set[Future] = set()
        waiting = deque(units)  # units to hand to the pool as they are (members of a failed chunk, one each, first)
        flying = self.workers if deadline else float("inf")

        def schedule(unit: list[int]) -> None:
            future: Future
            with sigint_blocked():  # the pool's workers and threads start here, and inherit this
                if len(unit) == 1:
                    future = pool.schedule(_in_worker, (work, *jobs[unit[0]]))
                else:
                    future = pool.schedule(_chunk_in_worker, (work, {i: jobs[i] for i in unit}))
            futures[future] = unit
            pending.add(future)

        def feed(first: list[list[int]] | None = None) -> None:
            """Hand the pool the units ``first`` (ahead of the others), then others while workers are free."""
            waiting.extendleft(reversed(first or []))
            while (waiting or groups) and len(pending) < flying:
                unit = waiting[0] if waiting else self._next_slice(groups, 1, take=False)
                if deadline and self._past_deadline(len(unit)):
                    self._cut = True
                    waiting.clear()
                    groups.clear()
                    return
                schedule(waiting.popleft() if waiting else self._next_slice(groups, 1))

        feed()
        clock, began = RunningClock(), time.perf_counter()
        started: dict = {}  # future -> running time of this process when its evaluation started
        while pending:
            done, still = wait(pending, timeout=POLL_S, return_when=FIRST_COMPLETED)
            pending.difference_update(done)
            now = clock.read()
            for future in done:
                unit = futures.pop(future)
                if len(unit) > 1:
                    try:
                        results = future.result()
                    except SimtuneError:
                        raise
                    except Exception:  # the worker died (or the chunk could not run): find the faulty member alone
                        feed([[i] for i in unit])
                        continue
                    for i, payload, score_or_error, wall_s in results:
                        if isinstance(score_or_error, str):
                            yield i, None, self._failed(score_or_error), wall_s
                        else:
                            yield i, payload, Score.from_dict(score_or_error), wall_s
                    continue
                yield unit[0], *self._single_result(future, time.perf_counter() - began)
            if self.eval_timeout is not None:
                for future in [f for f in still if f.running()]:
                    if now - started.setdefault(future, now) > self.eval_timeout and future.cancel():
                        pending.discard(future)  # pebble stops its worker and starts another
                        unit = futures.pop(future)
                        if len(unit) > 1:  # each member ran the chunk's whole time: which one hung is not known
                            feed([[i] for i in unit])
                            continue
                        reason = f"{TIMEOUT_REASON}{self.eval_timeout:g} s; worker replaced"
                        yield unit[0], None, self._failed(reason), time.perf_counter() - began
            feed()

    def _single_result(self, future: Future, waited_s: float) -> tuple[object, Score, float]:
        """``(payload, score, wall_s)`` of a worker's one evaluation; a dead worker, a cancelled or a failed
        evaluation gives a failed score (``wall_s``: ``waited_s``) and no payload, a SimtuneError stops the run."""
        from pebble import ProcessExpired  # with the pool (see __enter__)

        try:
            payload, score_dict, wall_s = future.result()
            return payload, Score.from_dict(score_dict), wall_s
        except ProcessExpired as exc:
            return None, self._failed(f"worker process died (exit code {exc.exitcode}); worker replaced"), waited_s
        except CancelledError:
            return None, self._failed("evaluation cancelled; worker replaced"), waited_s
        except SimtuneError:
            raise
        except Exception as exc:
            return None, self._failed(f"{type(exc).__name__}: {exc}"), waited_s

    def _simulation_groups(self, vectors: list[np.ndarray]) -> list[list[int]]:
        """The indices of ``vectors`` grouped by what they simulate: equal in every parameter but the marker
        offset's, in the order of each group's first member."""
        names = self.objective.vector_space().names
        simulated = [k for k, name in enumerate(names) if name not in self.objective.marker_names]
        groups: dict[bytes, list[int]] = {}
        for i, x in enumerate(vectors):
            groups.setdefault(x[simulated].tobytes(), []).append(i)
        return list(groups.values())

    def _costs(self, vectors: list[np.ndarray]) -> list[float]:
        """Each member's physics steps per control period, relative (its time step, where the space tunes it):
        what balances the chunks."""
        names = self.objective.vector_space().names
        if "timestep" not in names:
            return [1.0] * len(vectors)
        at = names.index("timestep")
        return [max(1.0, CONTROL_PERIOD / float(x[at])) if x[at] > 0 else 1.0 for x in vectors]

    def _simulate(self, work: Callable, jobs: dict[int, tuple]) -> Iterator[tuple[int, object, Score, float]]:
        """:meth:`_run` for a batch, after :attr:`before_simulating` has had its say, timed."""
        if not jobs:
            return
        if self.before_simulating is not None:
            self.before_simulating(len(jobs))
        start, count = time.perf_counter(), len(jobs)
        if self._need_pool(len(jobs)):
            self._start_pool()
        if not self.simulated_jobs and len(jobs) > 1:
            # the session's first batch (auto: the opening's start point with its whole Jacobian, D + 1 rollouts
            # in lockstep) would store its first evaluation only when all of them end: its first member goes
            # alone, so that the start's fitness is stored, and shown, a rollout after the set-up.  A member's
            # result does not depend on its batch (engines/mujoco/batch.py), so the search is the same.
            first = next(iter(jobs))
            yield from self._run(work, {first: jobs[first]})
            jobs = {i: job for i, job in jobs.items() if i != first}
            # its time, shared out over the workers' threads, is the first pace to judge the rest of the batch by
            if self._need_pool(len(jobs), (time.perf_counter() - start) / self.workers):
                self._start_pool()
        if not self._cut:
            yield from self._run(work, jobs)
        self.simulated_seconds += time.perf_counter() - start
        self.simulated_jobs += count

    def _run_batch(self, work: Callable, jobs: dict[int, tuple]) -> Iterator[tuple[int, object, Score, float]]:
        """:meth:`_run` in this process: the jobs as one batch of the objective (on ``workers`` threads with
        ``threads``)."""
        threads = self.workers if self.threads else 1
        for i, payload, result, wall_s in _batch_results(self.objective, work, jobs, threads):
            if isinstance(result, SimtuneError):
                raise result
            if isinstance(result, Exception):
                yield i, None, self._failed(f"{type(result).__name__}: {result}"), wall_s
            else:
                yield i, payload, result, wall_s

    def _end_batch(self, simulated: int) -> None:
        if simulated and len(self._batch_failures) == simulated:
            raise SimtuneError(f"every evaluation of generation {self.generation} failed: {self._batch_failures[0]}")
        self.generation += 1

    def score_one(self, x) -> float:
        """Fitness of one vector, from the store or simulated: an objective function for SciPy.

        For searches that update after every evaluation (SciPy's immediate
        updating and its polish): the vector counts towards the current
        ``generation``, which the caller advances.
        """
        x = np.asarray(x, dtype=float)
        self.requested += 1
        known = self.store.lookup(x)
        if known is not None:
            self.answered += 1
            if self.on_evaluation:
                self.on_evaluation(known, True)
            return known.fitness
        if self._deadline() and self._past_deadline(1):
            self._stop_at_deadline([], [], 1)
        for _, _, score, wall_s in self._run(_score, {0: (x, None)}):
            self._record(x, score, wall_s)
            return score.fitness
        raise AssertionError("one job gives one result")

    def evaluate(self, vectors) -> np.ndarray:
        """Fitness of each vector of a batch (one generation), from the store or simulated."""
        return np.asarray(self(None, vectors), dtype=float)

    def __call__(self, func, vectors) -> list[float]:
        vectors = [np.asarray(x, dtype=float) for x in vectors]
        self.requested += len(vectors)
        self._batch_failures = []
        parents = self.parent_energies
        if not self.prune or parents is None or len(parents) != len(vectors):
            parents = None  # no pruning
        fitness: list[float] = [0.0] * len(vectors)
        jobs: dict[int, tuple] = {}
        twins = _twins(vectors)  # a vector asked for twice in a batch is simulated once
        for i, x in enumerate(vectors):
            if i in twins:
                continue
            known = self.store.lookup(x)
            if known is None:
                # trial i competes with member i; a twin's result must hold for every parent: the loosest bound
                bound = None
                if parents is not None:
                    bound = float(max(parents[j] for j in (i, *[t for t, f in twins.items() if f == i])))
                jobs[i] = (x, bound)
                continue
            fitness[i] = known.fitness
            self.answered += 1
            if self.on_evaluation:
                self.on_evaluation(known, True)
        simulated = set()
        for i, _, score, wall_s in self._simulate(_score, jobs):
            self._record(vectors[i], score, wall_s)
            fitness[i] = score.fitness
            simulated.add(i)
        if self._cut:
            have = [i for i in range(len(vectors)) if i not in twins and (i in simulated or i not in jobs)]
            self._stop_at_deadline([vectors[i] for i in have], [fitness[i] for i in have], len(vectors))
        for i, first in twins.items():
            fitness[i] = fitness[first]
        self._end_batch(len(jobs))
        return fitness

    def residuals(self, vectors) -> list[tuple[np.ndarray, Score]]:
        """Residual vector and score of each vector of a batch (for least squares), stored like any evaluation.

        A vector whose score is in the store but whose residuals are not (e.g. the
        best point of the search a refinement starts from) is simulated again for
        them; its stored score is kept.  Failed or unstable simulations get the
        objective's penalty residuals.
        """
        vectors = [np.asarray(x, dtype=float) for x in vectors]
        self.requested += len(vectors)
        self._batch_failures = []
        results: list[tuple[np.ndarray, Score] | None] = [None] * len(vectors)
        jobs: dict[int, tuple] = {}
        twins = _twins(vectors)
        for i, x in enumerate(vectors):
            if i in twins:
                continue
            known, residuals = self.store.lookup(x), self.store.lookup_residuals(x)
            if known is None or residuals is None:
                jobs[i] = (x,)
                continue
            results[i] = (residuals, known)
            self.answered += 1
            if self.on_evaluation:
                self.on_evaluation(known, True)
        for i, payload, score, wall_s in self._simulate(_residuals, jobs):
            if isinstance(payload, np.ndarray) and score.stable:
                residuals = payload
            else:  # a failed evaluation has no residuals, an unstable one meaningless ones
                residuals = self.objective.penalty_residuals()
            known = self.store.lookup(vectors[i])
            if known is None:
                self._record(vectors[i], score, wall_s, residuals)  # both at once: a kill keeps both or neither
            else:
                score = known  # simulated again only for its residuals: the stored evaluation stands
                self.store.record_residuals(vectors[i], residuals)
            results[i] = (residuals, score)
        if self._cut:
            have = [(vectors[i], result[1].fitness) for i, result in enumerate(results) if result is not None]
            self._stop_at_deadline([x for x, _ in have], [f for _, f in have], len(vectors))
        for i, first in twins.items():
            results[i] = results[first]
        self._end_batch(len(jobs))
        return results  # type: ignore[return-value]

    def _stop_at_deadline(self, vectors: list[np.ndarray], fitness: list[float], asked: int) -> None:
        """Hand a batch cut at the deadline to :attr:`on_cut` (which stops the search): its ``vectors`` that have
        their ``fitness``, of ``asked``."""
        self._cut = False
        assert self.on_cut is not None, "a deadline comes with what to do at it"
        self.on_cut(vectors, fitness, asked)
        raise AssertionError("on_cut stops the search")
