"""The README's walk-through, as written (issue 48): every block marked ``# readme-run:`` runs in an empty folder
and leaves a tuned model of `cube` on the real recordings, its report, its export and an own robot's project."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest
from conftest import MOCAP

ROOT = Path(__file__).resolve().parent.parent


def _script():
    spec = importlib.util.spec_from_file_location("readme_blocks", ROOT / "scripts" / "readme_blocks.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_readme_marks_its_walk_through_and_every_marked_block_is_bash():
    blocks = _script().readme_blocks(ROOT / "README.md")
    titles = [title for title, _ in blocks]
    assert any("cube on the real recordings" in t for t in titles) and any("own robot" in t for t in titles)
    for _, body in blocks:
        assert "..." not in body, "a block that is run must be runnable as written"


@pytest.mark.slow  # the README's walk-through: a 180-s tune of cube, its report and export, an own robot (6 min)
@pytest.mark.skipif(not (MOCAP / "cube").is_dir(), reason=f"the real recordings are not at {MOCAP}")
def test_the_readme_walk_through_runs_as_written(tmp_path):
    problems = _script().run_blocks(ROOT / "README.md", tmp_path, MOCAP, Path(sys.executable).parent)
    assert problems == []


def test_every_flag_the_readme_gives_a_command_is_in_that_commands_help():
    """Nothing in the README disagrees with --help: each `simtune CMD ... --flag` of its code blocks names a flag
    CMD takes."""
    import re

    from typer.testing import CliRunner

    from simtune.cli import app

    text = (ROOT / "README.md").read_text()
    used: dict[str, set[str]] = {}
    for body in re.findall(r"^```[a-z]*\n(.*?)^```", text, flags=re.S | re.M):
        for line in body.splitlines():
            found = re.search(r"\bsimtune ([a-z][a-z-]*)(.*)", line.split("#")[0])
            if found:
                used.setdefault(found.group(1), set()).update(re.findall(r"(--[a-z][a-z-]*)", found.group(2)))
    assert {"tune", "report", "export", "init", "check"} <= set(used) and "--max-seconds" in used["tune"]
    runner = CliRunner()
    for command, flags in sorted(used.items()):
        result = runner.invoke(app, [command, "--help"], env={"COLUMNS": "300", "NO_COLOR": "1"})
        assert result.exit_code == 0, f"simtune {command} --help: {result.output[-300:]}"
        missing = [f for f in sorted(flags) if f not in result.output]
        assert not missing, f"the README gives simtune {command} {missing}, which its --help does not list"
