"""Global, then local (``--optimizer auto``): a short differential evolution, then bounded least squares, in rounds.

It opens with a local phase from the generic point with each task's clock aligned to its recordings
(:func:`aligned_generic_start`: the command delay from the recordings' motion onset, then a 1-D search over
the delay alone): on real recordings most of the generic error is the recording's clock, and what is left
is often one basin away.  Then, in rounds:

1. **global**: ``GLOBAL_GENERATIONS`` generations of differential evolution with the paper's settings
   (:data:`simtune.optimize.de.DE_SETTINGS`: best1bin, population 1 x D, deferred updating, trials that
   cannot beat their parent pruned); the first round starts from the opening's best point, half its
   members drawn close around it and half a latin hypercube (:func:`opening_population`; or, after
   ``resume --rescore``, from the old run's last population, with no opening), every later one from the
   last round's population
   with a fresh seed: the global search goes on where it stopped.  Those members are scored already: SciPy's
   scaling into its unit cube and back moves them by rounding errors, and the phase takes such a copy as the member
   itself (:func:`as_originals`), so a round's first batch comes from the store;
2. **local**: SciPy's ``least_squares`` (trust-region reflective, within the bounds, in the unit cube)
   from the best point of the run on the per-sample residuals (:func:`simtune.fitness.residuals`),
   with a forward-difference Jacobian whose D perturbed points go to the Evaluator as one batch (worker
   processes, or the engine's batch path with ``--threads``); each trial point goes out with the trial points
   the solver asks for next if it rejects it (most trials on the arms' objectives), as many as there are
   workers besides it (:func:`~simtune.optimize.refine.least_squares_phase`).  It ends when a solver step
   gains less than ``STALL_FTOL`` of the cost (it stalls: back to the global phase, which looks for a better
   basin) or after ``LOCAL_NFEV`` solver steps.  Its start is the run's best point after the global phase, which
   is where the last local phase ended when the global phase found nothing better: a phase restarted there, its
   trust region new, goes on (measured on real ``single``: after the opening every gain came from such a restart,
   0.06 to 1.6 % each, none of the global phases finding a better point).

The run stops by itself once it has converged (:func:`converged`): the last half of its rounds, and at least
``PATIENCE`` of them, together lowered the best fitness by less than ``ROUND_RTOL`` of it - neither the local phases
(each ends on SciPy's cost tolerance, ``STALL_FTOL``, or after ``LOCAL_NFEV`` steps) nor the global rounds that look
for a better basin are finding one.  The patience grows with the run because on contact tasks the global rounds'
finds come in bursts after plateaus: measured on real `cube` (``calibrated``, seeds 1 and 2), a fixed two rounds
stopped the runs at 0.0075 and 0.0077 after 12 rounds, where the rounds that followed reached 0.0068 and 0.0065 by
round 16 and 22 (docs/tuning.md).  A run of a few rounds is judged as before: the half is then two rounds.
A local phase's own tolerance alone is not the test: on contact tasks the objective is not smooth at the
finite-difference scale, and a phase creeps on by tiny gains until its step limit (measured: `cube`, three
parameters, 75 rounds of 12 steps each, none stalled).  The opening's local phase counts as a round's best: global
rounds that find nothing better than the opening end the run as well.

It also stops, as ``converged`` with a message that says so, once a local phase (the opening's or a round's) ends
at the recordings' noise floor (:func:`at_noise_floor`): the sum of squares of the residuals where it ended, on its
tolerance or on its step limit, is at most ``FLOOR_RATIO`` (1.1) times :func:`noise_floor_cost`, what a simulation
of the true parameters is expected to score.  The reference is the mean of R repeats, so each residual of the truth
is that mean's noise, of variance a repeat's own over R; the repeats' deviations from their mean
(:meth:`~simtune.objective.Objective.repeat_deviations`, in the residuals' own units and weights) give it, summed
over the residuals: sum of squares / (R (R - 1)).  With every signal weighed by its noise this is (1 mm)^2 / R for
each marker axis, object axis and logged joint (the MICO's marker and six joints, five repeats: 1.8e-6): the
fit's reduced chi-square is at most 1.1.  No basin can then lower the cost by more than a
tenth, so a global round has nothing meaningful left to find.  The phase's step limit counts as its end here:
measured on the synthetic MICO ``double`` (docs/vs-mujoco-sysid.md), the opening ends on its 12th step at 1.01 x the
floor, its last steps gaining 0.4 % of it, and stops the run there (not two rounds later, at the same fitness).
The rule needs a floor: only against the aligned reference (the plain mean's repeats scatter by their start
jitter too) with two repeats or more of every task; without one the rounds' gains alone decide.  Real recordings
sit far above it (qrg2019 ``single``: docs/tuning.md), so it is the synthetic problems' rule.

Budgets of the settings (time,
evaluations, generations, target fitness) stay as caps, checked after every batch: a DE generation, a
least-squares trial point or a Jacobian.  A generation of this optimiser is one such batch.

The worker count shapes the batches (the points scored ahead), not the search: a point scored ahead
counts towards the best point and the evaluation budget only once the solver asks for it, so runs of one seed
on any worker count ask for the same points and stop at the same one; the run's best point is then the best
of all it scored, which the points scored ahead can only improve.

Resume: the search is deterministic given its seed and the stored results (DE draws from the seed of its
round; least squares is deterministic given the residuals, which the store keeps for every point of a
local phase), so ``simtune resume`` replays it, taking every finished evaluation from the store, and
goes on where the killed session stopped: no finished evaluation is lost or simulated twice.  The point
a local phase starts from was scored without residuals; it is simulated once more for them.  The
opening's delay search (a dozen rollouts in the coordinating process, not stored: they are not
evaluations of the search) is deterministic: a resumed run, like any later start on the same recordings,
reads it from the start-up cache (:func:`simtune.alignment.cached_delay`) or runs it again.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.optimize import differential_evolution

from simtune.alignment import cached_delay
from simtune.objective import Objective, generic_values
from simtune.optimize.base import BatchSearch, BudgetSpent
from simtune.optimize.de import DE_SETTINGS, POPSIZE
from simtune.optimize.evaluator import TuneResult, TuneSettings
from simtune.optimize.refine import least_squares_phase
from simtune.optimize.start_check import warn_about_start
from simtune.params.kinds import delay_names
from simtune.store import RunStore

GLOBAL_GENERATIONS = 10  # differential evolution generations per round's global phase
LOCAL_NFEV = 12  # least-squares solver steps per local phase (each may add a D-evaluation Jacobian)
STALL_FTOL = 1e-3  # a solver step that lowers the cost by less than this share ends the local phase
NEAR_SHARE = 0.5  # of the first global phase's members, drawn around the opening's best point
NEAR_SCALE = 0.02  # their spread (standard deviation), as a share of each parameter's range
#: the fewest rounds whose gains together decide convergence (a longer run: the last half of its rounds), and the share
#: of the best fitness they must gain to go on
PATIENCE = 2
ROUND_RTOL = 0.01
#: a local phase that ends where its residuals' sum of squares is at most this many times the recordings' noise floor
#: (:func:`noise_floor_cost`) ends the run: no basin can be better by more than this share of the repeats' scatter
FLOOR_RATIO = 1.1
#: a point of a global phase's first batch within this share of each range of a member it started from is that member
#: (SciPy's scaling into its unit cube and back moves a coordinate by about 1e-16 of its range)
ROUNDING = 1e-12


def patience(best_after_round: list[float]) -> int:
    """How many of the last rounds :func:`converged` judges: the last half of them, ``PATIENCE`` at the least.

    Args:
        best_after_round: the run's best fitness after its opening (if any) and after each round, in order.
    Returns:
        The number of rounds.
    """
    return max(PATIENCE, (len(best_after_round) - 1) // 2)


def converged(best_after_round: list[float]) -> bool:
    """Whether a run of rounds has converged: the last :func:`patience` rounds (half of them, ``PATIENCE`` at the
    least) lowered the best fitness by less than ``ROUND_RTOL`` of it.

    Args:
        best_after_round: the run's best fitness after its opening (if any) and after each round, in order.
    Returns:
        True when the search should stop as ``converged``.
    """
    judged = patience(best_after_round)
    if len(best_after_round) <= judged:
        return False
    before, now = best_after_round[-1 - judged], best_after_round[-1]
    if not (np.isfinite(before) and np.isfinite(now)):
        return False
    return before - now <= ROUND_RTOL * abs(before)


def noise_floor_cost(deviations: list[np.ndarray | None]) -> float | None:
    """The sum of squared residuals a simulation of the true parameters is expected to score against the mean of
    the repeats: the recordings' noise floor, in the residuals' own units.

    The reference is the mean of R repeats, so each of its residuals carries that mean's noise, whose variance is
    a repeat's own (the rows' spread about their mean, unbiased: sum of squares over R - 1) over R.

    Args:
        deviations: per task, each repeat's deviation from the repeats' mean in the residuals' units (one row per
            repeat: :meth:`~simtune.objective.Objective.repeat_deviations`), None for a task without two repeats.
    Returns:
        The expected sum of squares, summed over the tasks; None where a task has no floor (fewer than two
        repeats) or the repeats agree exactly (nothing to compare a fit with).
    """
    if not deviations or any(d is None for d in deviations):
        return None
    total = 0.0
    for rows in deviations:
        assert rows is not None  # checked above: for mypy
        count = len(rows)
        total += float(np.sum(np.square(rows))) / (count * (count - 1))
    return total if np.isfinite(total) and total > 0 else None


def recordings_floor(objective: Objective) -> float | None:
    """:func:`noise_floor_cost` of ``objective``'s recordings where every task is fitted to its aligned reference;
    None against a plain mean (the repeats' start jitter then inflates their scatter beyond the noise, and a
    floor from it would stop a fit well above the real one) or with one repeat.

    Args:
        objective: the run's objective (its references and residual weighting).
    Returns:
        The floor of the residuals' sum of squares, or None where the rule does not apply.
    """
    if any(reference.reference != "aligned" for reference in objective.references.values()):
        return None
    return noise_floor_cost(objective.repeat_deviations())


def at_noise_floor(residuals: np.ndarray, floor: float | None) -> bool:
    """Whether a local phase ended at the recordings' noise floor: the residuals where it ended (on its tolerance or
    its step limit) have a sum of squares of at most ``FLOOR_RATIO`` times ``floor``, so that no point of any basin
    can lower it by more than that share.

    Args:
        residuals: the residuals where the phase ended (the solver's best point).
        floor: :func:`recordings_floor` of the run (None: no floor, the rule never fires).
    Returns:
        True when the search should stop as ``converged``.
    """
    cost = float(np.sum(np.square(residuals)))
    return floor is not None and bool(np.isfinite(cost)) and cost <= FLOOR_RATIO * floor


def global_local_tune(objective: Objective, store: RunStore, settings: TuneSettings) -> TuneResult:
    """Tune ``objective`` in rounds of differential evolution then least squares; every evaluation lands in
    ``store``."""
    search = BatchSearch(objective, store, settings, prune=True, deadline=True)
    search.evaluator.generation = 0
    rounds = 0
    best_after_round: list[float] = []  # after the opening and after each round: what convergence is judged on
    population = search.starting_points()
    if population is not None and len(population) < 5:
        population = None  # SciPy's DE needs 5 members or more
    opening = population is None and settings.initial_population is None
    floor = recordings_floor(objective)  # None: the rounds' gains alone decide
    with search:
        try:
            if opening:
                solution = _local_phase(search, aligned_generic_start(objective), diagnose=True)
                best_after_round.append(search.best_fitness)
                if at_noise_floor(solution.fun, floor):
                    return _converged(search, _floor_words(solution.fun, floor), rounds, opening)
                assert search.best_x is not None, "the opening scored its start"
                population = search.from_unit(opening_population(search.to_unit(search.best_x), settings.seed))
                population[0] = search.best_x  # as scored, not through the unit cube and back
            while True:
                population, last_energies = _global_phase(search, population, settings.seed + 1000 * rounds)
                assert search.best_x is not None, "the global phase scored a batch"
                solution = _local_phase(search, search.best_x)
                rounds += 1
                best_after_round.append(search.best_fitness)
                if at_noise_floor(solution.fun, floor):
                    return _converged(search, _floor_words(solution.fun, floor), rounds, opening)
                if converged(best_after_round):
                    judged = patience(best_after_round)
                    return _converged(search, f"{judged} rounds gained less than {ROUND_RTOL:.0%}", rounds, opening)
                # the next global phase goes on from this one's population, with the run's best point in it
                if not any(np.array_equal(member, search.best_x) for member in population):
                    population = population.copy()
                    population[int(np.argmax(last_energies))] = search.best_x
        except BudgetSpent:
            pass
        assert search.stop_reason is not None, "the rounds end only when a budget says stop"
        return search.result(f"{search.stop_reason} ({_progress(rounds, search.solver_steps, opening)})")


def _converged(search: BatchSearch, rule: str, rounds: int, opening: bool) -> TuneResult:
    """The run's result where a convergence rule (``rule``, in words) ended it."""
    message = f"converged: {rule} ({_progress(rounds, search.solver_steps, opening)})"
    return search.result(message, converged=True, stop_reason="converged")


def _floor_words(residuals: np.ndarray, floor: float | None) -> str:
    """Which rule fired, in words: ``at the recordings' noise floor (residuals 1.03 x the floor)``."""
    assert floor is not None, "the floor rule fired"
    return f"at the recordings' noise floor (residuals {float(np.sum(np.square(residuals))) / floor:.2f} x the floor)"


def _progress(rounds: int, steps: int, opening: bool) -> str:
    """Where the rounds stood, in words: ``2 full rounds after the opening, 31 least-squares steps``."""
    where = "in the opening" if opening and rounds == 0 else f"{rounds} full round{'s' * (rounds != 1)}"
    if opening and rounds:
        where += " after the opening"
    return f"{where}, {steps} least-squares step{'s' * (steps != 1)}"


def _local_phase(search: BatchSearch, start: np.ndarray, diagnose: bool = False):
    """One local phase from ``start``; ``search.solver_steps`` counts its steps.  Returns SciPy's result (``status``
    0: the phase ran out of steps; ``fun``: the residuals where it ended).

    ``diagnose``: warn about the start (a bound, parameters its first Jacobian cannot tell apart:
    :func:`~simtune.optimize.start_check.warn_about_start`) before the phase goes on - the opening's, so that
    a user hears it before the long global rounds."""
    search.evaluator.parent_energies = None  # no parents to prune against in a local phase
    names = search.space.names

    def warn(jacobian: np.ndarray, residuals: np.ndarray) -> None:
        warn_about_start(names, start, search.lows, search.highs, jacobian, residuals)

    return least_squares_phase(
        search, start, max_nfev=LOCAL_NFEV, ftol=STALL_FTOL, on_first_jacobian=warn if diagnose else None
    )


def aligned_generic_start(objective: Objective) -> np.ndarray:
    """The generic point of ``objective``'s space with each task's command delay aligned to its recordings (a delay
    tasks share: the median of theirs).

    A parameter without a generic value (none of the engine's, the controller's or the task's) starts mid-range.

    Args:
        objective: the run's objective.
    Returns:
        The point, as a vector of the objective's space.
    """
    space = objective.vector_space()
    values = generic_values(objective, space.names)
    estimates: dict[str, list[float]] = {}
    for task in objective.tasks:
        for name in delay_names(task.name):
            if name in space.names:
                estimates.setdefault(name, []).append(cached_delay(objective, task, values).delay_s)
                break
    # a delay several tasks share (commands logged on one clock: one robot's) starts at their estimates' median
    values.update({name: float(np.median(found)) for name, found in estimates.items()})
    return space.vector_within_bounds(values)


def opening_population(best: np.ndarray, seed: int) -> np.ndarray:
    """The first global phase's population after the opening, in the unit cube: its best point ``best`` first,
    ``NEAR_SHARE`` of the members drawn around it (normal, ``NEAR_SCALE`` of each range, within the cube) and the
    rest a latin hypercube (:func:`random_start`); DE's population size, as SciPy draws its own.

    Where the opening's least squares stalls, the objective is not smooth at its finite-difference scale (the
    cube's contact, the time step's whole steps per control period), and differential evolution's moves among
    members a few per cent apart find the way on; a population spread over the whole box leaves it at the
    opening's point for the round (measured: docs/performance.md, "The opening's population")."""
    dim = len(best)
    rng, unit, first_random = _opening_draw(dim, seed)
    unit[1:first_random] = np.clip(best + rng.normal(0.0, NEAR_SCALE, (first_random - 1, dim)), 0.0, 1.0)
    unit[0] = best
    return unit


def random_start(dim: int, seed: int) -> np.ndarray:
    """The members of the first global phase that ``opening_population`` leaves drawn at random over the whole
    unit cube (its latin-hypercube rows), for a space of ``dim`` parameters and the run's ``seed``: they depend on
    nothing else, so the report finds them again in any run store as its untuned baseline."""
    _, unit, first_random = _opening_draw(dim, seed)
    return unit[first_random:]


def global_population_size(dim: int) -> int:
    """Members of a global phase's population for ``dim`` parameters (SciPy's, with the paper's 1 x D)."""
    return max(5, POPSIZE * dim)


def _opening_draw(dim: int, seed: int) -> tuple[np.random.Generator, np.ndarray, int]:
    """The seeded stream of the opening's population, its latin hypercube drawn first, and the first row that
    stays random (rows 1 to it are drawn around the opening's best point)."""
    size = global_population_size(dim)
    rng = np.random.default_rng(seed)
    from scipy.stats import qmc  # here, not above: scipy.stats takes half a second to import, after the opening

    unit = qmc.LatinHypercube(d=dim, rng=rng).random(size)
    return rng, unit, 1 + int(NEAR_SHARE * size)


def as_originals(vectors: np.ndarray, points: np.ndarray, tolerance: np.ndarray) -> np.ndarray:
    """``vectors`` (one per row) with each that lies within ``tolerance`` (per parameter) of a row of ``points``
    replaced by that row: a point moved by rounding errors is the point itself.

    SciPy's differential evolution scales an ``init`` population into its unit cube and back before scoring it,
    which moves a coordinate by a rounding error: without this, every member of a population scored already (the
    last round's, the opening's best) would be simulated again as a new point, a whole batch per round.

    Args:
        vectors: the vectors, one per row.
        points: the points they may be copies of, one per row.
        tolerance: the largest difference per parameter that counts as rounding.
    Returns:
        A new array of ``vectors``' shape.
    """
    out = np.array(vectors, dtype=float)
    if out.ndim != 2 or len(points) == 0 or out.shape[1] != np.shape(points)[1]:
        return out
    for i, x in enumerate(out):
        near = np.flatnonzero(np.all(np.abs(points - x) <= tolerance, axis=1))
        if len(near):
            out[i] = points[near[0]]
    return out


def _global_phase(search: BatchSearch, init: np.ndarray | None, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``GLOBAL_GENERATIONS`` generations of differential evolution (the paper's settings) from ``init`` (None:
    a latin hypercube); its last population and their fitness."""
    last: list[tuple[np.ndarray, np.ndarray]] = []
    spent = False

    def checkpoint(intermediate_result) -> bool:
        nonlocal spent
        population = np.array(intermediate_result.population, dtype=float)
        energies = np.array(intermediate_result.population_energies, dtype=float)
        search.evaluator.parent_energies = energies
        search.track(population, energies)
        last.append((population, energies))
        spent = search.checkpoint(population, energies)
        return spent

    search.evaluator.parent_energies = None
    workers: Callable = search.evaluator
    if init is not None:  # members scored already: SciPy's scaling moves them by rounding errors only
        tolerance = ROUNDING * np.maximum(search.highs - search.lows, np.abs(init).max(axis=0))
        first_batch = True

        def workers(func, vectors):  # the Evaluator, its first batch (the population SciPy starts from) as given
            nonlocal first_batch
            if first_batch:
                first_batch = False
                vectors = as_originals(np.asarray(vectors, dtype=float), init, tolerance)
            return search.evaluator(func, vectors)

    differential_evolution(
        lambda x: search.objective.score_vector(x).fitness,  # never called: the Evaluator is the workers map
        bounds=search.space.bounds,
        maxiter=GLOBAL_GENERATIONS,
        rng=np.random.default_rng(seed),
        workers=workers,
        callback=checkpoint,
        **{**DE_SETTINGS, **({"init": init} if init is not None else {})},
    )
    if spent:
        raise BudgetSpent
    population, energies = last[-1]
    if init is not None:  # members SciPy kept since its start are the points it was given, not their rounded copies
        population = as_originals(population, init, tolerance)
    return population, energies
