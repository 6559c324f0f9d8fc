"""Random search: uniform samples of the parameter space, in batches of D (one "generation").

The baseline every other optimiser has to beat.  A seeded NumPy generator
draws each batch, so the same seed gives the same points and a resumed run
replays them from the store.
"""

from __future__ import annotations

import numpy as np

from simtune.objective import Objective
from simtune.optimize.base import BatchSearch, BudgetSpent
from simtune.optimize.evaluator import TuneResult, TuneSettings
from simtune.store import RunStore


def random_search_tune(objective: Objective, store: RunStore, settings: TuneSettings) -> TuneResult:
    """Uniform random search; a generation is a batch of D points (D = number of parameters)."""
    dim = len(objective.vector_space())
    rng = np.random.default_rng(settings.seed)
    search = BatchSearch(objective, store, settings, generation_size=dim)
    with search:
        try:
            first = search.initial_batch()
            if first is not None and first[2]:
                return search.result()
            while True:
                left = search.remaining()
                size = dim if left is None else min(dim, left)
                u = rng.random((dim, dim))[:size]  # always draw a full batch: the stream does not depend on the budget
                batch = search.from_unit(u)
                if search.checkpoint(batch, search.evaluate(batch)):
                    break
        except BudgetSpent:  # the time cap cut a batch
            pass
        return search.result()
