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
