"""Probe 5 (issue 71) on `simtune check` and `check --write-task`, the tune's start-up groups and the spaces' help:
rows 5 (#14), 14, 33, 34, 35, 37 and 38.  The checks run on the shipped reference recordings and on the real
qrg2019 motion capture (skipped where that is absent)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from simtune.check.task import task_quality
from simtune.cli.check_output import print_data_quality
from simtune.data import load_recording
from simtune.data.qualisys import write_qualisys_tsv
from simtune.errors import SimtuneError
from simtune.optimize.start_check import weak_directions
from simtune.project import BUNDLED_DIR, load_project
from simtune.reference import REFERENCE_DIR
from simtune.tasks import with_targets
from simtune.tasks.correct import Correction, check_task_out, corrected_text

MOCAP = Path("/work/shared/datasets/qrg2019/mocap")
needs_mocap = pytest.mark.skipif(not (MOCAP / "single").is_dir(), reason="the qrg2019 motion capture is not here")
#: the bundled cube's phase 2 as the task file writes it (corrected to 74 deg, the published 65 beside it)
CUBE_PHASE_2 = "targets_deg = [0, -60, 74, 90, 0, 0]\npublished_targets_deg = [0, -60, 65, 90, 0, 0]"


def _cube_project(folder: Path, data: Path, text: str | None = None) -> Path:
    """A project of the bundled `cube` (or ``text`` as its task file) on the recordings under ``data``."""
    (folder / "tasks").mkdir(parents=True)
    (folder / "tasks" / "cube.toml").write_text(text or (BUNDLED_DIR / "tasks" / "cube.toml").read_text())
    (folder / "simtune.toml").write_text(f'robot = "mico"\ndata = "{data}"\ntasks = ["tasks/cube.toml"]\n')
    return folder


def _printed(capsys, part: dict) -> str:
    print_data_quality([part])
    return " ".join(capsys.readouterr().out.split())  # one line: the console wraps to its width


@pytest.mark.slow  # the default tier's 4 minutes
def test_a_rest_no_targets_reach_is_said_and_neither_proposed_nor_written(tmp_path, capsys):
    """Row 5 (#14): a wrist recorded 1.7 m off in phase 2 got six new targets that left 1.4 m ("1700.0 -> 1433.5
    mm"), written to the task file, rc 0.  Now one warning names the phase and the residual, nothing is proposed
    for it and --write-task writes no file."""
    from simtune import api

    data = tmp_path / "data" / "cube"
    data.mkdir(parents=True)
    for source in sorted((REFERENCE_DIR / "cube").glob("*.tsv.gz")):
        recording = load_recording(source)
        # phase 2 (8-14 s) rests from about 14.4 s on the recordings' clock (its command delay about 1.4 s)
        during = (recording.time >= 10.0) & (recording.time < 16.0)
        recording.positions["RB1(Orange)"][during] += [1.7, 0.0, 0.0]
        write_qualisys_tsv(data / source.name, recording, header=True)
    project = load_project(_cube_project(tmp_path / "project", tmp_path / "data"))
    summary, _ = task_quality("mujoco", project.task("cube"), tmp_path / "data")
    rows = {r["stretch"]: r for r in summary["rest_poses"]}
    phase_2 = rows["phase 2"]
    assert phase_2["far"] and "proposal" not in phase_2
    assert phase_2["out_of_reach"]["residual_before_m"] > 1.6 and phase_2["out_of_reach"]["residual_after_m"] > 1.0
    assert not rows["phase 1"]["far"] and not rows["phase 3"]["far"]
    printed = _printed(capsys, summary)
    warned = [line for line in printed.split("warning: ")[1:] if "no joint targets place" in line]
    assert len(warned) == 1 and warned[0].startswith("phase 2:") and "out of the arm's reach" in warned[0]
    assert re.search(r"leave 1\d{3}\.\d of its 1\d{3}\.\d mm", warned[0])
    assert "proposed for phase 2" not in printed
    notes: list[str] = []
    assert api._write_corrected_task(project, project.task("cube"), summary, tmp_path / "fixed.toml", notes) is None
    assert not (tmp_path / "fixed.toml").exists() and notes == []


def test_the_users_comment_on_a_corrected_targets_line_stays(tmp_path):
    """Row 33: `targets_deg = [...]   # edited by hand [see notes]` lost its comment to --write-task."""
    text = (BUNDLED_DIR / "tasks" / "cube.toml").read_text()
    mine = text.replace(CUBE_PHASE_2, "targets_deg = [0, -60, 65, 90, 0, 0]   # edited by hand [see notes]")
    fixed = corrected_text(
        mine, tmp_path / "cube.toml", {1: Correction((0, -60, 74, 90, 0, 0), "why")}, {1: (0, -60, 65, 90, 0, 0)}
    )
    assert "targets_deg = [0, -60, 74, 90, 0, 0]  # edited by hand [see notes]\n" in fixed
    assert "published_targets_deg = [0, -60, 65, 90, 0, 0]\n" in fixed


@pytest.mark.slow  # the default tier's 4 minutes
@needs_mocap
def test_published_targets_corrected_say_the_files_own_value_and_flag_a_comment_naming_it(tmp_path, capsys):
    """Row 34: the bundled cube checked with --targets published: the file's 74 was replaced by 75.1 while the
    evidence said "65 -> 75.1", and the comment "Phase 2: joint 3 at 74 deg" stayed above it, unflagged."""
    from simtune import api
    from simtune.cli import data_commands

    project = load_project(BUNDLED_DIR)
    task = with_targets([project.task("cube")], "published")[0]
    summary, _ = task_quality("mujoco", task, MOCAP)
    proposal = {r["stretch"]: r for r in summary["rest_poses"]}["phase 2"]["proposal"]
    assert proposal["changed"] == {"joint_3": [65.0, proposal["targets_deg"][2]]}  # what the check ran
    notes: list[str] = []
    out = api._write_corrected_task(project, task, summary, tmp_path / "cube.toml", notes)
    text = Path(out).read_text()
    new = f"[0, -60, {proposal['targets_deg'][2]:g}, 90, 0, 0]"
    assert f"its targets_deg [0, -60, 74, 90, 0, 0] -> {new}" in text  # the file's own 74, not only 65
    assert "checked with the targets [0, -60, 65, 90, 0, 0], not this file's" in text
    now = proposal["targets_deg"][2]
    assert f'# note: a comment of this phase names the former 74 (now {now:g}): "Phase 2: joint 3 at 74 deg' in text
    assert len(notes) == 1 and "phase 2" in notes[0] and "Phase 2: joint 3 at 74 deg" in notes[0]
    assert f"targets_deg = {new}\npublished_targets_deg = [0, -60, 65, 90, 0, 0]" in text
    # the CLI says it too, below the file it names
    result = {"data_quality": [summary], "written_task": out, "written_task_notes": notes}
    capsys.readouterr()
    data_commands._print_written_task(result)
    printed = capsys.readouterr().out.splitlines()
    assert printed[0] == f"corrected task file: {out}"
    assert printed[1].startswith("  note: phases[1] (phase 2)") and "Phase 2: joint 3 at 74 deg" in printed[1]


def test_inline_phases_are_said_to_be_an_inline_array(tmp_path):
    """Row 35: a task whose phases are `phases = [{...}, ...]` was told "no [[phases]] tables to correct (a
    schedule_csv or a LeRobot schedule is data)"."""
    source = tmp_path / "inline.toml"
    source.write_text(
        'name = "inline"\nduration = 4\njoints = ["joint_1"]\nstart_pose_deg = [0]\n'
        "phases = [{start = 0, targets_deg = [10]}, {start = 2, targets_deg = [20]}]\n"
    )
    with pytest.raises(SimtuneError) as caught:
        check_task_out(source, tmp_path / "fixed.toml")
    message = str(caught.value)
    assert "inline array" in message and "only [[phases]] tables" in message and "is data" not in message
    with pytest.raises(SimtuneError, match="inline array"):
        corrected_text(source.read_text(), source, {0: Correction((5,), "why")}, {0: (10,)})


