"""Probe 5's run-store, grid-index, uncertainty and parameter-range defects, each end to end on the command line.

The runs are real (short) tuning runs of MuJoCo on the shipped reference recording; the foreign and damaged files
are built by the tests.
"""

import hashlib
import json
import re
import shutil
import sqlite3
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from simtune.errors import ConfigError, SimtuneError
from simtune.reference import REFERENCE_DIR
from simtune.runs import RunConfig, resume_run, start_run
from simtune.store import STORE_FILE, RunStore


def simtune(*args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "simtune.cli", *args], capture_output=True, text=True, timeout=300, env=env
    )


def one_line_error(proc: subprocess.CompletedProcess, *fragments: str) -> str:
    assert proc.returncode == 2, (proc.returncode, proc.stdout, proc.stderr)
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    return lines[0]


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> tuple[Path, float]:
    """A short finished run (1 generation of DE on two parameters) and the wall time its tune returned."""
    run_dir = tmp_path_factory.mktemp("probe5") / "run"
    config = RunConfig(
        engine="mujoco",
        tasks="cube",
        space="extended",
        data=str(REFERENCE_DIR),
        seed=3,
        max_generations=1,
        only=["command_delay", "max_velocity_joint_2"],
        optimizer="de",
    )
    result = start_run(config, run_dir, show_progress=False)
    return run_dir, result.wall_s


# --- 1. a grid folder's grid.sqlite that is someone's own file ---------------------------------------------------
GRID = ["grid", "--engines", "mujoco", "--tasks", "cube", "--spaces", "extended", "--repeats", "1"]
GRID_SETTINGS = ["--max-generations", "1", "--only", "command_delay"]


def test_a_grid_index_that_is_not_a_database_is_one_line_and_left_unchanged(tmp_path):
    """It was SQLite's traceback `file is not a database`."""
    index = tmp_path / "grid" / "grid.sqlite"
    index.parent.mkdir()
    index.write_text("my notes, not a database\n" * 200)
    before = digest(index)
    one_line_error(simtune(*GRID, "--out", str(index.parent), *GRID_SETTINGS), str(index), "not a grid index")
    assert digest(index) == before
    assert sorted(p.name for p in index.parent.iterdir()) == ["grid.sqlite"]  # no journal, no runs folder


@pytest.mark.slow  # the default tier's 4 minutes
def test_a_grid_index_that_is_a_database_of_other_tables_is_refused_unwritten(tmp_path):
    """A user's own SQLite file of that name: no grid tables are added to it."""
    index = tmp_path / "grid" / "grid.sqlite"
    index.parent.mkdir()
    db = sqlite3.connect(index)
    db.execute("CREATE TABLE notes (text TEXT)")
    db.execute("INSERT INTO notes VALUES ('keep me')")
    db.commit()
    db.close()
    before = digest(index)
    one_line_error(simtune(*GRID, "--out", str(index.parent), *GRID_SETTINGS), str(index), "left unchanged")
    assert digest(index) == before


