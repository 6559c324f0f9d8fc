"""`simtune synth`: recordings with known truth round-trip through the loader, and tuning recovers the truth."""

import json
import subprocess
import sys

import numpy as np
import pytest

from simtune.data import load_recording, load_task_data
from simtune.engines import make_engine
from simtune.errors import ConfigError
from simtune.fitness import marker_positions
from simtune.runs import RunConfig, start_run
from simtune.studies.synth import load_truth, make_synthetic
from simtune.tasks import get_task


def simtune(*args):
    return subprocess.run([sys.executable, "-m", "simtune.cli", *args], capture_output=True, text=True, timeout=300)


def test_synthetic_recordings_round_trip_through_the_loader(tmp_path):
    truth = {"command_delay": 0.8, "max_velocity_joint_2": 25.0, "marker_offset_z": 0.01}
    result = make_synthetic("mujoco", "single", tmp_path, truth=truth, noise_m=0.002, repeats=3, seed=5, jitter_s=0.0)
    files = sorted((tmp_path / "single").iterdir())
    assert (
        [f.name for f in files]
        == ["single0001.tsv", "single0002.tsv", "single0003.tsv"]
        == [f.name for f in result.files["single"]]
    )
    assert files[0].read_text().startswith("NO_OF_FRAMES")  # Qualisys TSV with its header block
    task = get_task("single")
    rec = load_recording(files[0])
    assert task.wrist_body in rec.bodies and abs(rec.time[-1] - task.duration) < 1e-9
    data = load_task_data(tmp_path / "single", "single", wrist_body=task.wrist_body)
    assert data.wrist_repeats.shape == (3, int(task.duration * 20) + 1, 3)
    # the loaded mean is the simulation plus noise of 2 mm / sqrt(3) per axis
    sim = make_engine("mujoco", task)
    marker = marker_positions(sim.rollout(truth, len(data.times)), truth)
    sim.close()
    error = np.linalg.norm(data.wrist_mean - marker, axis=1)
    assert 0.0005 < error.mean() < 0.003
    written = json.loads((tmp_path / "truth.json").read_text())
    assert written["params"] == truth and written["parameters"] == list(truth) and written["noise_m"] == 0.002
    # different seed, different noise; same seed, same files
    again = make_synthetic(
        "mujoco", "single", tmp_path / "again", truth=truth, noise_m=0.002, repeats=1, seed=5, jitter_s=0.0
    )
    assert again.files["single"][0].read_bytes() == files[0].read_bytes()


def test_tasks_with_objects_and_seed_tasks_are_synthesised(tmp_path):
    make_synthetic("mujoco", "seed-9", tmp_path, truth={"command_delay": 0.5}, repeats=1, seed=0)
    task = get_task("seed-9")
    data = load_task_data(tmp_path / "seed-9", "seed-9", wrist_body=task.wrist_body, object_body=task.object.mocap_body)
    np.testing.assert_allclose(data.object_start[0], task.object.start_position, atol=0.005)


def test_tuning_recovers_the_true_delay(tmp_path):
    make_synthetic(
        "mujoco", "single", tmp_path / "data", truth={"command_delay": 1.1}, noise_m=0.002, repeats=3, seed=1
    )
    config = RunConfig(
        engine="mujoco",
        tasks="single",
        space="extended",
        data=str(tmp_path / "data"),
        seed=0,
        only=["command_delay"],
        optimizer="cmaes",
        max_evaluations=24,
        # the delay the repeats' jitter averages to (the aligned reference moves at the median repeat's delay)
        reference="mean",
    )
    result = start_run(config, tmp_path / "run", show_progress=False)
    assert abs(result.params["command_delay"] - 1.1) <= 0.05
    assert result.score.wrist_error < 0.004


def test_truth_defaults_overrides_and_validation(tmp_path):
    assert load_truth(None, "mujoco", None) == {"command_delay": 1.5}
    path = tmp_path / "t.json"
    path.write_text(json.dumps({"command_delay": 2.0, "timestep": 0.004}))
    assert load_truth(path, "mujoco", 0.7) == {"command_delay": 0.7, "timestep": 0.004}
    path.write_text(json.dumps({"timestep": 0.5}))
    with pytest.raises(ConfigError, match="'timestep' = 0.5 is outside its range"):
        load_truth(path, "mujoco", None)
    path.write_text(json.dumps({"restitution_wood": 0.2}))
    with pytest.raises(ConfigError, match="engine 'drake' has no parameter 'restitution_wood'"):
        load_truth(path, "drake", None)


@pytest.mark.slow  # 5 s of CLI runs; synth's functions are tested above in the default tier
def test_synth_command_writes_data_and_refuses_to_mix_recordings(tmp_path):
    truth = tmp_path / "truth.json"
    truth.write_text(json.dumps({"params": {"command_delay": 1.9, "marker_offset_x": 0.01}}))
    out = tmp_path / "data"
    proc = simtune(
        "synth",
        "--task",
        "single",
        "--truth",
        str(truth),
        "--delay-s",
        "1.2",
        "--repeats",
        "2",
        "--noise-mm",
        "1",
        "--jitter-s",
        "0",
        "--out",
        str(out),
    )
    assert proc.returncode == 0, proc.stderr
    written = json.loads((out / "truth.json").read_text())
    assert written["params"] == {"command_delay": 1.2, "marker_offset_x": 0.01} and written["noise_m"] == 0.001
    assert len(list((out / "single").glob("*.tsv"))) == 2
    # the truth file is a params file: it scores the data better than generic
    ev = simtune("evaluate", "--task", "single", "--data", str(out), "--params-file", str(out / "truth.json"), "--json")
    scored = json.loads(ev.stdout)
    assert scored["fitness"] < 0.002
    assert scored["generic_fitness"] > 0.1
    again = simtune("synth", "--task", "single", "--out", str(out))
    assert again.returncode == 2 and "already holds recordings" in again.stderr and again.stderr.count("\n") == 1
    bad = simtune("synth", "--task", "nope", "--out", str(tmp_path / "x"))
    assert bad.returncode == 2 and "unknown task" in bad.stderr


def test_synthesising_an_arm_on_the_floor_warns(recwarn):
    """A truth whose arm touches the floor in a task without an object is synthesised, with one warning that says
    when (the MICO's shoulder swung 130 deg down lays the arm on the floor); the bundled `single` gives none."""
    import dataclasses

    from simtune.errors import TaskWarning
    from simtune.reference.make import synthesize
    from simtune.tasks.spec import Phase

    single = get_task("single")
    settings = {"repeats": 1, "noise_m": 0.002, "jitter_s": 0.0, "seed": 0}
    synthesize("mujoco", single, {}, **settings)
    assert not [w for w in recwarn if issubclass(w.category, TaskWarning)]
    down = dataclasses.replace(single, phases=(Phase(0.0, (0.0, -130.0, 0.0, 0.0, 0.0, 0.0)),))
    (recording,) = synthesize("mujoco", down, {}, **settings)
    (warned,) = [w for w in recwarn if issubclass(w.category, TaskWarning)]
    assert "task single: the arm touches the floor with these true values (" in str(warned.message)
    assert len(recording.time) > 0
