"""``simtune sensitivity``: global sensitivity of the fitness to each parameter (SALib).

The paper judges a parameter's importance after the fact, by how tightly
independent tuning runs agree on it.  A global sensitivity analysis asks the
fitness directly, over the whole space:

- ``morris`` (elementary effects): N trajectories of D + 1 points each; per
  parameter mu* = mean |change of fitness| for a step of 2/3 of its range
  (scaled to a full range), sigma = their spread (interactions,
  non-linearity).  Cheap screening; ranked by mu*.
- ``sobol`` (Saltelli sampling): N (D + 2) points, N a power of two; S1 =
  the share of the fitness variance a parameter explains alone, ST = with
  all its interactions.  Ranked by ST.

The points are scored through the same :class:`~simtune.optimize.evaluator.Evaluator`
as tuning (process pool with ``workers``, failed evaluations stored as
penalties), cached in ``OUT/sensitivity.sqlite``: running the command again,
or with more samples, reuses what was simulated.  Written to OUT:
``sensitivity.json`` (read by ``simtune report``), ``sensitivity.csv``,
``sensitivity.md`` and ``sensitivity.png``.
"""

from __future__ import annotations

import json
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from simtune.common.table import Column, Table
from simtune.engines import engine_class
from simtune.errors import ConfigError, SimtuneError
from simtune.fitness import Score
from simtune.objective import Objective, load_references
from simtune.optimize.evaluator import Evaluator
from simtune.params import get_space
from simtune.store import RunStore
from simtune.tasks import parse_tasks
from simtune.tasks.spec import common_robot

METHODS = ("morris", "sobol")
RESULT_FILE = "sensitivity.json"
STORE_NAME = "sensitivity.sqlite"
MORRIS_LEVELS = 4


def _salib():
    try:
        import SALib  # noqa: F401
    except ImportError:
        raise SimtuneError("simtune sensitivity needs the SALib package: pip install 'simtune[opt]'") from None
    from SALib.analyze import morris as morris_analyze
    from SALib.analyze import sobol as sobol_analyze
    from SALib.sample import morris as morris_sample
    from SALib.sample import sobol as sobol_sample

    return morris_sample, morris_analyze, sobol_sample, sobol_analyze


def evaluation_count(method: str, samples: int, dim: int) -> int:
    return samples * (dim + 1) if method == "morris" else samples * (dim + 2)


def run_sensitivity(
    engine: str,
    tasks: str,
    data: Path,
    space: str,
    out: Path,
    *,
    samples: int,
    method: str = "morris",
    only: list[str] | None = None,
    seed: int = 0,
    workers: int = 1,
    eval_timeout: float | None = None,
    on_evaluation: Callable[[Score, bool], None] | None = None,
) -> dict:
    """Sample, score and analyse; write the result files into ``out``; return the result dict."""
    _check_sampling(method, samples)
    _salib()  # SALib missing: its install hint before anything is read
    task_specs = parse_tasks(tasks)
    robot = common_robot(task_specs)
    sp = get_space(space, engine_class(engine).supported(robot), only, robot=robot)
    if len(sp) < 2:
        raise ConfigError(f"--only: a sensitivity analysis needs at least two parameters, got {len(sp)}")
    objective = Objective(engine, task_specs, load_references(Path(data), task_specs), sp)
    problem = {"num_vars": len(sp), "names": sp.names, "bounds": [list(b) for b in sp.bounds]}
    X = _sample(problem, method, samples, seed)
    out = Path(out)
    identity = {
        "engine": engine,
        "tasks": [t.name for t in task_specs],
        "data": str(Path(data).resolve()),
        "parameters": sp.names,
    }
    store = _open_cache(out, identity)
    evaluator = Evaluator(objective, store, workers, on_evaluation, eval_timeout, prune=False)
    try:
        with evaluator:
            Y = evaluator.evaluate(X)
        unstable = sum(1 for x in X if not (store.lookup(x) or Score(0, 0, None)).stable)
        new = evaluator.new_evaluations
    finally:
        store.close()
    rows = _analyse(problem, X, Y, method, seed)
    for rank, row in enumerate(rows, start=1):
        row["rank"] = rank
        lo, hi = sp.bounds[sp.names.index(row["parameter"])]
        row["low"], row["high"] = lo, hi
    result = {
        "engine": engine,
        "tasks": tasks,
        "space": space,
        "data": str(data),
        "method": method,
        "samples": samples,
        "seed": seed,
        "evaluations": int(len(X)),
        "new_evaluations": new,
        "unstable": unstable,
        "fitness_mean": float(np.mean(Y)),
        "fitness_std": float(np.std(Y)),
        "fitness_min": float(np.min(Y)),
        "parameters": rows,
    }
    write_outputs(result, out)
    return result