# --- 2. uncertainty of a store with garbage in its middle --------------------------------------------------------
@pytest.mark.slow  # the default tier's 4 minutes
def test_uncertainty_refuses_a_store_with_garbage_in_its_middle_as_resume_does(finished, tmp_path):
    """Resume, report and export refused it; uncertainty read around the damage and printed intervals, exit 0."""
    run_dir = Path(shutil.copytree(finished[0], tmp_path / "run"))
    path = run_dir / STORE_FILE
    store = RunStore(run_dir)
    page_size = store.db.execute("PRAGMA page_size").fetchone()[0]
    pages = store.db.execute("PRAGMA page_count").fetchone()[0]
    store.close()
    with open(path, "r+b") as fh:  # one page of garbage halfway into the file, as a failing disk would leave
        fh.seek((pages // 2) * page_size)
        fh.write(np.random.default_rng(5).bytes(page_size))
    damaged = digest(path)
    with pytest.raises(SimtuneError, match="damaged"):
        resume_run(run_dir, show_progress=False)
    one_line_error(simtune("uncertainty", str(run_dir)), str(path), "damaged")
    assert digest(path) == damaged


# --- 3. resuming a finished run ----------------------------------------------------------------------------------
def test_resuming_a_finished_run_says_so_and_changes_nothing(finished, tmp_path):
    """Twice: the store and best_params.json to the byte, the wall time the tune gave to the last digit, one line
    saying the run is finished (no start-up warnings again)."""
    run_dir = Path(shutil.copytree(finished[0], tmp_path / "run"))
    files = {name: digest(run_dir / name) for name in (STORE_FILE, "best_params.json")}
    for _ in range(2):
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # nothing read again, so nothing to warn about again
            again = resume_run(run_dir, show_progress=False)
        assert again.new_evaluations == 0 and again.wall_s == finished[1]
        assert {name: digest(run_dir / name) for name in files} == files
    proc = simtune("resume", str(run_dir), "--quiet")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "is already finished" in lines[0] and "nothing to resume" in lines[0], proc.stderr
    assert {name: digest(run_dir / name) for name in files} == files
    assert sorted(p.name for p in run_dir.iterdir()) == sorted(files)  # no lock file, journal or side file left


def test_a_finished_run_stores_the_wall_time_its_tune_returned(finished):
    store = RunStore.open_read_only(finished[0])
    try:
        assert store.get("elapsed_s") == finished[1]
    finally:
        store.close()


# --- 4. parameter ranges as `simtune params` prints them ---------------------------------------------------------
def printed_ranges(*args: str) -> dict[str, tuple[str, str]]:
    """``simtune params``'s rows: name -> (low, high) as printed."""
    proc = simtune("params", *args, env={**_environ(), "COLUMNS": "250"})
    assert proc.returncode == 0, proc.stderr
    rows = re.findall(r"^│ (\w+)\s+│ (\S+)\s+│ (\S+)\s+│", proc.stdout, flags=re.MULTILINE)
    return {name: (low, high) for name, low, high in rows if name != "parameter"}


def _environ() -> dict:
    import os

    return dict(os.environ)


def test_every_bound_simtune_params_prints_is_accepted_back():
    """`compliance_joint_3`'s high bound 0.009383807017... was printed 0.00938381, which a parameter file refused
    as outside [0, 0.00938381]."""
    ranges = printed_ranges("--space", "calibrated", "--engine", "mujoco")
    by_name = {p.name: p for p in calibrated().parameters}
    assert len(ranges) > 50 and set(ranges) <= set(by_name)
    for name, (low, high) in ranges.items():
        assert by_name[name].check(float(low)) == float(low) and by_name[name].check(float(high)) == float(high)
        # shown to 6 significant digits at least: never rounded further than before
        assert float(high) == pytest.approx(by_name[name].high, rel=5e-6, abs=1e-12)
    assert ranges["compliance_joint_3"][1] == "0.009383807"


def test_the_printed_bound_that_was_refused_is_evaluated(tmp_path):
    """The bound as printed, in a parameter file: evaluated (it was refused as outside its range)."""
    from simtune import api

    values = tmp_path / "values.json"
    values.write_text(
        json.dumps({"compliance_joint_3": float(printed_ranges("--space", "calibrated")["compliance_joint_3"][1])})
    )
    assert np.isfinite(api.evaluate("mujoco", "cube", params=values).fitness)


def test_a_value_past_a_bound_is_refused_with_the_digits_that_show_why():
    compliance = next(p for p in calibrated().parameters if p.name == "compliance_joint_3")
    with pytest.raises(ConfigError, match=re.escape("= 0.00938381 is outside its range [0, 0.009383807] rad")):
        compliance.check(0.00938381)
    mass = next(p for p in calibrated().parameters if p.name == "mass_link_3")
    with pytest.raises(ConfigError, match=re.escape("= 0.8 is outside its range [0.4242, 0.7878] kg")):
        mass.check(0.8)
    assert mass.shown_bounds() == ("0.4242", "0.7878")  # 6 digits where they lie in the range


def calibrated():
    from simtune.params import get_space
    from simtune.project import get_project
    from simtune.tasks.spec import common_robot

    return get_space("calibrated", None, robot=common_robot(get_project(None).tasks.values()))
