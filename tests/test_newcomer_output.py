"""The first ten minutes (issue items 3 and 4): warnings a newcomer can act on, and an uncertainty that reads right.

A data warning is printed once per command however often the command loads the recordings, and says what to do;
simtune's own synthetic start jitter is never called odd; the uncertainty leads with what is identified, groups
the unbounded parameters by reason, explains the rank in words and never cuts a parameter's name short.
"""

from __future__ import annotations

import inspect
import re
import warnings
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from rich.console import Console

from simtune.cli import output
from simtune.data import Recording, load_task_data, write_csv
from simtune.data.clock import OUTLIER_FLOOR_S, outlying_shifts

#: when each repeat starts to move on its own clock [s]: the last one 0.9 s late, an outlier by any rule
LATE_STARTS = [1.20, 1.25, 1.18, 1.22, 1.21, 1.19, 1.24, 2.10]


def _repeat(i: int, start: float) -> Recording:
    """A wrist at rest, then out 20 cm and up 10 cm (minimum jerk), starting at ``start``; 100 Hz, 6 s."""
    t = np.arange(601) / 100.0
    u = np.clip((t - start) / 1.5, 0.0, 1.0)
    out = u**3 * (10 - 15 * u + 6 * u**2)
    wrist = np.c_[0.3 + 0.2 * out, 0.05 + 0 * out, 0.6 + 0.1 * out]
    wrist += np.random.default_rng(i).normal(0.0, 0.0005, wrist.shape)
    rot = np.tile(np.eye(3), (len(t), 1, 1))
    return Recording(source=Path(f"r{i}.csv"), time=t, positions={"wrist": wrist}, rotations={"wrist": rot})


@pytest.fixture
def command_line(monkeypatch) -> Iterator[Console]:
    """The command line's warning hook, as ``simtune.cli.main`` installs it, printing to a recording console:
    a fresh process's state (nothing shown yet) and Python's default filters."""
    err = Console(width=200, record=True)
    monkeypatch.setattr(output, "err", err)
    monkeypatch.setattr(output, "_shown", set())
    with warnings.catch_warnings():
        warnings.resetwarnings()
        warnings.simplefilter("default")
        monkeypatch.setattr(warnings, "showwarning", output.show_warning)
        yield err


def test_a_data_warning_is_printed_once_however_often_a_command_loads_the_data(tmp_path, command_line) -> None:
    folder = tmp_path / "reach"
    folder.mkdir()
    for i, start in enumerate(LATE_STARTS):
        write_csv(folder / f"r{i:02d}.csv", _repeat(i, start))
    load_task_data(folder, "reach", "wrist", reference="aligned")
    # between two loads, anything that opens a catch_warnings block (the C3D reader for every file, MuJoCo's scene
    # builder for every model) makes Python forget what it has shown
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
    load_task_data(folder, "reach", "wrist", reference="aligned")
    printed = command_line.export_text()
    assert printed.count("clock check:") == 1, printed
    # it names the repeat and says what to do: nothing for a late start, how to leave out another motion
    assert "reach/r07.csv" in printed and "(late)" in printed
    assert "Kept" in printed and "needs nothing" in printed
    assert "take its file out of the task's recordings" in printed and "simtune check --task reach" in printed


def test_distinct_warnings_are_each_printed(command_line) -> None:
    warnings.warn("first", UserWarning, stacklevel=1)
    warnings.warn("second [s]", UserWarning, stacklevel=1)  # brackets are text, not markup
    warnings.warn("first", UserWarning, stacklevel=1)
    assert command_line.export_text().splitlines() == ["warning: first", "warning: second [s]"]


def _synth_jitter_defaults() -> list[float]:
    """The start jitter ``simtune synth`` uses by default, as the API and the command line state it."""
    from simtune.cli.data_commands import synth as synth_command
    from simtune.studies.synth import make_synthetic

    return [
        inspect.signature(make_synthetic).parameters["jitter_s"].default,
        inspect.signature(synth_command).parameters["jitter_s"].default,
    ]


