"""``simtune demo``: tune MuJoCo to the shipped reference recording, show before and after."""

from __future__ import annotations

import json
from pathlib import Path

from rich.console import Console

from simtune.common.console import text_table
from simtune.reference import REFERENCE_DIR
from simtune.run_plan import new_run_config
from simtune.runs import discard_run, has_run, read_run_record, start_run
from simtune.store.lock import run_lock

#: What the demo tunes: the parameters the reference recording hides, in the extended space's ranges.
DEMO_PARAMETERS = (
    "command_delay",
    "max_velocity_joint_2",
    "max_velocity_joint_3",
    "lateral_friction_plastic",
    "lateral_friction_floor",
    "marker_offset_x",
    "marker_offset_y",
    "marker_offset_z",
)


def run_demo(out_dir: Path, workers: int = 2, max_seconds: float = 120.0, console: Console | None = None) -> dict:
    console = console or Console()
    truth = json.loads((REFERENCE_DIR / "truth.json").read_text())
    console.print(
        f"[bold]simtune demo[/]: tune MuJoCo to the shipped reference recording of task "
        f"'{truth['task']}' ({REFERENCE_DIR / truth['task']}),\nmade by a simulation with hidden "
        f"parameters and {truth['noise_m'] * 1000:g} mm motion-capture noise."
    )
    out_dir = Path(out_dir)
    if has_run(out_dir):
        with run_lock(out_dir):  # the demo always starts afresh, but never under a run in progress
            discard_run(out_dir)
    config = new_run_config(
        "mujoco",
        truth["task"],
        "extended",
        data=REFERENCE_DIR,
        workers=workers,
        max_seconds=max_seconds,
        only=list(DEMO_PARAMETERS),
        # the demo's search as measured and documented (README): the paper's DE, no worker time-out
        optimizer="de",
        eval_timeout=None,
    )
    result = start_run(config, out_dir)
    generic = read_run_record(out_dir).generic_score
    table = text_table("generic vs tuned", ("", "fitness", "wrist error [m]", "object error [m]"))
    table.add_row(
        "generic MuJoCo", f"{generic['fitness']:.4f}", f"{generic['wrist_error']:.4f}", f"{generic['object_error']:.4f}"
    )
    s = result.score
    table.add_row("tuned", f"{s.fitness:.4f}", f"{s.wrist_error:.4f}", f"{s.object_error:.4f}")
    console.print(table)
    params = text_table("hidden truth vs tuned", ("parameter", "truth", "tuned"))
    for name in DEMO_PARAMETERS:
        params.add_row(name, f"{truth['params'][name]:.4g}", f"{result.params[name]:.4g}")
    console.print(params)
    console.print(
        f"{result.evaluations} evaluations in {result.wall_s:.0f} s; run store and best parameters in {out_dir}"
    )
    return {"generic": generic["fitness"], "tuned": s.fitness}
