"""The command line: JSON output, --help everywhere, one-line errors with exit status 2."""

import json
import os
import subprocess
import sys

import pytest

from simtune.reference import REFERENCE_DIR


def simtune(*args, check=False):
    proc = subprocess.run([sys.executable, "-m", "simtune.cli", *args], capture_output=True, text=True, timeout=300)
    if check:
        assert proc.returncode == 0, proc.stderr
    return proc


@pytest.mark.parametrize(
    "command", ["evaluate", "tune", "resume", "demo", "engines", "tasks", "params", "grid", "report"]
)
def test_every_command_has_help(command):
    proc = simtune(command, "--help", check=True)
    assert "Usage" in proc.stdout


def test_help_and_tables_keep_brackets():
    # units ([s], [m]) and extras ('simtune[opt]') must survive Rich's markup parsing
    env = {**os.environ, "COLUMNS": "250"}
    run = lambda *args: (
        subprocess.run(
            [sys.executable, "-m", "simtune.cli", *args],
            capture_output=True,
            text=True,
            timeout=300,
            env=env,
            check=True,
        ).stdout
    )
    tune_help = run("tune", "--help")
    assert "simtune[opt]" in tune_help and "wall time [s]" in tune_help
    assert "ROOT/<task>/*.tsv" in tune_help
    assert "duration [s]" in run("tasks")


def test_evaluate_json_is_one_clean_object():
    proc = simtune("evaluate", "--engine", "pybullet", "--task", "cube", "--json", check=True)
    data = json.loads(proc.stdout)
    assert data["engine"] == "pybullet" and data["object_error"] is not None
    assert data["fitness"] == pytest.approx(data["wrist_error"] + data["object_error"])


def test_evaluate_params_file_round_trip(tmp_path):
    params = tmp_path / "p.json"
    params.write_text(json.dumps({"params": {"command_delay": 1.4, "timestep": 0.004}}))
    proc = simtune("evaluate", "--task", "cube", "--params-file", str(params), "--json", check=True)
    data = json.loads(proc.stdout)
    assert data["fitness"] < data["generic_fitness"]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["evaluate", "--engine", "bulletx"], "unknown engine 'bulletx'"),
        (["evaluate", "--task", "cubes"], "unknown task 'cubes'"),
        (["tune", "--space", "huge", "--max-generations", "1"], "unknown parameter space 'huge'"),
        (["evaluate", "--data", "/nonexistent/folder"], "/nonexistent/folder does not exist"),
        (["evaluate", "--task", "single"], "no recordings for task 'single'"),
        (["resume", "/tmp"], "not a run folder"),
    ],
)
def test_bad_requests_fail_with_one_line(args, message):
    proc = simtune(*args)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], proc.stderr
    assert "Traceback" not in proc.stderr


def test_broken_recording_names_file_and_line(tmp_path):
    folder = tmp_path / "cube"
    folder.mkdir()
    good = REFERENCE_DIR / "cube" / "cube0001.tsv.gz"
    import gzip

    lines = gzip.decompress(good.read_bytes()).decode().splitlines()
    lines[40] = lines[40].replace("\t", "\tabc\t", 1)
    (folder / "bad.tsv").write_text("\n".join(lines) + "\n")
    proc = simtune("evaluate", "--task", "cube", "--data", str(tmp_path))
    assert proc.returncode == 2
    assert "bad.tsv" in proc.stderr and "line 41" in proc.stderr
