"""Optimisers behind one interface, and the least-squares refinement of a best point.

Every optimiser is a function ``tune(objective, store, settings: TuneSettings) -> TuneResult``
that scores batches through :class:`~simtune.optimize.evaluator.Evaluator` (run
store cache, process pool) and keeps its budgets with
:class:`~simtune.optimize.base.BatchSearch`.  Each is deterministic given its
seed and the fitness values, so ``simtune resume`` replays it with every stored evaluation reused.

:data:`simtune.optimizers.OPTIMIZER_TABLE` names and describes each (``auto``, ``de``, ``cmaes``, ``bo``,
``random``) and the package it needs; :data:`OPTIMIZERS` holds their functions.

Only DE prunes (a trial stops once it cannot beat its parent); the others
have no parent to compare with.  :func:`least_squares_refine` polishes a
point with SciPy's bounded least squares on the per-sample residuals.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable

from simtune.errors import ConfigError, SimtuneError
from simtune.optimize.evaluator import Evaluator, TuneResult, TuneSettings
from simtune.optimize.refine import least_squares_refine
from simtune.optimizers import OPTIMIZER_TABLE


def _function(path: str) -> Callable[..., TuneResult]:
    """The function a table entry names as ``module:function``, imported now."""
    module, name = path.split(":")
    return getattr(importlib.import_module(module), name)


#: Every optimiser's function, by name (:data:`~simtune.optimizers.OPTIMIZER_TABLE` says what each is).
OPTIMIZERS: dict[str, Callable[..., TuneResult]] = {
    name: _function(entry.function) for name, entry in OPTIMIZER_TABLE.items()
}

#: The package an optimiser needs beyond simtune's core dependencies.
REQUIRES = {name: entry.requires for name, entry in OPTIMIZER_TABLE.items() if entry.requires}


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
