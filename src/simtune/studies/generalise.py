"""``simtune generalise``: is the tuned simulator one of the robot, or one of the task it saw?

For a project's recorded tasks it tunes each task alone, all of them together, and (with three tasks or
more) every set that leaves one task out, each an ordinary resumable run under ``OUT``.  Then it scores
each task four ways against its own recordings:

* its **floor**: the real arm against itself (its repeats against their aligned mean), what no simulation beats;
* **alone**: tuned on that task alone, the best a simulator does for it;
* **joint**: its part of the fit tuned on every task together; ``joint / alone`` is the *joint-fit penalty*,
  1 where one parameter set is right for every task, above 1 where each task bends the parameters its own way;
* **held out**: tuned on the other tasks only, its own recording clock aligned (the command delay of a
  recording is its clock's, not the physics': :func:`simtune.alignment.estimate_delay`, the tuned physics held
  fixed), what a user running a motion never recorded can expect.

With two tasks the leave-one-out runs are the other task's alone runs: none is tuned twice.  Run again into
the same folder, finished runs are reused and unfinished ones resumed; a folder holding runs of other settings
is refused.
"""

from __future__ import annotations

import dataclasses
import json
import statistics
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

from simtune.alignment import estimate_delay
from simtune.errors import ConfigError
from simtune.fitness import FitnessWeights, reference_floor
from simtune.objective import Objective, load_references
from simtune.params.kinds import delay_names, task_delay_name
from simtune.run_config import RunConfig
from simtune.studies.transfer import tuned_run
from simtune.tasks import TaskSpec, parse_tasks

RESULT_FILE = "generalise.json"
ALONE_FOLDER = "alone"
JOINT_FOLDER = "joint"
WITHOUT_FOLDER = "without"


@dataclass(frozen=True)
class Fit:
    """One task scored with one parameter set: its fitness and wrist part (None: no wrist marker), and the
    command delay it ran with [s] where the study aligned its clock (None: the parameters' own)."""

    fitness: float
    wrist: float | None
    delay_s: float | None = None


@dataclass(frozen=True)
class TaskGeneralisation:
    """One task's row of the study (see the module's notes); ``floor`` None: one repeat, no floor."""

    task: str
    floor: float | None
    alone: Fit
    joint: Fit
    held_out: Fit
    #: the tasks the held-out parameters were tuned on
    held_out_from: tuple[str, ...]

    @property
    def penalty(self) -> float:
        """The joint-fit penalty: the task's part of the joint fit over its fit tuned alone (1: no penalty)."""
        return self.joint.fitness / self.alone.fitness if self.alone.fitness else float("inf")

    @property
    def transfer(self) -> float:
        """The held-out score over the alone score: what not having recorded this motion costs (1: nothing)."""
        return self.held_out.fitness / self.alone.fitness if self.alone.fitness else float("inf")

    def to_json(self) -> dict:
        ratio = (lambda f: None) if not self.floor else (lambda f: f / self.floor)
        return {
            "task": self.task,
            "floor": self.floor,
            "alone": asdict(self.alone),
            "joint": asdict(self.joint),
            "held_out": asdict(self.held_out),
            "held_out_from": list(self.held_out_from),
            "penalty": self.penalty,
            "transfer": self.transfer,
            "alone_over_floor": ratio(self.alone.fitness),
            "joint_over_floor": ratio(self.joint.fitness),
            "held_out_over_floor": ratio(self.held_out.fitness),
        }


def study_runs(config: RunConfig, out: Path) -> dict[str, tuple[RunConfig, Path]]:
    """The runs the study needs, by label: ``alone/<task>``, ``joint`` and (three tasks or more)
    ``without/<task>``, each its settings (``config`` with its tasks replaced) and folder under ``out``."""
    names = [t.name for t in parse_tasks(config.tasks, config.project, config.targets, config.loading)]
    if len(names) < 2:
        raise ConfigError(
            f"tasks: generalise needs two tasks or more to tune together and leave out, got {config.tasks!r}"
        )
    runs = {}
    for name in names:
        runs[f"{ALONE_FOLDER}/{name}"] = (dataclasses.replace(config, tasks=name), out / ALONE_FOLDER / name)
    runs[JOINT_FOLDER] = (config, out / JOINT_FOLDER)
    if len(names) > 2:
        for name in names:
            rest = ",".join(n for n in names if n != name)
            runs[f"{WITHOUT_FOLDER}/{name}"] = (dataclasses.replace(config, tasks=rest), out / WITHOUT_FOLDER / name)
    return runs


