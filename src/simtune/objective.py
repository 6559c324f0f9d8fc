"""The objective: parameter values in, fitness out, for one engine on one or more tasks.

An :class:`Objective` holds only plain data (engine name, task specs, the
resampled recordings), so it pickles cheaply to worker processes; each process
builds its engines on first use and keeps them, resetting them between
evaluations instead of rebuilding.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from simtune.data import TaskData, load_task_data
from simtune.engines import Engine, engine_class, make_engine
from simtune.errors import SimtuneError
from simtune.fitness import Score, TaskScore, score_rollout
from simtune.params import ParameterSpace
from simtune.tasks import TaskSpec


def load_references(root: Path, tasks: list[TaskSpec]) -> dict[str, TaskData]:
    """The recordings of each task, from ``root/<task name>/``."""
    root = Path(root)
    if not root.is_dir():
        raise SimtuneError(f"data folder {root} does not exist (expected {root}/<task>/*.tsv)")
    refs = {}
    for task in tasks:
        folder = root / task.name
        if not folder.is_dir():
            raise SimtuneError(f"no recordings for task {task.name!r}: folder {folder} does not exist")
        refs[task.name] = load_task_data(
            folder, task.name, wrist_body=task.wrist_body,
            object_body=task.object.mocap_body if task.object is not None else None,
        )
    return refs


class Objective:
    """Scores parameter dicts (or vectors of a space) for ``engine`` on ``tasks``."""

    def __init__(self, engine: str, tasks: list[TaskSpec], references: dict[str, TaskData],
                 space: ParameterSpace | None = None):
        engine_class(engine)  # fail early on an unknown or missing engine
        self.engine = engine
        self.tasks = list(tasks)
        self.references = references
        self.space = space
        self._engines: dict[str, Engine] = {}

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_engines"] = {}  # engine handles stay in the process that made them
        return state

    def _engine(self, task: TaskSpec) -> Engine:
        if task.name not in self._engines:
            self._engines[task.name] = make_engine(self.engine, task)
        return self._engines[task.name]

    def rollouts(self, params: dict[str, float]) -> dict:
        """Each task's rollout for ``params``, as long as its recordings."""
        return {t.name: self._engine(t).rollout(params, len(self.references[t.name].times)) for t in self.tasks}

    def score(self, params: dict[str, float], bound: float | None = None) -> Score:
        """Fitness of ``params`` over all tasks.

        With ``bound``, simulation stops as soon as the error accumulated so far
        proves the fitness will exceed ``bound`` (every remaining sample can only
        add to it); the score is then a flagged lower bound that still exceeds
        ``bound``.  The optimiser passes a trial's parent fitness: a trial that
        cannot beat its parent is rejected either way, so the search is unchanged.
        """
        scores: list[TaskScore] = []
        spent = 0.0
        offset = np.array([params.get(f"marker_offset_{a}", 0.0) for a in "xyz"])
        for task in self.tasks:
            reference = self.references[task.name]
            n = len(reference.times)
            monitor = None
            if bound is not None:
                # the summed marker error that proves the bound exceeded (with a margin far above
                # rounding, so the rescored lower bound is sure to exceed it too)
                budget = (bound - spent) * n * (1 + 1e-9) + 1e-12
                accumulated = [0.0]

                def monitor(k, pos, rot, reference=reference, budget=budget, accumulated=accumulated):
                    accumulated[0] += float(np.linalg.norm(pos + rot @ offset - reference.wrist_mean[k]))
                    return accumulated[0] > budget

            rollout = self._engine(task).rollout(params, n, monitor=monitor)
            scores.append(score_rollout(rollout, reference, params))
            spent += scores[-1].fitness
            if bound is not None and spent > bound:
                break  # the remaining tasks cannot lower the sum
        return Score.combine(scores)

    def score_vector(self, x, bound: float | None = None) -> Score:
        assert self.space is not None, "score_vector needs a parameter space"
        return self.score(self.space.to_dict(x), bound)

    def close(self) -> None:
        for engine in self._engines.values():
            engine.close()
        self._engines.clear()
