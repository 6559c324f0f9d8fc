"""Budgets, checkpoints and the best point, for every optimiser that evaluates batches of vectors.

An optimiser asks for a batch of vectors, :class:`BatchSearch` scores it
through the :class:`~simtune.optimize.evaluator.Evaluator` (store cache,
process pool), checkpoints it with ``store.record_generation`` and says
whether a budget of its :class:`~simtune.optimize.evaluator.TuneSettings`
is spent:

- ``max_seconds``: wall time over all sessions of the run;
- ``max_evaluations``: evaluations asked for (simulated or taken from the
  store); ``remaining()`` lets an optimiser shorten its last batch to fit;
- ``max_generations``: generations of the optimiser (``generation_size`` = 0),
  or, for optimisers without generations, units of ``generation_size``
  evaluations (1 x D, as DE's population);
- ``target_fitness``: the best fitness so far reached it.

Every optimiser built on it is deterministic given its seed and the fitness
values, so resuming a run replays it with every stored evaluation reused.

``settings.initial_population`` (``simtune resume --rescore``: the last
population of a run whose data changed) is where a search starts: DE takes it
as its first population; the others score it as their first batch
(:meth:`BatchSearch.initial_batch`) and go on from there.
"""

from __future__ import annotations

import time

import numpy as np

from simtune.objective import Objective
from simtune.optimize.evaluator import Evaluator, TuneResult, TuneSettings
from simtune.store import RunStore


#: Why a search stops (``TuneResult.stop_reason``, the run store's ``search_stop_reason``, ``--json``'s
#: ``stop_reason``): it met its convergence criterion; one of its budgets was spent (``--max-seconds``,
#: ``--target-fitness``, ``--max-evaluations``, ``--max-generations``); or the optimiser ended by itself without a
#: convergence criterion (``finished``).
class BudgetSpent(Exception):
    """Raised inside a solver (SciPy's, which has no other way out) when a budget of the search says stop."""


STOP_REASONS = ("converged", "max-seconds", "target-fitness", "max-evaluations", "max-generations", "finished")


