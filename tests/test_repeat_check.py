"""The repeat check (issue 50 item 9): one physically wrong repeat among good ones is named and left out.

Folders are built from the real qrg2019 recordings (skipped without them): eight repeats of a task, one of them
damaged the way a marker system or a careless export damages one (mirrored, two bodies swapped, a marker
glitch, an object never touched).  The check must name that file and leave it out, in ``load_references``,
``simtune evaluate``, ``simtune check`` and a run's fingerprint; ``--keep-repeats`` keeps it; and none of the
23 + 23 real repeats is left out.
"""

from __future__ import annotations

import shutil
import sys
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from test_data_sanity import Fields, rewrite

from simtune.check.task import task_quality
from simtune.data.screen import far_repeats
from simtune.errors import RecordingWarning
from simtune.objective import load_references
from simtune.run_plan import RunConfig, plan_run
from simtune.runs import left_out_changes, run_fingerprint
from simtune.tasks import get_task

DAMAGED = 3  # the index of the damaged repeat among the eight
WRIST, CUBE = 1, 2  # body columns of the qrg2019 TSVs: RB2(Black) base, RB1(Orange) wrist, PCube


def _columns(body: int) -> slice:
    return slice(2 + 17 * body, 2 + 17 * body + 16)


def mirrored(rows: Fields) -> Fields:
    """Every body's y negated: a take exported in a mirrored frame."""
    for row in rows:
        for body in range(3):
            c = 3 + 17 * body
            if row[c].strip():
                row[c] = f"{-float(row[c]):.5f}".encode()
    return rows


def swapped(rows: Fields) -> Fields:
    """The wrist's and the cube's columns swapped: two rigid bodies labelled the wrong way round."""
    for row in rows:
        row[_columns(WRIST)], row[_columns(CUBE)] = row[_columns(CUBE)], row[_columns(WRIST)]
    return rows


def glitch(rows: Fields) -> Fields:
    """The wrist marker 20 cm off for half a second (100 Hz frames 300-349): a marker glitch."""
    for row in rows[300:350]:
        c = 4 + 17 * WRIST
        if row[c].strip():
            row[c] = f"{float(row[c]) + 200:.5f}".encode()
    return rows


def untouched(rows: Fields) -> Fields:
    """The cube where it started for the whole take: a push that never touched it."""
    first = rows[0][_columns(CUBE)]
    for row in rows:
        row[_columns(CUBE)] = list(first)
    return rows


def damaged_root(root: Path, mocap: Path, task: str, change: Callable[[Fields], Fields]) -> tuple[Path, str]:
    """A data root with eight real repeats of ``task``, the fourth changed by ``change``; its file name."""
    folder = root / task
    folder.mkdir(parents=True)
    files = sorted((mocap / task).glob("*.tsv"))[:8]
    for i, src in enumerate(files):
        if i == DAMAGED:
            rewrite(src, folder / src.name, change)
        else:
            shutil.copy(src, folder / src.name)
    return root, files[DAMAGED].name


def load(root: Path, task: str, keep: bool = False):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ref = load_references(root, [get_task(task)], reference="aligned", keep_repeats=keep)[task]
    return ref, [str(w.message) for w in caught if issubclass(w.category, RecordingWarning)]


CASES = [
    ("single", mirrored),
    ("cube", mirrored),
    ("single", swapped),
    ("cube", swapped),
    ("single", glitch),
    ("cube", glitch),
    ("cube", untouched),
]


@pytest.mark.parametrize(("task", "change"), CASES, ids=[f"{t}-{c.__name__}" for t, c in CASES])
def test_damaged_repeat_is_named_and_left_out(tmp_path: Path, mocap_root: Path, task: str, change) -> None:
    root, name = damaged_root(tmp_path, mocap_root, task, change)
    ref, messages = load(root, task)
    assert [p.name for p in ref.left_out] == [name]
    assert name not in [p.name for p in ref.sources] and len(ref.sources) == 7
    named = [m for m in messages if "repeat check" in m]
    assert len(named) == 1 and named[0].startswith(f"{task}/{name}: repeat check: left out")
    assert "--keep-repeats" in named[0]
    kept, messages = load(root, task, keep=True)
    assert kept.left_out == [] and len(kept.sources) == 8
    assert not [m for m in messages if "repeat check" in m]


