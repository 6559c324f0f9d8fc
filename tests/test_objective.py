"""Several tasks tuned together: their fitness is summed, as the paper's experiment 11."""

import pytest

from simtune.objective import Objective, load_references
from simtune.tasks import parse_tasks


def test_fitness_of_several_tasks_is_the_sum(two_task_data):
    both = parse_tasks("single,cube")
    refs = load_references(two_task_data, both)
    params = {"command_delay": 1.2}
    together = Objective("mujoco", both, refs).score(params)
    apart = [Objective("mujoco", [t], refs).score(params) for t in both]
    assert together.fitness == pytest.approx(sum(s.fitness for s in apart), rel=1e-12)
    assert together.object_error == pytest.approx(apart[1].object_error)
    assert [t.task for t in together.tasks] == ["single", "cube"]


def test_bound_stops_early_with_a_lower_bound_above_it(two_task_data):
    tasks = parse_tasks("single,cube")
    objective = Objective("mujoco", tasks, load_references(two_task_data, tasks))
    exact = objective.score({"command_delay": 0.0})
    bounded = objective.score({"command_delay": 0.0}, bound=exact.fitness / 4)
    assert bounded.pruned and exact.fitness / 4 < bounded.fitness <= exact.fitness
    assert sum(t.steps for t in bounded.tasks) < sum(t.steps for t in exact.tasks)
    assert objective.score({"command_delay": 0.0}, bound=exact.fitness * 2).fitness == exact.fitness