def _check_sampling(method: str, samples: int) -> None:
    if method not in METHODS:
        raise ConfigError(f"unknown sensitivity method {method!r} (known: {', '.join(METHODS)})")
    if samples < 2:
        raise ConfigError(f"--samples must be at least 2, got {samples}")
    if method == "sobol" and samples & (samples - 1):
        raise ConfigError(f"--samples {samples}: Sobol sampling needs a power of two (e.g. 64, 128, 256)")


def _sample(problem: dict, method: str, samples: int, seed: int) -> np.ndarray:
    """SALib's sample of the space: Morris trajectories or Sobol (Saltelli) points."""
    morris_sample, _, sobol_sample, _ = _salib()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # SALib's notes on sample sizes: _check_sampling covers them
        if method == "morris":
            return morris_sample.sample(problem, samples, num_levels=MORRIS_LEVELS, seed=seed)
        return sobol_sample.sample(problem, samples, calc_second_order=False, seed=seed)


def _open_cache(out: Path, identity: dict) -> RunStore:
    """The evaluation cache in ``out``; refused when it holds another engine's, task's, data's or space's."""
    store = RunStore(out, create=True, filename=STORE_NAME)
    stored = store.get("identity")
    if stored is None:
        store.set(identity=identity)
    elif stored != identity:
        store.close()
        raise SimtuneError(
            f"{out / STORE_NAME} holds evaluations of another engine, task, data or parameter "
            "list: choose another --out"
        )
    return store


#: what each method's analysis gives per parameter, the first its ranking
INDICES = {"morris": ("mu_star", "mu_star_conf", "mu", "sigma"), "sobol": ("ST", "ST_conf", "S1", "S1_conf")}


def _analyse(problem: dict, X: np.ndarray, Y: np.ndarray, method: str, seed: int) -> list[dict[str, Any]]:
    """One row per parameter, most influential first: Morris's mu* (and mu, sigma) or Sobol's ST (and S1)."""
    _, morris_analyze, _, sobol_analyze = _salib()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if method == "morris":
            res = morris_analyze.analyze(problem, X, Y, num_levels=MORRIS_LEVELS, seed=seed)
        else:
            res = sobol_analyze.analyze(problem, Y, calc_second_order=False, seed=seed)
    rows = [
        {"parameter": name, **{index: float(res[index][i]) for index in INDICES[method]}}
        for i, name in enumerate(problem["names"])
    ]
    if method == "morris":
        rows.sort(key=lambda r: (-r["mu_star"], r["parameter"]))
    else:  # an ST SALib could not estimate (NaN) last
        rows.sort(key=lambda r: (-np.nan_to_num(r["ST"], nan=-np.inf), r["parameter"]))
    return rows


