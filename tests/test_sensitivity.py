"""`simtune sensitivity`: Morris and Sobol through the Evaluator's process pool; the report picks it up."""

import json
import re
import subprocess
import sys

import pytest

from simtune.errors import ConfigError, SimtuneError
from simtune.reference import REFERENCE_DIR
from simtune.store import RunStore
from simtune.studies.sensitivity import STORE_NAME, run_sensitivity

ONLY = ["command_delay", "mass_cuboid_wood", "max_velocity_joint_2"]


def simtune(*args):
    return subprocess.run([sys.executable, "-m", "simtune.cli", *args], capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def morris(tmp_path_factory):
    out = tmp_path_factory.mktemp("runs") / "sens"
    result = run_sensitivity(
        "mujoco", "cube", REFERENCE_DIR, "extended", out, samples=4, method="morris", only=ONLY, workers=2
    )
    return out, result


def test_morris_ranks_the_command_delay_above_a_mass_the_task_lacks(morris):
    out, result = morris
    rows = {r["parameter"]: r for r in result["parameters"]}
    assert result["evaluations"] == 4 * (len(ONLY) + 1)
    # Morris trajectories may share points: each distinct point is simulated once and stored once
    store = RunStore.open_read_only(out, filename=STORE_NAME)
    assert result["new_evaluations"] == store.count_evaluations() <= result["evaluations"]
    store.close()
    assert rows["command_delay"]["rank"] < rows["mass_cuboid_wood"]["rank"]
    assert rows["command_delay"]["mu_star"] > 0.01
    assert rows["mass_cuboid_wood"]["mu_star"] == 0.0  # no cuboid in task cube: no effect at all
    assert [r["rank"] for r in result["parameters"]] == [1, 2, 3]
    mu = [r["mu_star"] for r in result["parameters"]]
    assert mu == sorted(mu, reverse=True)
    assert json.loads((out / "sensitivity.json").read_text()) == result
    assert (out / "sensitivity.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    csv = (out / "sensitivity.csv").read_text().splitlines()
    assert csv[0].startswith("rank,parameter,mu*") and csv[1].split(",")[1] == result["parameters"][0]["parameter"]
    assert "| rank | parameter |" in (out / "sensitivity.md").read_text()


def test_a_second_analysis_reuses_the_cached_evaluations(morris):
    out, first = morris
    again = run_sensitivity("mujoco", "cube", REFERENCE_DIR, "extended", out, samples=4, method="morris", only=ONLY)
    assert again["new_evaluations"] == 0 and again["parameters"] == first["parameters"]
    with pytest.raises(SimtuneError, match="another engine, task, data or parameter list"):
        run_sensitivity("mujoco", "cube", REFERENCE_DIR, "extended", out, samples=4, only=ONLY[:2])


@pytest.mark.slow  # the command end to end: 6 s
def test_sobol_command_prints_the_table(tmp_path):
    proc = simtune(
        "sensitivity",
        "--task",
        "cube",
        "--method",
        "sobol",
        "--samples",
        "4",
        "--only",
        "command_delay,mass_cuboid_wood",
        "--out",
        str(tmp_path / "s"),
    )
    assert proc.returncode == 0, proc.stderr
    lines = [line for line in proc.stdout.splitlines() if "command_delay" in line or "mass_cuboid_wood" in line]
    assert "command_delay" in lines[0] and "mass_cuboid_wood" in lines[1]  # sorted: most influential first
    result = json.loads((tmp_path / "s" / "sensitivity.json").read_text())
    assert result["evaluations"] == 4 * (2 + 2)
    assert result["parameters"][0]["ST"] > 0.5


def test_sobol_needs_a_power_of_two():
    with pytest.raises(ConfigError, match="power of two"):
        run_sensitivity("mujoco", "cube", REFERENCE_DIR, "extended", "/nonexistent", samples=6, method="sobol")
    proc = simtune("sensitivity", "--method", "fast", "--out", "/nonexistent")
    assert proc.returncode == 2 and "unknown sensitivity method 'fast'" in proc.stderr


@pytest.mark.slow  # 7 s; test_sobol_command_prints_the_table keeps the command in the default tier
def test_report_includes_the_sensitivity_found_next_to_its_runs(morris, tmp_path):
    from simtune.runs import RunConfig, start_run

    out, _ = morris
    run_dir = out.parent / "run"  # a run folder beside the sensitivity folder
    start_run(
        RunConfig(
            engine="mujoco",
            tasks="cube",
            space="extended",
            data=str(REFERENCE_DIR),
            optimizer="random",
            only=["command_delay"],
            max_evaluations=2,
        ),
        run_dir,
        show_progress=False,
    )
    proc = simtune("report", str(run_dir), "--out", str(tmp_path / "report"), "--quiet")
    assert proc.returncode == 0, proc.stderr
    html = (tmp_path / "report" / "index.html").read_text()
    # its own numbered section (the number depends on which other sections the runs fill)
    assert re.search(r"<h2>\d+\. Global sensitivity</h2>", html) and "mass_cuboid_wood" in html
    assert (tmp_path / "report" / "tables" / "sensitivity_1.csv").is_file()
    assert (tmp_path / "report" / "figures" / "sensitivity_1.png").is_file()