def test_no_real_repeat_is_left_out(mocap_root: Path) -> None:
    for task in ("single", "cube"):
        for reference in ("aligned", "mean"):
            ref = load_references(mocap_root, [get_task(task)], reference=reference)[task]
            assert ref.left_out == [] and len(ref.sources) == 23, (task, reference)


def test_far_repeats_needs_a_majority() -> None:
    rng = np.random.default_rng(0)
    good = rng.normal(0, 0.001, (6, 50, 3))
    bad = good.copy()
    bad[2] += 0.3
    assert [f.index for f in far_repeats(bad, None, None)] == [2]
    assert far_repeats(bad[:2], None, None) == []  # two repeats: which one is wrong?
    split = good.copy()
    split[:3] += 0.3  # half and half: no majority agrees
    assert far_repeats(split, None, None) == []
    assert far_repeats(good, None, None) == []


def test_check_and_evaluate_name_it(tmp_path: Path, mocap_root: Path, capsys) -> None:
    root, name = damaged_root(tmp_path, mocap_root, "single", mirrored)
    summary, reference = task_quality("mujoco", get_task("single"), root)
    assert summary["repeat_check_left_out"] == [name] and len(reference.sources) == 7
    assert sum(name in line for line in summary["left_out"]) == 1  # once, though both references were read
    summary, _ = task_quality("mujoco", get_task("single"), root, keep=True)
    assert summary["repeat_check_left_out"] == [] and len(summary["repeats"]) == 8
    from simtune.cli import main

    for extra, named in (([], True), (["--keep-repeats"], False)):
        argv = sys.argv
        sys.argv = ["simtune", "evaluate", "--task", "single", "--data", str(root), "--json", *extra]
        try:
            with pytest.raises(SystemExit) as info:
                main()
        finally:
            sys.argv = argv
        captured = capsys.readouterr()
        assert (info.value.code or 0) == 0, captured.err
        assert (f"single/{name}: repeat check: left out" in captured.err) is named


def test_run_fingerprint_records_left_out_repeats(tmp_path: Path, mocap_root: Path) -> None:
    root, name = damaged_root(tmp_path, mocap_root, "single", glitch)
    config = RunConfig(optimizer="de", engine="mujoco", tasks="single", space="shared", data=str(root))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fingerprint = run_fingerprint(plan_run(config))
        kept = run_fingerprint(plan_run(RunConfig(**{**config.record(), "keep_repeats": True})))
    assert fingerprint["left_out"] == {"single": [name]}
    assert "left_out" not in kept  # as every run stored before the check
    assert "keep_repeats" not in config.record()
    assert RunConfig(**{**config.record(), "keep_repeats": True}).record()["keep_repeats"] is True
    # a resume whose check leaves out other repeats than the run's start is told so, naming the file
    assert left_out_changes({}, fingerprint["left_out"]) == [f"the repeat check now leaves out single/{name}"]
    assert left_out_changes(fingerprint["left_out"], {}) == [
        f"the repeat check now keeps single/{name} (left out when the run started)"
    ]


def test_report_and_export_read_the_repeats_a_run_was_scored_against(tmp_path: Path, mocap_root: Path) -> None:
    """A run tuned with --keep-repeats is reported against every repeat, one without against the screened ones."""
    from simtune.report.collect import load_run
    from simtune.report.simulate import References
    from simtune.runs import start_run

    root, _ = damaged_root(tmp_path, mocap_root, "single", glitch)
    counts = {}
    for keep in (False, True):
        config = RunConfig(optimizer="de",
            engine="mujoco", tasks="single", space="extended", data=str(root), only=["command_delay"],
            max_evaluations=6, keep_repeats=keep,
        )  # fmt: skip
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            start_run(config, tmp_path / f"run-{keep}", show_progress=False)
            run = load_run(tmp_path / f"run-{keep}")
            counts[keep] = len(References().for_run(run)["single"].sources)
    assert counts == {False: 7, True: 8}
