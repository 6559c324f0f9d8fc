"""Optimisers behind one interface, and the least-squares refinement of a best point.

Every optimiser is a function ``tune(objective, store, settings: TuneSettings) -> TuneResult``
that scores batches through :class:`~simtune.optimize.evaluator.Evaluator` (run
store cache, process pool) and keeps its budgets with
:class:`~simtune.optimize.base.BatchSearch`.  Each is deterministic given its
seed and the fitness values, so ``simtune resume`` replays it with every stored evaluation reused.

- ``auto``: rounds of a short differential evolution then least squares on the residuals (:mod:`.pipeline`);
- ``de``: the seed paper's differential evolution (SciPy), unchanged;
- ``cmaes``: CMA-ES with restarts (``cmaes`` package);
- ``bo``: Bayesian optimisation, Optuna's seeded TPE sampler;
- ``random``: uniform random search.

Only DE prunes (a trial stops once it cannot beat its parent); the others
have no parent to compare with.  :func:`least_squares_refine` polishes a
point with SciPy's bounded least squares on the per-sample residuals.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable

from simtune.errors import ConfigError, SimtuneError
from simtune.optimize.bayes import bayesian_tune
from simtune.optimize.cmaes_search import cmaes_tune
from simtune.optimize.de import differential_evolution_tune
from simtune.optimize.evaluator import Evaluator, TuneResult, TuneSettings
from simtune.optimize.pipeline import global_local_tune
from simtune.optimize.random_search import random_search_tune
from simtune.optimize.refine import least_squares_refine

OPTIMIZERS: dict[str, Callable[..., TuneResult]] = {
    "de": differential_evolution_tune,
    "cmaes": cmaes_tune,
    "bo": bayesian_tune,
    "random": random_search_tune,
    "auto": global_local_tune,
}

#: The package an optimiser needs beyond simtune's core dependencies.
REQUIRES = {"cmaes": "cmaes", "bo": "optuna"}


def get_optimizer(name: str) -> Callable[..., TuneResult]:
    """The optimiser ``name``; a one-line error for an unknown one or one whose package is missing."""
    try:
        tune = OPTIMIZERS[name]
    except KeyError:
        raise ConfigError(f"unknown optimizer {name!r} (known: {', '.join(OPTIMIZERS)})") from None
    if name in REQUIRES:
        try:
            importlib.import_module(REQUIRES[name])
        except ImportError:
            raise SimtuneError(
                f"optimizer {name!r} needs the {REQUIRES[name]} package: pip install 'simtune[opt]'"
            ) from None
    return tune


__all__ = [
    "OPTIMIZERS",
    "Evaluator",
    "TuneResult",
    "TuneSettings",
    "get_optimizer",
    "least_squares_refine",
]
