"""``simtune grid --plan``: a grid's size and cost, measured before anything runs."""

from __future__ import annotations

import time
from pathlib import Path

from simtune.grid.spec import GridSpec


def plan_grid(spec: GridSpec, samples: int = 3, seed: int = 0) -> list[dict]:
    """Size and cost of ``spec``: per engine x experiment x space, measured seconds per evaluation.

    The cost of an evaluation is measured at ``samples`` random points of the
    space (the time step, which dominates it, varies across the search), and a
    run is costed at ``max_generations + 1`` populations of 1 x D members, capped
    by ``max_seconds_per_run``: an upper bound, as most runs converge earlier.
    """
    import numpy as np

    from simtune.engines import engine_class
    from simtune.objective import Objective, load_references
    from simtune.params import get_space
    from simtune.tasks import parse_tasks

    spec.validate()
    rng = np.random.default_rng(seed)
    rows = []
    for engine in spec.engines:
        for entry in spec.tasks:
            tasks = parse_tasks(entry.replace("+", ","))
            refs = load_references(Path(spec.data), tasks, reference=spec.reference, repeats=spec.repeat_set)
            for space_name in spec.spaces:
                space = get_space(space_name, engine_class(engine).supported(), spec.only)
                objective = Objective(engine, tasks, refs, space)
                lo, hi = np.array(space.bounds).T
                objective.score_vector(lo + (hi - lo) / 2)  # build the engines outside the timing
                t0 = time.perf_counter()
                for _ in range(samples):
                    objective.score_vector(lo + rng.random(len(space)) * (hi - lo))
                cost = (time.perf_counter() - t0) / samples
                objective.close()
                evaluations = max(5, len(space)) * (spec.max_generations + 1)
                run_s = evaluations * cost
                if spec.max_seconds_per_run is not None:
                    run_s = min(run_s, spec.max_seconds_per_run)
                rows.append(
                    dict(
                        engine=engine,
                        tasks=entry,
                        space=space_name,
                        parameters=len(space),
                        eval_s=cost,
                        evaluations_per_run=evaluations,
                        run_hours=run_s / 3600,
                        repeats=spec.repeats,
                        core_hours=spec.repeats * run_s / 3600,
                    )
                )
    return rows