def run_generalisation(
    config: RunConfig,
    out: Path,
    show_progress: bool = True,
    on_run: Callable[[int, int, str, Path], None] | None = None,
) -> dict:
    """Tune ``config.tasks`` alone, together and leaving each out; score every task each way.

    Args:
        config: the settings of every run (its tasks: two or more).
        out: the study's folder: the runs (``alone/<task>``, ``joint``, ``without/<task>``) and generalise.json.
        show_progress: draw each run's progress bar.
        on_run: called before each run with its number, the number of runs, its label and its folder.

    Returns:
        The study as OUT/generalise.json holds it: the settings, each task's row
        (:meth:`TaskGeneralisation.to_json`), the runs' folders and their evaluations.
    """
    out = Path(out)
    tasks = parse_tasks(config.tasks, config.project, config.targets, config.loading)
    runs = study_runs(config, out)
    root = None if config.data is None else Path(config.data)
    # every recording is read (and refused) before the first run is tuned
    references = load_references(root, tasks, config.joint_topic, config.reference, config.repeats, config.keep_repeats)
    aligned = (
        references
        if config.reference == "aligned"
        else load_references(root, tasks, config.joint_topic, "aligned", config.repeats, config.keep_repeats)
    )
    results = {}
    for number, (label, (run_config, folder)) in enumerate(runs.items(), start=1):
        if on_run is not None:
            on_run(number, len(runs), label, folder)
        results[label] = tuned_run(run_config, folder, show_progress)
    weights = None if config.weights is None else FitnessWeights.from_mapping(config.weights, "weights")
    names = [t.name for t in tasks]
    rows = []
    for task in tasks:
        others = tuple(n for n in names if n != task.name)
        held_label = f"{ALONE_FOLDER}/{others[0]}" if len(names) == 2 else f"{WITHOUT_FOLDER}/{task.name}"
        objective = Objective(config.engine, [task], {task.name: references[task.name]}, weights=weights)
        try:
            rows.append(
                TaskGeneralisation(
                    task=task.name,
                    floor=reference_floor(aligned[task.name]).floor,
                    alone=_fit(objective, results[f"{ALONE_FOLDER}/{task.name}"].params),
                    joint=_fit(objective, results[JOINT_FOLDER].params),
                    held_out=_held_out_fit(objective, task, results[held_label].params),
                    held_out_from=others,
                )
            )
        finally:
            objective.close()
    result = {
        "engine": config.engine,
        "tasks": names,
        "space": config.space,
        "optimizer": config.optimizer,
        "seed": config.seed,
        "data": config.data,
        "reference": config.reference,
        "runs": {label: str(folder) for label, (_, folder) in runs.items()},
        "evaluations": {label: r.evaluations for label, r in results.items()},
        "rows": [r.to_json() for r in rows],
        "joint_penalty": statistics.median(r.penalty for r in rows),
        "transfer": statistics.median(r.transfer for r in rows),
    }
    out.mkdir(parents=True, exist_ok=True)
    (out / RESULT_FILE).write_text(json.dumps(result, indent=1) + "\n")
    return result


def _fit(objective: Objective, params: dict[str, float]) -> Fit:
    score = objective.score(params)
    return Fit(score.fitness, score.wrist_error)


def _held_out_fit(objective: Objective, task: TaskSpec, params: dict[str, float]) -> Fit:
    """``task`` scored with parameters tuned without it, its own clock aligned with the physics held fixed."""
    estimate = estimate_delay(objective, task, params)
    physics = {k: v for k, v in params.items() if k not in delay_names(task.name)}
    score = objective.score({**physics, task_delay_name(task.name): estimate.delay_s})
    return Fit(score.fitness, score.wrist_error, estimate.delay_s)
