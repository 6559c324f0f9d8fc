"""Every optimiser behind one interface: improves on generic, deterministic per seed, resumable; compare."""

import json
import subprocess
import sys

import numpy as np
import pytest
from conftest import kill_when

from simtune.errors import ConfigError, SimtuneError
from simtune.objective import Objective, load_references
from simtune.optimize import OPTIMIZERS
from simtune.reference import REFERENCE_DIR
from simtune.runs import RunConfig, resume_run, start_run
from simtune.store import RunStore
from simtune.tasks import parse_tasks

ONLY = ["command_delay", "max_velocity_joint_2", "marker_offset_z"]
BUDGET = 15


def config(**kw):
    base = dict(
        engine="mujoco",
        tasks="cube",
        space="extended",
        data=str(REFERENCE_DIR),
        seed=3,
        workers=1,
        only=ONLY,
        max_evaluations=BUDGET,
        optimizer="de",
    )
    base.update(kw)
    return RunConfig(**base)


def simtune(*args):
    return subprocess.run([sys.executable, "-m", "simtune.cli", *args], capture_output=True, text=True, timeout=300)


# whole runs of every optimiser (10-15 s each) in the slow tier; the default tier tunes end to end in
# tests/test_tune.py (DE) and tests/test_api.py, and keeps auto's phases in tests/test_pipeline.py
@pytest.mark.slow
@pytest.mark.parametrize("optimizer", OPTIMIZERS)
def test_optimizer_improves_is_deterministic_and_replays_from_the_store(optimizer, tmp_path):
    first = start_run(config(optimizer=optimizer), tmp_path / "a", show_progress=False)
    store = RunStore(tmp_path / "a")
    generic = store.get("generic")["fitness"]
    rows = store.evaluations()
    store.close()
    assert first.fitness < generic
    assert len(rows) == first.evaluations == first.new_evaluations
    assert min(r["fitness"] for r in rows) == pytest.approx(first.fitness)
    if optimizer in ("de", "auto"):  # a DE generation is never cut short: up to one population (5 here) more
        assert BUDGET <= first.evaluations < BUDGET + 5
    else:
        assert first.evaluations == BUDGET
    assert not any(r["pruned"] for r in rows) or optimizer in ("de", "auto")  # only DE prunes (auto's global phase)

    again = start_run(config(optimizer=optimizer), tmp_path / "b", show_progress=False)
    np.testing.assert_array_equal(again.x, first.x)
    assert again.fitness == first.fitness

    replay = resume_run(tmp_path / "a", show_progress=False)
    assert replay.new_evaluations == 0  # every evaluation came from the store
    assert replay.evaluations == first.evaluations
    np.testing.assert_array_equal(replay.x, first.x)


def test_seeds_differ(tmp_path):
    a = start_run(config(optimizer="random", max_evaluations=3), tmp_path / "a", show_progress=False)
    b = start_run(config(optimizer="random", max_evaluations=3, seed=4), tmp_path / "b", show_progress=False)
    assert not np.array_equal(a.x, b.x)


@pytest.mark.slow
def test_cmaes_killed_with_sigkill_resumes_without_losing_or_redoing_work(tmp_path):
    reference = start_run(config(optimizer="cmaes", max_evaluations=21), tmp_path / "whole", show_progress=False)
    run_dir = tmp_path / "killed"
    kept = kill_when(
        [
            sys.executable,
            "-m",
            "simtune.cli",
            "tune",
            "--engine",
            "mujoco",
            "--task",
            "cube",
            "--data",
            str(REFERENCE_DIR),
            "--space",
            "extended",
            "--seed",
            "3",
            "--optimizer",
            "cmaes",
            "--max-evaluations",
            "21",
            "--only",
            ",".join(ONLY),
            "--out",
            str(run_dir),
            "--quiet",
        ],
        run_dir,
        9,
    )
    assert 0 < kept < reference.evaluations, "the kill must land mid-run"
    resumed = resume_run(run_dir, show_progress=False)
    assert resumed.new_evaluations == reference.evaluations - kept
    assert resumed.evaluations == reference.evaluations
    np.testing.assert_array_equal(resumed.x, reference.x)
    assert RunStore(run_dir).get("status") == "finished"


def test_residuals_square_to_the_fitness_with_squared_distances():
    tasks = parse_tasks("cube")
    objective = Objective("mujoco", tasks, load_references(REFERENCE_DIR, tasks))
    params = {"command_delay": 1.3, "marker_offset_z": 0.01}
    residuals, score = objective.residuals_and_score(params)
    reference = objective.references["cube"]
    n = len(reference.times)
    assert residuals.shape == (3 * n + 3,) == (objective.residual_size,)
    markers = residuals[: 3 * n].reshape(n, 3) * np.sqrt(n)  # marker minus recorded mean, per sample
    assert np.mean(np.linalg.norm(markers, axis=1)) == pytest.approx(score.wrist_error, rel=1e-12)
    assert np.linalg.norm(residuals[3 * n :]) == pytest.approx(score.object_error, rel=1e-12)
    assert score.fitness == objective.score(params).fitness  # the same rollout as the fitness
    np.testing.assert_array_equal(objective.residuals(params), residuals)
    objective.close()