def test_a_group_of_weak_parameters_is_named_once():
    """Row 37: the tune's start-up named "mass_link_4 with mass_link_5 with mass_link_2; joint_offset_6; mass_link_4
    with mass_link_2 with mass_link_5": two weak directions among the same three masses, one group twice."""
    # three masses whose two weakest directions both weigh each of them (shares 0.58 and 0.82/0.41/0.41)
    directions = np.array(
        [
            [0.0, 1.0, -1.0, 0.0] / np.sqrt(2.0),
            [0.0, 0.0, 0.0, 1.0],
            [1.0, 1.0, 1.0, 0.0] / np.sqrt(3.0),
            [2.0, -1.0, -1.0, 0.0] / np.sqrt(6.0),
        ]
    )
    columns, _ = np.linalg.qr(np.random.default_rng(0).normal(size=(40, 4)))
    jacobian = columns @ np.diag([1.0, 0.5, 2e-6, 1e-6]) @ directions
    names = ["mass_link_2", "mass_link_4", "mass_link_5", "joint_offset_6"]
    _, groups, _ = weak_directions(names, jacobian)
    assert len(groups) == 1 and set(groups[0]) == {"mass_link_2", "mass_link_4", "mass_link_5"}


def test_the_space_help_says_what_gains_holds_for_an_own_robot():
    """Row 38: `--space gains` on an own robot tuned armature_joint_* and friction_joint_* (its `extended` holds
    the drive train), while the help said gains = calibrated + controller and servo gains."""
    from dataclasses import replace

    from simtune.cli.options import SPACE_HELP
    from simtune.params.space import robot_spaces
    from simtune.robot.mico import MICO

    own = robot_spaces(replace(MICO, name="my_arm"))
    assert own["gains"] == own["calibrated"] and any(p.name.startswith("armature_joint") for p in own["gains"])
    help_text = " ".join(SPACE_HELP.split())
    assert "for an own robot gains and drivetrain are its calibrated" in help_text
    assert "armature, friction and both gains" in help_text
    table = (Path(__file__).parents[1] / "docs" / "parameters.md").read_text()
    gains_row = next(line for line in table.splitlines() if line.startswith("| `gains` |"))
    assert "an own robot's `gains` is its `calibrated`, armature and friction included" in gains_row


