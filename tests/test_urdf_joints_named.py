"""Issue 50 item 12: joints a URDF names wrongly are one clear line naming the file and joint, never accepted
quietly: a name used three times, a mimic of a joint the URDF lacks, mimics in a loop (errors, at load, so
``init`` and ``check`` exit 2), and a mobile base's wheels, continuous joints off the arm's chain (a warning:
the base is simulated fixed, so they never turn)."""

from __future__ import annotations

import subprocess
import sys
import warnings
from pathlib import Path

import pytest
from test_urdf_defects import BOX, INERTIAL, arm

from simtune.errors import RobotError, RobotWarning
from simtune.robot.urdf import load_urdf

pytest.importorskip("yourdfpy")

LINK = "<link name={!r}>" + INERTIAL + BOX + "</link>"
FINGER = (
    '<joint name="{name}" type="revolute"><parent link="fore"/><child link="{child}"/><axis xyz="0 1 0"/>'
    '<limit lower="0" upper="1" effort="1" velocity="1"/><mimic joint="{follows}"/></joint>'
)


def finger(name: str, child: str, follows: str) -> str:
    return LINK.format(child).replace("'", '"') + FINGER.format(name=name, child=child, follows=follows)


def wheel(name: str, child: str) -> str:
    return LINK.format(child).replace("'", '"') + (
        f'<joint name="{name}" type="continuous"><parent link="base"/><child link="{child}"/>'
        '<axis xyz="0 1 0"/></joint>'
    )


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "arm.urdf"
    path.write_text(text)
    return path


def test_a_joint_name_used_three_times(tmp_path: Path) -> None:
    extra = "".join(
        LINK.format(f"x{i}").replace("'", '"')
        + f'<joint name="elbow" type="fixed"><parent link="fore"/><child link="x{i}"/></joint>'
        for i in (1, 2)
    )
    path = write(tmp_path, arm(extra=extra))
    pattern = r"joint 'elbow' is defined 3 times \(first on line \d+, again on lines \d+, \d+\)"
    with pytest.raises(RobotError, match=pattern) as info:
        load_urdf(path)
    assert str(path) in str(info.value)


def test_a_mimic_of_a_missing_joint(tmp_path: Path) -> None:
    path = write(tmp_path, arm(extra=finger("finger", "f1", "nosuch")))
    with pytest.raises(RobotError, match="joint 'finger' mimics 'nosuch', which is not a joint of the URDF"):
        load_urdf(path)


@pytest.mark.parametrize("loop", [("fa", "fb"), ("fa",)], ids=["two", "itself"])
def test_mimics_in_a_loop(tmp_path: Path, loop: tuple[str, ...]) -> None:
    follows = loop[1:] + loop[:1]
    extra = "".join(finger(name, f"link_{name}", after) for name, after in zip(loop, follows))
    path = write(tmp_path, arm(extra=extra))
    with pytest.raises(RobotError, match="mimic joints follow each other in a loop") as info:
        load_urdf(path)
    assert str(path) in str(info.value) and "'fa'" in str(info.value)


def test_wheels_of_a_mobile_base_are_named(tmp_path: Path) -> None:
    path = write(tmp_path, arm(extra=wheel("wheel_left", "wl") + wheel("wheel_right", "wr")))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        robot = load_urdf(path)
    named = [str(w.message) for w in caught if issubclass(w.category, RobotWarning) and "wheel_left" in str(w.message)]
    assert len(named) == 1 and str(path) in named[0] and "'wheel_right'" in named[0]
    assert "off the arm's chain" in named[0]
    assert robot.arm_joints == ("shoulder", "elbow")
    with warnings.catch_warnings(record=True) as caught:  # an arm without wheels: no such warning
        warnings.simplefilter("always")
        load_urdf(write(tmp_path, arm()))
    assert not [w for w in caught if "off the arm's chain" in str(w.message)]


def test_init_says_it_in_one_line(tmp_path: Path) -> None:
    path = write(tmp_path, arm(extra=finger("fa", "f1", "fb") + finger("fb", "f2", "fa")))
    done = subprocess.run(
        [sys.executable, "-m", "simtune.cli", "init", "--robot", str(path), "--out", str(tmp_path / "project")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr and "mimic joints follow each other in a loop" in done.stderr
