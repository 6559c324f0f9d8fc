"""The optimisers' table: each one's name, its function, what it is and the package it needs beyond simtune's core.

The one place an optimiser is described.  It is data only (each function named by module path), so that the
command line describes the optimisers (every command's ``--optimizer`` help) without importing them (a second
of SciPy and Optuna); :data:`simtune.optimize.OPTIMIZERS` imports the functions from it.
"""

from __future__ import annotations

from typing import NamedTuple


class OptimizerEntry(NamedTuple):
    """One optimiser of the table."""

    #: ``module:function`` of its ``tune(objective, store, settings) -> TuneResult``
    function: str
    #: what it is, in a phrase (the ``--optimizer`` help)
    about: str
    #: the package it needs beyond simtune's core dependencies (installed by ``pip install 'simtune[opt]'``)
    requires: str | None = None


#: Every optimiser, by name, in the order ``unknown optimizer`` lists them.
OPTIMIZER_TABLE: dict[str, OptimizerEntry] = {
    "de": OptimizerEntry("simtune.optimize.de:differential_evolution_tune", "differential evolution as in the paper"),
    "cmaes": OptimizerEntry("simtune.optimize.cmaes_search:cmaes_tune", "CMA-ES with restarts", requires="cmaes"),
    "bo": OptimizerEntry(
        "simtune.optimize.bayes:bayesian_tune",
        "Bayesian optimisation (Optuna TPE, batches of --workers trials)",
        requires="optuna",
    ),
    "random": OptimizerEntry("simtune.optimize.random_search:random_search_tune", "uniform random search"),
    "auto": OptimizerEntry(
        "simtune.optimize.pipeline:global_local_tune",
        "a least-squares opening from the generic point with each task's clock aligned to its recordings, then "
        "rounds of a short DE and least squares on the residuals (see the README's Speed)",
    ),
}


def optimizer_help() -> str:
    """What each optimiser is, in one paragraph: every command's ``--optimizer`` help.

    Returns:
        ``"de: ...; cmaes: ...; ... cmaes and bo need `pip install 'simtune[opt]'`."``
    """
    described = "; ".join(f"{name}: {entry.about}" for name, entry in OPTIMIZER_TABLE.items())
    needing = [name for name, entry in OPTIMIZER_TABLE.items() if entry.requires]
    return f"{described}. {' and '.join(needing)} need `pip install 'simtune[opt]'`."
