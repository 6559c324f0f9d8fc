"""The tested set of versions (requirements/lock.txt) and pyproject.toml's ranges agree, and scripts/lock.py says in
one line each where a lock does not."""

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def lock():
    spec = importlib.util.spec_from_file_location("simtune_lock_script", ROOT / "scripts" / "lock.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_lock_agrees_with_pyproject(lock):
    pins = lock.read_lock()
    assert lock.disagreements(pins) == []
    core, _ = lock.requirements()
    for req in core:  # every core requirement is pinned, MuJoCo among them
        assert lock.canonicalize_name(req.name) in pins, req
    assert "mujoco" in pins and "pytest" in pins and "ruff" in pins


def test_a_pin_outside_a_range_and_a_missing_pin_are_named(lock):
    pins = lock.read_lock()
    pins["mujoco"] = "3.0.0"
    del pins["scipy"]
    found = lock.disagreements(pins)
    assert any(f.startswith("lock.txt pins mujoco==3.0.0, outside core's mujoco") for f in found), found
    assert any(f.startswith("lock.txt pins no version of scipy") for f in found), found


def test_an_extra_that_would_install_another_version_than_the_core_is_named(lock, monkeypatch):
    """The `sysid` extra once pinned MuJoCo 4.0.0 while the core took any 3.1 or later."""
    core, extras = lock.requirements()
    extras["sysid"] = [lock.Requirement("mujoco[sysid]==3.5.0")]
    monkeypatch.setattr(lock, "requirements", lambda: (core, extras))
    (found,) = lock.disagreements(lock.read_lock())
    assert found.startswith("extra 'sysid' asks mujoco[sysid]==3.5.0, which the tested mujoco==")


def test_the_check_fails_in_one_line_per_disagreement_with_exit_2(tmp_path):
    """As scripts/test.sh (and so CI) runs it, before installing: a copy of the scripts beside a lock that disagrees."""
    (tmp_path / "scripts").mkdir()
    (tmp_path / "requirements").mkdir()
    (tmp_path / "scripts" / "lock.py").write_text((ROOT / "scripts" / "lock.py").read_text())
    (tmp_path / "pyproject.toml").write_text((ROOT / "pyproject.toml").read_text())
    text = (ROOT / "requirements" / "lock.txt").read_text()
    (tmp_path / "requirements" / "lock.txt").write_text(
        "\n".join(line for line in text.splitlines() if not line.startswith("numpy=="))
    )
    done = subprocess.run([sys.executable, "scripts/lock.py", "check"], cwd=tmp_path, capture_output=True, text=True)
    assert done.returncode == 2 and done.stdout == ""
    lines = done.stderr.splitlines()
    assert (
        lines[0]
        == "error: the lock and pyproject.toml disagree: lock.txt pins no version of numpy (core asks numpy>=1.26)"
    )
    assert "scripts/lock.py refresh" in lines[-1] and len(lines) == 2
