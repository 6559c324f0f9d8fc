"""How long `simtune design` takes for a six-joint arm: the bundled MICO's whole drivetrain space (issue 68: <= 2 min).

Runs the command as a user does, a whole process from a fresh interpreter, and prints its wall time, the design's
own (its summary's ``wall_s``), the ratio to the 120-s target, the criterion against the project's task and how many
parameters the design and the task identify.

    python benchmarks/design_speed.py [--space drivetrain] [--duration 40] [--workers 2] [--task cube]
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import make_parser

TARGET_S = 120.0


def main() -> None:
    parser = make_parser(__doc__)
    parser.add_argument("--space", default="drivetrain")
    parser.add_argument("--duration", type=float, default=40.0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--task", default="cube")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="simtune-design-") as scratch:
        out = Path(scratch) / "id.toml"
        command = [
            sys.executable, "-m", "simtune.cli", "design", "--engine", "mujoco", "--task", args.task,
            "--space", args.space, "--duration", f"{args.duration:g}", "--workers", str(args.workers),
            "--out", str(out), "--json",
        ]  # fmt: skip
        started = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True, check=False)
        wall = time.perf_counter() - started
        if done.returncode != 0:
            sys.exit(f"simtune design failed ({done.returncode}): {done.stderr.strip()}")
        summary = json.loads(done.stdout)
    parameters = summary["parameters"]
    criterion = summary["criterion"]
    print(
        f"simtune design, {len(parameters)} parameters of {args.space!r}, {args.duration:g} s, {args.workers} workers"
    )
    print(f"  whole process {wall:.1f} s (the design itself {summary['wall_s']:.1f} s); target {TARGET_S:g} s: "
          f"{wall / TARGET_S:.2f} x")  # fmt: skip
    print(f"  log det: design {criterion['design_log_det']:.1f}, {args.task} {criterion['current_log_det']:.1f}")
    print(
        f"  identified: design {sum(bool(p['identified']) for p in parameters)}, "
        f"{args.task} {sum(bool(p['current_identified']) for p in parameters)} of {len(parameters)}"
    )


if __name__ == "__main__":
    main()