def test_the_outlier_floor_lies_beyond_the_synth_default_jitter() -> None:
    # a uniform jitter of +-j puts every shift within 2 j of the median; the floor leaves room for the alignment
    for jitter in _synth_jitter_defaults():
        assert 2 * 2 * jitter <= OUTLIER_FLOOR_S


@pytest.mark.parametrize("repeats", [5, 6, 8, 10, 15, 23, 40])
def test_a_uniform_designed_jitter_is_never_an_outlier(repeats: int) -> None:
    rng = np.random.default_rng(repeats)
    (jitter, *_) = _synth_jitter_defaults()
    for _ in range(500):
        delays = rng.uniform(-jitter, jitter, repeats)
        shifts = -(delays - np.median(delays)) + rng.normal(0.0, 0.003, repeats)  # and the alignment's error
        for rate in (20.0, 30.0, 100.0):  # markers, LeRobot episodes, joint logs
            assert outlying_shifts(shifts, 1.0 / rate) == [], shifts


def test_synthetic_recordings_are_not_called_odd(tmp_path) -> None:
    """``simtune synth``'s recordings with its default jitter: 8 repeats whose extremes 3 scaled MADs flagged."""
    from simtune.objective import load_task_recordings
    from simtune.studies.synth import make_synthetic
    from simtune.tasks import get_task

    make_synthetic("mujoco", "single", tmp_path, truth={"command_delay": 0.3}, repeats=8, seed=3)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        data = load_task_recordings(tmp_path / "single", get_task("single"), reference="aligned")
    assert data.alignment is not None and np.ptp(data.alignment.shifts) > 0.05  # jittered, and aligned
    assert not [w for w in caught if "clock check" in str(w.message)], [str(w.message) for w in caught]


def test_real_late_starts_stay_flagged() -> None:
    """qrg2019 ``cube``'s 23 shifts [s] (aligned, 2026-11-27): the four outliers flagged before the floor still are."""
    shifts = [
        0.0, 0.065, -0.034, -0.121, -0.005, -0.301, -0.168, -0.043, 0.033, 0.017, 0.062, -0.238,
        0.076, -0.049, -0.126, 0.003, 0.661, -0.603, 0.05, 0.744, 0.086, -0.091, 0.067,
    ]  # fmt: skip
    assert outlying_shifts(np.array(shifts), 1 / 20) == [5, 16, 17, 19]


def _summary() -> dict:
    """An uncertainty summary over the calibrated MuJoCo space: 9 identified, the others unbounded for each of
    the three reasons, rank 12 of 42 searched."""
    from simtune.engines import engine_class
    from simtune.params import get_space

    names = get_space("calibrated", engine_class("mujoco").supported()).names
    inactive = set(names[-22:])
    kinked = set(names[:2])  # the time step, for one
    identified = [n for n in names if n not in inactive and n not in kinked][-9:]
    entries = []
    for k, name in enumerate(names):
        value = 0.01 * (k + 1)
        pinned = name in identified
        entries.append(
            {
                "name": name,
                "value": value,
                "low": value * 0.9 if pinned else None,
                "high": value * 1.1 if pinned else None,
                "active": name not in inactive,
                "identifiable": pinned,
            }
        )
    return {
        "parameters": entries,
        "rank": 12,
        "searched": 42,
        "condition_number": 3.4e4,
        "non_smooth": sorted(kinked),
        "correlated_pairs": [{"a": identified[0], "b": identified[1], "correlation": 0.91}],
    }


