"""``simtune transfer``: do parameters tuned on some tasks carry over to tasks never tuned on?

Tunes the engine on the train tasks together (an ordinary, resumable run in
``OUT/run``), then scores the tuned and the generic parameters on every train
and every test task.  A transfer is good when the test tasks improve about as
much as the train tasks did.  Parameters the test tasks do not use (e.g. the
mass of an object they lack) have no effect there.

The command delay is a property of each recording's clock, not of the physics: by default
each test task's clock is aligned (:func:`simtune.alignment.estimate_delay`, the tuned physics
held fixed) and its tuned fitness reported both with and without that alignment
(``align_clock=False``: without only).
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

from simtune.alignment import estimate_delay
from simtune.data import TaskData
from simtune.errors import ConfigError, SimtuneError
from simtune.fitness import FitnessWeights
from simtune.objective import Objective, load_references
from simtune.optimize import TuneResult
from simtune.runs import RunConfig, resume_run, start_run
from simtune.store import STORE_FILE, RunStore
from simtune.tasks import TaskSpec, parse_tasks

RUN_FOLDER = "run"
RESULT_FILE = "transfer.json"


@dataclass
class TaskResult:
    task: str
    role: str  # "train" or "test"
    generic: float
    tuned: float
    tuned_wrist: float | None  # None: recordings without a wrist marker
    tuned_object: float | None
    stable: bool
    #: test tasks: the tuned fitness with the task's own clock aligned, and the delay found (None: not aligned)
    tuned_aligned: float | None = None
    delay_s: float | None = None

    @property
    def change(self) -> float:
        """Relative change of the fitness, tuned vs generic (negative: better)."""
        return (self.tuned - self.generic) / self.generic if self.generic else 0.0


def run_transfer(
    config: RunConfig,
    test: str,
    out: Path,
    test_data: Path | None = None,
    show_progress: bool = True,
    align_clock: bool = True,
) -> dict:
    """Tune on ``config.tasks``, score on them and on ``test``; the result as a dict (also OUT/transfer.json)."""
    train_tasks = parse_tasks(config.tasks, config.project, config.targets, config.loading)
    test_tasks = parse_tasks(test, config.project, config.targets, config.loading)
    overlap = {t.name for t in train_tasks} & {t.name for t in test_tasks}
    if overlap:
        raise ConfigError(f"--test: {', '.join(sorted(overlap))} also in --train: a transfer test needs unseen tasks")
    test_root = Path(test_data) if test_data is not None else _root(config.data)
    # fail on missing test data before tuning
    test_refs = load_references(test_root, test_tasks, config.joint_topic, config.reference, config.repeats)
    out = Path(out)
    run_dir = out / RUN_FOLDER
    tuned = tuned_run(config, run_dir, show_progress)
    train_refs = load_references(_root(config.data), train_tasks, config.joint_topic, config.reference, config.repeats)
    weights = None if config.weights is None else FitnessWeights.from_mapping(config.weights, "weights")
    rows = [
        _score(config.engine, task, role, refs[task.name], tuned.params, weights, role == "test" and align_clock)
        for role, tasks, refs in (("train", train_tasks, train_refs), ("test", test_tasks, test_refs))
        for task in tasks
    ]
    result = {
        "engine": config.engine,
        "train": config.tasks,
        "test": test,
        "space": config.space,
        "data": config.data,
        "test_data": str(test_root),
        "optimizer": config.optimizer,
        "reference": config.reference,
        **({"repeats": config.repeats} if config.repeats != "all" else {}),
        "run": str(run_dir),
        "best_params_file": str(run_dir / "best_params.json"),
        "evaluations": tuned.evaluations,
        "tasks": [{**asdict(r), "change": r.change} for r in rows],
        "totals": _totals(rows),
        "clock_aligned": align_clock,
        "params": tuned.params,
    }
    (out / RESULT_FILE).write_text(json.dumps(result, indent=1) + "\n")
    return result


def tuned_run(config: RunConfig, run_dir: Path, show_progress: bool) -> TuneResult:
    """The tuning run in ``run_dir``: resumed (or reused) when it holds one of these settings, else started."""
    if not (run_dir / STORE_FILE).exists():
        return start_run(config, run_dir, show_progress=show_progress)
    store = RunStore(run_dir)
    try:
        same = store.get("config") == config.record()
    finally:
        store.close()
    if not same:
        raise SimtuneError(f"{run_dir} holds a tuning run with other settings: choose another --out")
    return resume_run(run_dir, show_progress=show_progress)


def _score(
    engine: str,
    task: TaskSpec,
    role: str,
    reference: TaskData,
    params: dict[str, float],
    weights: FitnessWeights | None,
    align_clock: bool,
) -> TaskResult:
    """One task scored with the generic and the tuned parameters (and, ``align_clock``, its own clock aligned)."""
    objective = Objective(engine, [task], {task.name: reference}, weights=weights)
    try:
        generic = objective.score({})
        score = objective.score(params)
        estimate = estimate_delay(objective, task, params) if align_clock else None
    finally:
        objective.close()
    return TaskResult(
        task.name,
        role,
        generic.fitness,
        score.fitness,
        score.wrist_error,
        score.object_error,
        score.stable,
        None if estimate is None else estimate.fitness,
        None if estimate is None else estimate.delay_s,
    )


def _totals(rows: list[TaskResult]) -> dict[str, dict[str, float]]:
    """Per role (train, test): the summed generic and tuned fitness, their relative change, and with every task's
    clock aligned the same for the aligned fitness."""
    totals = {}
    for role in ("train", "test"):
        mine = [r for r in rows if r.role == role]
        generic_sum, tuned_sum = sum(r.generic for r in mine), sum(r.tuned for r in mine)
        totals[role] = {
            "generic": generic_sum,
            "tuned": tuned_sum,
            "change": (tuned_sum - generic_sum) / generic_sum if generic_sum else 0.0,
        }
        if mine and all(r.tuned_aligned is not None for r in mine):
            aligned_sum = sum(r.tuned_aligned or 0.0 for r in mine)
            totals[role]["tuned_aligned"] = aligned_sum
            totals[role]["change_aligned"] = (aligned_sum - generic_sum) / generic_sum if generic_sum else 0.0
    return totals


def _root(data: str | None) -> Path | None:
    return None if data is None else Path(data)