class BatchSearch:
    """Budget accounting and checkpoints for an optimiser that evaluates batches of vectors."""

    def __init__(
        self,
        objective: Objective,
        store: RunStore,
        settings: TuneSettings,
        *,
        generation_size: int = 0,
        first_generation: int = 1,
        prune: bool = False,
        deadline: bool = False,
    ):
        self.objective = objective
        self.store = store
        self.settings = settings
        self.space = objective.vector_space()
        self.lows = np.array([lo for lo, _ in self.space.bounds], dtype=np.float64)
        self.highs = np.array([hi for _, hi in self.space.bounds], dtype=np.float64)
        self.generation_size = generation_size
        self.evaluator = Evaluator(
            objective,
            store,
            settings.workers,
            settings.on_evaluation,
            settings.eval_timeout,
            prune=prune and settings.prune,
            threads=settings.threads,
            threads_first_s=settings.threads_first_s,
        )
        self.evaluator.generation = first_generation
        self.first_generation = first_generation
        self.start = time.perf_counter()
        self.history: list[float] = []
        self.best_x: np.ndarray | None = None
        self.best_fitness = float("inf")
        #: why the search stopped, in words (``stopped after 60 s``), and as its code (:data:`STOP_REASONS`)
        self.stop_reason: str | None = None
        self.stop_code: str | None = None
        #: points scored before the search asked for them (least squares' speculative Jacobian columns), by key:
        #: tracked when it asks (:meth:`release`) or at the end (:meth:`result`), never before, so that the
        #: search's path does not depend on how many workers scored ahead
        self.held: dict[bytes, tuple[np.ndarray, float]] = {}
        #: points a least-squares solver asked for in this session (its steps; replays of it not counted), so that
        #: a search stopped inside a local phase still says how many it took
        self.solver_steps = 0
        if deadline and settings.max_seconds is not None:
            self.evaluator.before_simulating = self._before_batch
        # the cap reaches into a batch: the Evaluator cuts one whose next slice would end past it
        self.evaluator.seconds_left = self._seconds_left
        self.evaluator.on_cut = self._cut

    # --- context: the process pool -----------------------------------------------------------------
    def __enter__(self) -> BatchSearch:
        self.evaluator.__enter__()
        return self

    def __exit__(self, *exc) -> None:
        self.evaluator.__exit__(*exc)

    # --- scaling: optimisers that work in the unit cube ---------------------------------------------
    def from_unit(self, u) -> np.ndarray:
        """Parameter vector(s) for point(s) of [0, 1]^D (clipped to the bounds)."""
        x = self.lows + np.asarray(u, dtype=float) * (self.highs - self.lows)
        return np.clip(x, self.lows, self.highs)

    def to_unit(self, x) -> np.ndarray:
        width = np.where(self.highs > self.lows, self.highs - self.lows, 1.0)
        return (np.asarray(x, dtype=float) - self.lows) / width

    # --- budgets ------------------------------------------------------------------------------------
    def elapsed(self) -> float:
        return self.settings.elapsed_before + time.perf_counter() - self.start

    @property
    def used(self) -> int:
        """Evaluations asked for so far in this session's search (reused from the store or simulated); points
        scored ahead count once the search asks for them, so a budget stops a search at the same point of its
        path on any number of workers."""
        return self.evaluator.requested - len(self.held)

    @property
    def generations(self) -> int:
        return len(self.history)

    def remaining(self) -> int | None:
        """Evaluations left in the budget (None: no evaluation budget)."""
        s = self.settings
        caps = [s.max_evaluations] if s.max_evaluations is not None else []
        if self.generation_size and s.max_generations is not None:
            caps.append(s.max_generations * self.generation_size)
        return max(0, min(caps) - self.used) if caps else None

    def _check(self) -> tuple[str, str] | None:
        """The budget that is spent, as its code (:data:`STOP_REASONS`) and in words; None while none is."""
        s = self.settings
        if s.max_seconds is not None and (elapsed := self.elapsed()) >= s.max_seconds:
            # a batch's slice under way when the cap passed ran on to its end: say how long it ran, not only the cap
            # (probe 5: "stopped after 120 s" after 323 s)
            if elapsed < s.max_seconds * 1.05 + 1:
                return "max-seconds", f"stopped after {max(elapsed, s.max_seconds):.0f} s"
            return "max-seconds", (
                f"stopped after {elapsed:.0f} s, its cap {s.max_seconds:g} s reached inside a batch whose evaluations "
                "under way ran on to their end"
            )
        if s.target_fitness is not None and self.best_fitness <= s.target_fitness:
            return "target-fitness", f"reached the target fitness {s.target_fitness:g}"
        if s.max_evaluations is not None and self.used >= s.max_evaluations:
            if self.used > s.max_evaluations:  # a generation or a Jacobian is never cut: say what it cost
                return "max-evaluations", (
                    f"used {self.used} evaluations, its budget of {s.max_evaluations} reached inside a batch that ran "
                    "on to its end (a batch is never cut: its evaluations are the search's next step)"
                )
            return "max-evaluations", f"used its budget of {s.max_evaluations} evaluations"
        if s.max_generations is not None:
            if not self.generation_size and self.generations >= s.max_generations:
                return "max-generations", f"reached {s.max_generations} generations"
            if self.generation_size and self.used >= s.max_generations * self.generation_size:
                return "max-generations", f"used {s.max_generations} generations of {self.generation_size} evaluations"
        return None

    def _seconds_left(self) -> float | None:
        """Seconds before ``max_seconds`` (over all sessions of the run); None without a cap."""
        cap = self.settings.max_seconds
        return None if cap is None else cap - self.elapsed()

    def _cut(self, vectors: list[np.ndarray], fitness: list[float], asked: int) -> None:
        """Stop (:class:`BudgetSpent`) where the Evaluator cut a batch of ``asked`` vectors at the deadline: the
        ``vectors`` of it that have their ``fitness`` (stored: a resumed search takes them from the store) count
        towards the best point, as every point the run scored does at its end."""
        if vectors:
            self.track(np.array(vectors), np.array(fitness, dtype=float))
        elapsed, cap = self.elapsed(), self.settings.max_seconds
        assert cap is not None, "a cut needs a cap"
        finished = f"{len(vectors)} of its {asked} evaluations done and stored"
        self.stop_code = "max-seconds"
        if elapsed >= cap:
            self.stop_reason = f"stopped after {elapsed:.0f} s, its cap {cap:g} s reached inside a batch ({finished})"
        else:
            self.stop_reason = (
                f"stopped at {elapsed:.0f} s inside a batch whose next evaluations would have run past its cap "
                f"{cap:g} s ({finished})"
            )
        raise BudgetSpent

    def _before_batch(self, rollouts: int) -> None:
        """Stop (:class:`BudgetSpent`) before a batch that would run past ``max_seconds`` at this session's pace.

        Budgets are otherwise checked between batches, and a batch (a Jacobian's D + 1 rollouts, a population)
        takes many seconds: the command would end a batch's length after its cap.  The pace is the seconds per
        rollout of this session's batches so far; the first batch has none and always runs.
        """
        evaluator, cap = self.evaluator, self.settings.max_seconds
        if cap is None or not evaluator.simulated_jobs:
            return
        needed = rollouts * evaluator.simulated_seconds / evaluator.simulated_jobs
        if self.elapsed() + needed > cap:
            self.stop_code = "max-seconds"
            self.stop_reason = (
                f"stopped at {self.elapsed():.0f} s: its next batch ({rollouts} rollouts, about {needed:.0f} s) "
                f"would have run past {cap:g} s"
            )
            raise BudgetSpent

    def starting_points(self) -> np.ndarray | None:
        """``settings.initial_population`` within the bounds (None: start as usual)."""
        start = self.settings.initial_population
        if start is None or len(start) == 0:
            return None
        return np.clip(np.atleast_2d(np.asarray(start, dtype=float)), self.lows, self.highs)

    def initial_batch(self) -> tuple[np.ndarray, np.ndarray, bool] | None:
        """Score the starting points (cut to the evaluation budget) as the first generation.

        ``(vectors, fitness, stop)``, or None without starting points; ``stop``: a budget is spent.
        """
        start = self.starting_points()
        if start is None:
            return None
        left = self.remaining()
        batch = start if left is None else start[: max(1, left)]
        fitness = self.evaluate(batch)
        return batch, fitness, self.checkpoint(batch, fitness)

    # --- one batch ----------------------------------------------------------------------------------
    def evaluate(self, vectors) -> np.ndarray:
        """Fitness of a batch; tracks the best point."""
        vectors = np.atleast_2d(np.asarray(vectors, dtype=float))
        fitness = self.evaluator.evaluate(vectors)
        self.track(vectors, fitness)
        return fitness

    def track(self, vectors, fitness) -> None:
        """Note scored vectors (the best point so far is kept)."""
        if len(fitness) == 0:
            return
        i = int(np.argmin(fitness))
        if fitness[i] < self.best_fitness:
            self.best_fitness = float(fitness[i])
            self.best_x = np.array(vectors[i], dtype=float)

    def hold(self, key: bytes, x: np.ndarray, fitness: float) -> None:
        """Keep a point scored ahead of the search out of its best point until :meth:`release` (``key``: the
        search's own name for the point)."""
        self.held[key] = (np.array(x, dtype=float), float(fitness))

    def release(self, key: bytes) -> None:
        """Track the held point ``key`` now that the search asks for it (nothing if none is held)."""
        if key in self.held:
            x, fitness = self.held.pop(key)
            self.track(x[None], np.array([fitness]))

    def checkpoint(self, vectors, fitness, population: bool = True) -> bool:
        """Record a batch (or population) as a generation checkpoint; True when a budget says stop.

        ``population``: the batch is a search population that ``resume --rescore`` may start from (the store
        keeps the latest such); a refinement's batches of points are not.
        """
        generation = self.first_generation + len(self.history)
        self.history.append(self.best_fitness)
        elapsed = self.elapsed()
        self.store.record_generation(
            generation,
            np.atleast_2d(vectors),
            fitness,
            self.best_x,
            self.best_fitness,
            self.store.count_evaluations(),
            elapsed,
            keep_population=population,
        )
        # this session's seconds inside the Evaluator's batches: what is left of its elapsed time is the coordinator's
        # (the solver, DE, the checks; benchmarks/auto_workers.py reads it)
        self.store.set(elapsed_s=elapsed, session_simulating_s=self.evaluator.simulated_seconds)
        if self.settings.on_generation:
            self.settings.on_generation(generation, self.best_fitness)
        spent = self._check()
        self.stop_code, self.stop_reason = spent if spent is not None else (None, None)
        return spent is not None

    def result(self, message: str | None = None, converged: bool = False, stop_reason: str | None = None) -> TuneResult:
        """The :class:`TuneResult` of the search so far (best point, with its stored score).

        Args:
            message: why it stopped, in words (default: the budget that stopped it).
            converged: whether the search met its own convergence criterion.
            stop_reason: the code of why it stopped (:data:`STOP_REASONS`); default: the spent budget's code, else
                ``converged`` or ``finished`` (the optimiser ended by itself).
        Returns:
            The best point with its stored score, the counts and the stop reason.
        """
        used = self.used  # before the held points are let in: what the search asked for (a replay's budget)
        for key in list(self.held):  # the run's best point is the best of every point it scored
            self.release(key)
        if self.best_x is None:
            raise RuntimeError("no batch was evaluated")
        best = self.store.lookup(self.best_x) or self.objective.score_vector(self.best_x)
        return TuneResult(
            self.best_x,
            self.space.to_dict(self.best_x),
            best,
            self.generations,
            self.store.count_evaluations(),
            self.evaluator.new_evaluations,
            self.elapsed(),
            message or self.stop_reason or "stopped",
            converged,
            list(self.history),
            self.evaluator.pruned_evaluations,
            self.evaluator.steps,
            used,
            stop_reason or self.stop_code or ("converged" if converged else "finished"),
        )