def test_one_odd_onset_carries_neither_the_onset_nor_the_delay():
    """Row 14, on rows as the check makes them: an onset far from the others' is left out of the mean and std and
    named; the median is what the delay is read from."""
    from simtune.check.task import onset_summary

    rows = [{"file": f"r{i}.tsv", "onset_s": t, "shift_s": 0.0} for i, t in enumerate([1.2, 1.3, 1.25, 1.1, 1.4])]
    rows.append({"file": "late.tsv", "onset_s": 0.04, "shift_s": -0.05})
    summary = onset_summary(rows)
    assert summary["onset_median_s"] == pytest.approx(1.225)
    assert summary["onset_mean_s"] == pytest.approx(1.25) and summary["onset_std_s"] == pytest.approx(
        np.std([1.2, 1.3, 1.25, 1.1, 1.4], ddof=1)
    )
    assert [o["file"] for o in summary["onset_outliers"]] == ["late.tsv"]
    assert onset_summary(rows[:5])["onset_outliers"] == []


@pytest.mark.slow  # the default tier's 4 minutes
@needs_mocap
def test_the_real_single_onset_and_delay_are_not_carried_by_single0010(capsys):
    """Row 14: the real Single0010_6D.tsv's onset is read at 0.040 s (the others' 1.0-1.45 s); the mean 1.215 s,
    std 0.28 s and "command delay about 1.19 s" were carried by it."""
    project = load_project(BUNDLED_DIR)
    summary, _ = task_quality("mujoco", project.task("single"), MOCAP)
    onsets = {r["file"]: r["onset_s"] for r in summary["repeats"]}
    others = [t for name, t in onsets.items() if name != "Single0010_6D.tsv"]
    assert onsets["Single0010_6D.tsv"] < 0.1 and min(others) > 0.9
    assert [o["file"] for o in summary["onset_outliers"]] == ["Single0010_6D.tsv"]
    assert summary["onset_median_s"] == pytest.approx(np.median(list(onsets.values())))
    assert summary["onset_mean_s"] == pytest.approx(np.mean(others)) and summary["onset_std_s"] < 0.15
    assert summary["implied_command_delay_s"] == pytest.approx(summary["onset_median_s"] - summary["simulated_onset_s"])
    assert summary["implied_command_delay_s"] > 1.22  # 1.19 with the mean
    printed = _printed(capsys, summary)
    assert "left out of the onset's mean and std: Single0010_6D.tsv moves at 0.040 s" in printed
    assert "(median; mean" in printed


def test_an_onset_that_could_not_be_measured_is_said_in_words_not_printed_as_a_dash(capsys):
    """Probe 5: a check whose recordings never leave their rest printed "motion onset - s" and "delay about - s"."""
    from simtune.cli.check_output import _print_onset

    part = {"repeats": [{}], "onset_median_s": None, "onset_mean_s": None, "onset_std_s": None}
    _print_onset({**part, "simulated_onset_s": None, "implied_command_delay_s": None})
    printed = " ".join(capsys.readouterr().out.split())
    assert "- s" not in printed
    assert "motion onset: none found" in printed and "the generic simulation does not move" in printed
    assert "no command delay estimated from it" in printed
