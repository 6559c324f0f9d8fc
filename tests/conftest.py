"""Shared fixtures: the engines to test, paths to the real data set (when present) and the shipped reference."""

from pathlib import Path

import pytest

from simtune.engines import ENGINES, Engine, engine_class
from simtune.errors import EngineUnavailable

#: Engines whose rollouts cost seconds (DART about 0.7 s, Drake about 4 s per `cube` rollout):
#: tests that sweep many rollouts run them in the slow tier.
COSTLY_ENGINES = frozenset({"dart", "drake"})
#: Engines whose long rollouts (every task, 20 s of `cube`) belong in the slow tier too.
SLOWEST_ENGINES = frozenset({"drake"})
#: Engines every test of which is slow without a GPU: MuJoCo Warp builds its kernels for about a minute on first
#: use and steps one world 20-50 times slower than MuJoCo on Warp's CPU device.
GPU_ENGINES = frozenset({"mujoco-warp"})
#: The engines of the registry that run on a CPU (all but the GPU's), in the registry's order: those every robot
#: must load in.
CPU_ENGINES = tuple(name for name in ENGINES if name not in GPU_ENGINES)


def engine_or_skip(name: str) -> type[Engine]:
    """The engine class called ``name``; the test is skipped with the engine's install command if it is missing."""
    try:
        return engine_class(name)
    except EngineUnavailable as exc:
        pytest.skip(str(exc))


def every_engine(slow: frozenset[str] = frozenset()) -> list:
    """Every engine of the registry as a test parameter; those in ``slow`` (and the GPU engines) marked for the
    slow tier."""
    return [pytest.param(name, marks=[pytest.mark.slow] if name in slow | GPU_ENGINES else []) for name in ENGINES]


ROOT = Path(__file__).resolve().parents[1]
QRG2019 = ROOT.parent / "shared" / "datasets" / "qrg2019"
MOCAP = QRG2019 / "mocap"


@pytest.fixture(scope="session")
def mocap_root() -> Path:
    if not MOCAP.is_dir():
        pytest.skip(f"real recordings not found at {MOCAP}")
    return MOCAP


@pytest.fixture(scope="session")
def two_task_data(tmp_path_factory) -> Path:
    """A data root with recordings of two tasks: the shipped `cube` and a synthetic `single`."""
    import shutil

    from simtune.data import write_qualisys_tsv
    from simtune.reference import REFERENCE_DIR
    from simtune.reference.make import synthesize
    from simtune.tasks import get_task

    root = tmp_path_factory.mktemp("data")
    shutil.copytree(REFERENCE_DIR / "cube", root / "cube")
    (root / "single").mkdir()
    for rec in synthesize(
        "mujoco", get_task("single"), {"command_delay": 1.2}, repeats=2, noise_m=0.002, jitter_s=0.05, seed=1
    ):
        write_qualisys_tsv(root / "single" / rec.source.name, rec, header=True)
    return root


def stored_evaluations(run_dir: Path) -> int:
    """Evaluations in a run store another process may be writing or creating right now (0 until it exists)."""
    from simtune.errors import SimtuneError
    from simtune.store import RunStore

    if not (run_dir / "run.sqlite").exists():
        return 0
    try:
        store = RunStore(run_dir)
    except SimtuneError:  # created this instant: not yet versioned
        return 0
    try:
        return store.count_evaluations()
    finally:
        store.close()


def kill_when(cmd: list[str], run_dir: Path, at_count: int, limit_s: float = 120) -> int:
    """Start ``cmd``, SIGKILL it once its run store holds ``at_count`` evaluations; the count it left."""
    import os
    import signal
    import subprocess
    import time

    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + limit_s
    while time.time() < deadline and proc.poll() is None and stored_evaluations(run_dir) < at_count:
        time.sleep(0.02)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    return stored_evaluations(run_dir)


def cli_in_process(*args: str, capsys) -> tuple[int, str, str]:
    """The command line run in this process, as a user runs it (warnings as `warning:` lines): exit status, stdout,
    stderr."""
    import sys

    from simtune.cli import main

    argv = sys.argv
    sys.argv = ["simtune", *args]
    try:
        with pytest.raises(SystemExit) as info:
            main()
    finally:
        sys.argv = argv
    captured = capsys.readouterr()
    return int(info.value.code or 0), captured.out, captured.err
