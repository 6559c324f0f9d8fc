"""Shared fixtures: paths to the real data set (when present) and the shipped reference."""

from pathlib import Path

import pytest

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
    for rec in synthesize("mujoco", get_task("single"), {"command_delay": 1.2}, repeats=2, noise_m=0.002,
                          jitter_s=0.05, seed=1):
        write_qualisys_tsv(root / "single" / rec.source.name, rec, header=True)
    return root