# --- presentation (also used by `simtune report`) -------------------------------------------------------
def sensitivity_table(result: dict, name: str = "sensitivity") -> Table:
    """The result as a :class:`~simtune.common.table.Table`, most influential parameter first."""
    where = f"{result['engine']} on {result['tasks']} (space {result['space']})"
    note = (
        f"{result['evaluations']} evaluations ({result['unstable']} unstable, scored as the penalty); fitness "
        f"over the samples: mean {result['fitness_mean']:.4f}, std {result['fitness_std']:.4f}. "
    )
    if result["method"] == "morris":
        columns = [
            Column("rank", "d"),
            Column("parameter"),
            Column("mu*", ".4f"),
            Column("mu* 95% conf", ".4f"),
            Column("sigma", ".4f"),
            Column("mu", ".4f"),
        ]
        rows = [
            [r["rank"], r["parameter"], r["mu_star"], r["mu_star_conf"], r["sigma"], r["mu"]]
            for r in result["parameters"]
        ]
        note += (
            "Morris elementary effects, " + f"{result['samples']} trajectories: mu* = mean absolute change of "
            "the fitness [m] per full-range change of the parameter; sigma = spread of the effects "
            "(interactions, non-linearity)."
        )
    else:
        columns = [
            Column("rank", "d"),
            Column("parameter"),
            Column("ST", ".3f"),
            Column("ST 95% conf", ".3f"),
            Column("S1", ".3f"),
            Column("S1 95% conf", ".3f"),
        ]
        rows = [[r["rank"], r["parameter"], r["ST"], r["ST_conf"], r["S1"], r["S1_conf"]] for r in result["parameters"]]
        note += (
            f"Sobol indices, N = {result['samples']}: S1 = share of the fitness variance the parameter "
            "explains alone, ST = including its interactions."
        )
    return Table(name, f"Global sensitivity ({result['method']}) of the fitness: {where}", columns, rows, note=note)


def sensitivity_figure(result: dict, top: int = 30):
    """Horizontal bars of mu* (Morris) or ST and S1 (Sobol) with 95 % intervals, most influential on top."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    rows = result["parameters"][:top]
    names = [r["parameter"] for r in rows][::-1]
    y = np.arange(len(rows))
    fig = Figure(figsize=(7.5, 0.28 * len(rows) + 1.4), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    if result["method"] == "morris":
        ax.barh(
            y,
            [r["mu_star"] for r in rows][::-1],
            xerr=[r["mu_star_conf"] for r in rows][::-1],
            color="#4472c4",
            ecolor="#333333",
            capsize=2,
        )
        ax.set_xlabel("mu* [m of fitness per full range]")
    else:
        ax.barh(
            y + 0.2,
            [r["ST"] for r in rows][::-1],
            height=0.4,
            xerr=[r["ST_conf"] for r in rows][::-1],
            color="#4472c4",
            ecolor="#333333",
            capsize=2,
            label="ST (total)",
        )
        ax.barh(
            y - 0.2,
            [r["S1"] for r in rows][::-1],
            height=0.4,
            xerr=[r["S1_conf"] for r in rows][::-1],
            color="#ed7d31",
            ecolor="#333333",
            capsize=2,
            label="S1 (first order)",
        )
        ax.set_xlabel("Sobol index")
        ax.legend(fontsize="small", loc="lower right")
    ax.set_yticks(y, names, fontsize=8)
    ax.grid(axis="x", alpha=0.3)
    shown = f" (top {top} of {len(result['parameters'])})" if len(result["parameters"]) > top else ""
    ax.set_title(f"{result['method']} sensitivity: {result['engine']} on {result['tasks']}{shown}", fontsize=10)
    return fig


def write_outputs(result: dict, out: Path) -> None:
    table = sensitivity_table(result)
    (out / RESULT_FILE).write_text(json.dumps(result, indent=1) + "\n")
    (out / "sensitivity.csv").write_text(table.to_csv())
    (out / "sensitivity.md").write_text(table.to_markdown())
    sensitivity_figure(result).savefig(out / "sensitivity.png", dpi=120, metadata={"Software": None})


def find_results(paths: list[Path]) -> list[Path]:
    """``sensitivity.json`` files under each of ``paths`` and in the folders next to them (siblings)."""
    found: list[Path] = []
    for path in paths:
        path = Path(path)
        candidates = list(path.rglob(RESULT_FILE)) if path.is_dir() else []
        candidates += [path.parent / RESULT_FILE, *path.parent.glob(f"*/{RESULT_FILE}")]
        for c in sorted(candidates):
            if c.is_file() and c.resolve() not in {f.resolve() for f in found}:
                found.append(c)
    return found
