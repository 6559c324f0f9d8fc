"""``simtune compare``: optimisers head to head on the same budget of evaluations.

Each optimiser runs once per seed as an ordinary run (``OUT/<optimizer>/seed-<s>/``,
resumable, readable by ``simtune report``) with ``max_evaluations`` = the
budget.  The comparison reads each run store's evaluations in the order they
were stored and takes the first ``budget`` of them (DE finishes its last
generation, so it may have a few more): the best fitness so far after 25, 50
and 100 % of the budget, and the number of evaluations until the best fitness
first reached ``target``.  Medians are over seeds; an evaluation count is the
median only if at least half the seeds reached the target ("-" otherwise).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from simtune.errors import ConfigError, SimtuneError
from simtune.optimize import get_optimizer
from simtune.runs import RunConfig, resume_run, start_run
from simtune.store import STORE_FILE, RunStore

FRACTIONS = (0.25, 0.5, 1.0)
RESULT_FILE = "compare.json"


@dataclass
class RunCurve:
    optimizer: str
    seed: int
    best_so_far: list[float]  # best fitness after each of the first `budget` evaluations, in store order
    wall_s: float
    run_dir: str

    def best_at(self, fraction: float, budget: int) -> float:
        k = max(1, math.ceil(fraction * budget))
        return self.best_so_far[min(k, len(self.best_so_far)) - 1]

    def evaluations_to(self, target: float | None) -> int | None:
        if target is None:
            return None
        hits = np.flatnonzero(np.asarray(self.best_so_far) <= target)
        return int(hits[0]) + 1 if hits.size else None


@dataclass
class OptimizerSummary:
    optimizer: str
    seeds: int
    best: dict[str, float]  # "25%" -> median over seeds of the best fitness after 25 % of the budget
    evaluations_to_target: float | None  # median over seeds (None: fewer than half reached it)
    reached: int  # seeds that reached the target
    median_wall_s: float


def curve_from_store(run_dir: Path, budget: int) -> tuple[list[float], float]:
    """Best fitness so far over the first ``budget`` stored evaluations of a run, and its wall time."""
    store = RunStore.open_read_only(run_dir)
    try:
        fitness = [row["fitness"] for row in store.evaluations()[:budget]]
        wall = float(store.get("elapsed_s", 0.0) or 0.0)
    finally:
        store.close()
    if not fitness:
        raise SimtuneError(f"{run_dir}: no evaluations in the run store")
    return np.minimum.accumulate(np.asarray(fitness, dtype=float)).tolist(), wall


def _median_count(counts: list[int | None]) -> float | None:
    """Median with "never" as +infinity; None when the median itself is never."""
    values = sorted(math.inf if c is None else c for c in counts)
    median = float(np.median(values)) if values else math.inf
    return None if math.isinf(median) or math.isnan(median) else median


def summarise(
    curves: list[RunCurve], optimizers: list[str], budget: int, target: float | None
) -> list[OptimizerSummary]:
    rows = []
    for name in optimizers:
        mine = [c for c in curves if c.optimizer == name]
        best = {f"{round(f * 100)}%": float(np.median([c.best_at(f, budget) for c in mine])) for f in FRACTIONS}
        counts = [c.evaluations_to(target) for c in mine]
        rows.append(
            OptimizerSummary(
                name,
                len(mine),
                best,
                _median_count(counts) if target is not None else None,
                sum(c is not None for c in counts),
                float(np.median([c.wall_s for c in mine])),
            )
        )
    return rows


def run_compare(
    base: RunConfig,
    optimizers: list[str],
    seeds: int,
    budget: int,
    out: Path,
    target: float | None = None,
    on_run: Callable[[str, int, str], None] | None = None,
) -> dict:
    """Run (or resume, or reuse) every optimiser x seed and return the comparison as a dict (also OUT/compare.json)."""
    if not optimizers:
        raise ConfigError("--optimizers: name at least one (e.g. de,cmaes,bo,random)")
    for name in optimizers:
        get_optimizer(name)
    if seeds < 1:
        raise ConfigError(f"--seeds must be at least 1, got {seeds}")
    if budget < 1:
        raise ConfigError(f"--budget-evals must be at least 1, got {budget}")
    out = Path(out)
    curves: list[RunCurve] = []
    for name in optimizers:
        for seed in range(seeds):
            run_dir = out / name / f"seed-{seed}"
            config = replace(
                base,
                optimizer=name,
                seed=seed,
                max_evaluations=budget,
                max_seconds=None,
                target_fitness=None,
                refine=False,
            )
            if (run_dir / STORE_FILE).exists():
                stored = RunStore(run_dir)
                try:
                    # a run stored before the choice of reference scored against the mean
                    same = {"reference": "mean", **(stored.get("config") or {})} == config.record()
                    finished = stored.get("status") == "finished"
                finally:
                    stored.close()
                if not same:
                    raise SimtuneError(f"{run_dir} holds a run with other settings: choose another --out")
                if not finished:
                    if on_run:
                        on_run(name, seed, "resuming")
                    resume_run(run_dir, show_progress=False)
            else:
                if on_run:
                    on_run(name, seed, "running")
                start_run(config, run_dir, show_progress=False)
            best, wall = curve_from_store(run_dir, budget)
            curves.append(RunCurve(name, seed, best, wall, str(run_dir)))
    summary = summarise(curves, optimizers, budget, target)
    result = {
        "engine": base.engine,
        "tasks": base.tasks,
        "space": base.space,
        "reference": base.reference,
        **({"repeats": base.repeats} if base.repeats != "all" else {}),
        "data": base.data,
        "only": base.only,
        "budget": budget,
        "seeds": seeds,
        "target": target,
        "workers": base.workers,
        "summary": [asdict(s) for s in summary],
        "runs": [asdict(c) for c in curves],
    }
    (out / RESULT_FILE).write_text(json.dumps(result, indent=1) + "\n")
    return result


def markdown_table(result: dict) -> str:
    """The comparison as a Markdown table (what the CLI prints, for README and reports)."""
    target = result["target"]
    head = [
        "optimizer",
        *(f"best @ {k}" for k in ("25%", "50%", "100%")),
        f"evals to {target:g}" if target is not None else "evals to target",
        "reached",
        "wall [s]",
    ]
    lines = ["| " + " | ".join(head) + " |", "|---|" + "---:|" * (len(head) - 1)]
    for s in result["summary"]:
        count = "-" if s["evaluations_to_target"] is None else f"{s['evaluations_to_target']:g}"
        reached = f"{s['reached']}/{s['seeds']}" if target is not None else "-"
        lines.append(
            "| "
            + " | ".join(
                [
                    s["optimizer"],
                    *(f"{s['best'][k]:.4f}" for k in ("25%", "50%", "100%")),
                    count,
                    reached,
                    f"{s['median_wall_s']:.0f}",
                ]
            )
            + " |"
        )
    return "\n".join(lines) + "\n"
