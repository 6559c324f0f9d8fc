"""Bayesian optimisation with Optuna's TPE sampler, seeded: ask/tell in batches of ``workers`` trials.

Optuna keeps its study in memory; the run store is what persists.  Trials of
one batch are asked before any is told (TPE's "constant liar" keeps them
apart), and the sampler is seeded, so the same seed and the same fitness
values give the same trials: a resumed run replays them from the store.
Without generations of its own, D trials count as one generation for
``max_generations``.
"""

from __future__ import annotations

import warnings

import numpy as np

from simtune.errors import SimtuneError
from simtune.objective import Objective
from simtune.optimize.base import BatchSearch, BudgetSpent
from simtune.optimize.evaluator import TuneResult, TuneSettings
from simtune.store import RunStore


def _optuna():
    try:
        import optuna
    except ImportError:
        raise SimtuneError("optimizer 'bo' needs the optuna package: pip install 'simtune[opt]'") from None
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    return optuna


def bayesian_tune(objective: Objective, store: RunStore, settings: TuneSettings) -> TuneResult:
    """TPE (multivariate, 10 random start-up trials) over the parameter ranges; batches of ``workers`` trials."""
    optuna = _optuna()
    space = objective.vector_space()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        sampler = optuna.samplers.TPESampler(
            seed=settings.seed, multivariate=True, constant_liar=True, n_startup_trials=10
        )
    study = optuna.create_study(direction="minimize", sampler=sampler)
    distributions = {p.name: optuna.distributions.FloatDistribution(p.low, p.high) for p in space.parameters}
    search = BatchSearch(objective, store, settings, generation_size=len(space))
    start = search.starting_points()
    for row in start if start is not None else []:  # asked first, before TPE proposes anything
        study.enqueue_trial(dict(zip(distributions, (float(v) for v in row))))
    size = max(1, int(settings.workers))
    with search:
        try:
            while True:
                left = search.remaining()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
                    trials = [study.ask(distributions) for _ in range(size if left is None else min(size, left))]
                batch = np.array([[t.params[name] for name in space.names] for t in trials], dtype=np.float64)
                fitness = search.evaluate(batch)
                for trial, f in zip(trials, fitness):
                    study.tell(trial, float(f))
                if search.checkpoint(batch, fitness):
                    break
        except BudgetSpent:  # the time cap cut a batch
            pass
        return search.result()