@pytest.mark.slow  # about 10 s: a search, its polish and a replay (auto's test covers least squares by default)
def test_refine_improves_on_the_search_and_replays_from_the_store(tmp_path):
    cfg = config(optimizer="random", max_evaluations=6, only=["command_delay", "marker_offset_z"], refine=True)
    refined = start_run(cfg, tmp_path / "r", show_progress=False)
    plain = start_run(
        config(optimizer="random", max_evaluations=6, only=["command_delay", "marker_offset_z"]),
        tmp_path / "p",
        show_progress=False,
    )
    assert refined.fitness < plain.fitness  # least squares moved the marker offset downhill
    assert refined.evaluations > 6 and "refined by" in refined.message
    store = RunStore(tmp_path / "r")
    assert store.lookup_residuals(refined.x) is not None
    assert store.get("best_fitness") == refined.fitness
    store.close()
    replay = resume_run(tmp_path / "r", show_progress=False)
    assert replay.new_evaluations == 0 and replay.fitness == refined.fitness
    np.testing.assert_array_equal(replay.x, refined.x)


def test_every_optimizer_is_described_once_where_it_is_defined():
    """The optimisers' table (simtune.optimizers) defines and describes each: simtune.optimize takes the functions
    from it and the command line its --optimizer help, without importing simtune.optimize (a second of SciPy and
    Optuna); the help used to describe the optimisers a second time, by hand."""
    from simtune.cli.options import OPTIMIZER_HELP
    from simtune.optimizers import OPTIMIZER_TABLE

    assert list(OPTIMIZERS) == list(OPTIMIZER_TABLE)
    for name, entry in OPTIMIZER_TABLE.items():
        assert f"{OPTIMIZERS[name].__module__}:{OPTIMIZERS[name].__name__}" == entry.function
        assert f"{name}: {entry.about}" in OPTIMIZER_HELP
    loaded = "import sys, simtune.cli.options; print('simtune.optimize' in sys.modules)"
    result = subprocess.run([sys.executable, "-c", loaded], capture_output=True, text=True, timeout=60)
    assert result.stdout.strip() == "False", result.stderr


def test_unknown_optimizer_is_a_one_line_config_error(tmp_path):
    with pytest.raises(ConfigError, match=r"unknown optimizer 'nelder' \(known: de, cmaes, bo, random, auto\)"):
        start_run(config(optimizer="nelder"), tmp_path / "x", show_progress=False)
    assert not (tmp_path / "x").exists()
    proc = simtune("tune", "--optimizer", "nelder", "--out", str(tmp_path / "y"))
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1 and "known: de, cmaes, bo, random" in proc.stderr


@pytest.mark.parametrize(("optimizer", "module"), [("cmaes", "cmaes"), ("bo", "optuna")])
def test_missing_package_gives_an_install_hint(optimizer, module, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, module, None)  # import fails as if not installed
    with pytest.raises(
        SimtuneError,
        match=rf"optimizer '{optimizer}' needs the {module} package: "
        r"pip install 'simtune\[opt\]'",
    ):
        start_run(config(optimizer=optimizer), tmp_path / "x", show_progress=False)
    assert not (tmp_path / "x").exists()  # refused before any run folder is made


@pytest.mark.slow  # about 9 s: three short runs
def test_compare_prints_the_table_from_the_run_stores(tmp_path):
    out = tmp_path / "cmp"
    args = [
        "compare",
        "--optimizers",
        "random,cmaes",
        "--task",
        "cube",
        "--budget-evals",
        "6",
        "--seeds",
        "2",
        "--only",
        "command_delay,max_velocity_joint_2",
        "--target",
        "0.05",
        "--out",
        str(out),
    ]
    proc = simtune(*args)
    assert proc.returncode == 0, proc.stderr
    for text in ("optimizer", "best @ 25%", "best @ 100%", "evals to 0.05", "random", "cmaes"):
        assert text in proc.stdout
    result = json.loads((out / "compare.json").read_text())
    for summary in result["summary"]:
        bests = []
        for seed in range(2):
            rows = RunStore(out / summary["optimizer"] / f"seed-{seed}").evaluations()
            assert len(rows) == 6
            bests.append(min(r["fitness"] for r in rows))
        assert summary["best"]["100%"] == pytest.approx(float(np.median(bests)))
        assert summary["best"]["25%"] >= summary["best"]["50%"] >= summary["best"]["100%"]
    assert (out / "compare.md").read_text().startswith("| optimizer |")
    again = simtune(*args, "--json")  # finished runs are reused, not run again
    assert again.returncode == 0 and json.loads(again.stdout)["summary"] == result["summary"]


def test_compare_summary_counts_evaluations_to_target():
    from simtune.studies.compare import RunCurve, summarise

    curves = [
        RunCurve("a", 0, [0.3, 0.2, 0.1, 0.1], 1.0, ""),
        RunCurve("a", 1, [0.3, 0.3, 0.3, 0.15], 1.0, ""),
        RunCurve("a", 2, [0.5, 0.1, 0.1, 0.1], 1.0, ""),
        RunCurve("b", 0, [0.5, 0.4, 0.4, 0.4], 1.0, ""),
    ]
    a, b = summarise(curves, ["a", "b"], 4, target=0.1)
    assert a.evaluations_to_target == 3 and a.reached == 2  # median of 3, never, 2
    assert a.best == {"25%": 0.3, "50%": 0.2, "100%": 0.1}
    assert b.evaluations_to_target is None and b.reached == 0


@pytest.mark.parametrize("command", ["compare", "synth", "transfer", "sensitivity", "tune"])
def test_new_commands_have_help_with_an_example(command):
    proc = simtune(command, "--help")
    assert proc.returncode == 0 and "Usage" in proc.stdout and "Example" in proc.stdout