@pytest.mark.parametrize("short", [True, False])
@pytest.mark.parametrize("width", [80, 50])
def test_uncertainty_shows_every_full_name_and_says_what_it_means(monkeypatch, short: bool, width: int) -> None:
    console = Console(width=width, record=True)
    monkeypatch.setattr(output, "out", console)
    summary = _summary()
    output.print_uncertainty(summary, short=short, run_dir=Path("runs/x"))
    text = console.export_text()
    assert "…" not in text
    for entry in summary["parameters"]:  # each name whole, never cut short or broken across lines
        assert re.search(rf"(?<![\w]){re.escape(entry['name'])}(?![\w])", text), entry["name"]
    words = " ".join(text.split())
    # what is identified comes first, then the rank in words
    assert words.startswith("uncertainty at the best point (Gauss-Newton, 95 % intervals): identified: 9 of the 42")
    assert "rank 12 of 42: the recordings respond to 12 of the 42 independent directions" in words
    assert "the other 30 change the motion less than 1e-06 times as much as the strongest" in words
    # the unbounded, one group per reason, not a row each
    assert "not identified (55, intervals unbounded), by reason:" in words
    assert "22 change no simulated motion of these tasks" in words
    assert "2 make the motion jump rather than slope here" in words
    assert "31 trade off against other parameters" in words
    assert "unbounded" not in text.replace("intervals unbounded", "")
    if short:
        assert "simtune uncertainty runs/x" in words
    else:
        assert "timestep = 0.01" in words  # every parameter with its value
    assert "`simtune uncertainty runs/x --bootstrap 30` gives the non-smooth ones intervals from refits" in words


def test_uncertainty_with_bootstrap_draws_says_so_and_groups_no_parameter_as_non_smooth(monkeypatch) -> None:
    console = Console(width=80, record=True)
    monkeypatch.setattr(output, "out", console)
    output.print_uncertainty(_summary() | {"bootstrap_draws": 30}, short=False, run_dir=Path("runs/x"))
    words = " ".join(console.export_text().split())
    assert words.startswith("uncertainty at the best point (Gauss-Newton and 30 bootstrap draws of the repeats, 95 %")
    assert "make the motion jump" not in words and "--bootstrap" not in words
    assert "33 trade off against other parameters" in words  # the 2 kinked ones too wide even for the draws


def test_uncertainty_error_is_one_line(monkeypatch) -> None:
    console = Console(width=80, record=True)
    monkeypatch.setattr(output, "out", console)
    output.print_uncertainty({"error": "no [best] point"}, short=True, run_dir=Path("runs/x"))
    assert console.export_text() == "  uncertainty not computed: no [best] point\n"


@pytest.mark.slow  # 8 s: a tune with its progress line
def test_the_progress_line_counts_what_the_summary_counts(tmp_path, monitor_progress):
    """The progress line's evaluations are the run store's (issue 48: a new folder's line said "301 evals (57 from
    store)" where the summary said 244): points the search asks for again are no new evaluations; a resumed run
    counts the earlier sessions' too, and says so."""
    from simtune.reference import REFERENCE_DIR
    from simtune.runs import RunConfig, resume_run, start_run

    config = RunConfig(
        engine="mujoco", tasks="cube", space="extended", data=str(REFERENCE_DIR), seed=1,
        only=["command_delay", "marker_offset_z"], optimizer="auto", max_evaluations=80,
    )  # fmt: skip
    first = start_run(config, tmp_path / "run", show_progress=False)
    progress = monitor_progress[-1]
    assert progress.stored == 0 and progress.stored + progress.simulated == first.evaluations
    assert progress.reused > 0  # the search did ask for some points twice: they are not counted again
    from simtune.store import RunStore

    # as if killed after its last evaluation: replayed from the store (a finished run is given back as stored)
    store = RunStore(tmp_path / "run")
    store.set(status="running")
    store.close()
    resumed = resume_run(tmp_path / "run", show_progress=False)
    progress = monitor_progress[-1]
    assert progress.stored == first.evaluations and progress.simulated == 0
    assert progress.stored + progress.simulated == resumed.evaluations


@pytest.fixture
def monitor_progress(monkeypatch):
    """Every TuneProgress a run makes, kept for the test to read."""
    from simtune import runs
    from simtune.optimize.progress import TuneProgress

    made: list[TuneProgress] = []

    class Kept(TuneProgress):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            made.append(self)

    monkeypatch.setattr(runs, "TuneProgress", Kept)
    return made
