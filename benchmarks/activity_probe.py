"""The activity probe on one process and on worker processes: its wall time, and that both find the same.

    python benchmarks/activity_probe.py [--engines mujoco,dart] [--task cube] [--space calibrated] [--workers 2]

A run measures which parameters can act before it searches (`simtune.activity`, cached afterwards); on a
fresh cache that probe is the first thing a user waits for: minutes for the slow engines.  Each engine's
probe runs uncached, first on one process, then on --workers processes; the times, their ratio and whether
the two outcomes are equal are printed.
"""

from __future__ import annotations

import os
import time

from common import add_engines_option, make_parser

from simtune.activity import measure_activity
from simtune.engines import engine_class
from simtune.params import get_space
from simtune.tasks import get_task


def main() -> None:
    parser = make_parser(__doc__)
    add_engines_option(parser, "mujoco,dart")
    parser.add_argument("--task", default="cube")
    parser.add_argument("--space", default="calibrated")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    task = get_task(args.task)
    print(f"activity probe, task {args.task}, space {args.space}, {os.cpu_count()} cores, {time.strftime('%Y-%m-%d')}")
    for engine in args.engines.split(","):
        space = get_space(args.space, engine_class(engine).supported(task.robot), robot=task.robot)
        seconds, found = [], []
        for workers in (1, args.workers):
            t0 = time.perf_counter()
            found.append(measure_activity(engine, task, space, workers=workers))
            seconds.append(time.perf_counter() - t0)
        active = sum(a.active for a in found[0].values())
        print(
            f"{engine}: {len(space.names)} parameters, {active} active; 1 process {seconds[0]:.1f} s, "
            f"{args.workers} processes {seconds[1]:.1f} s (x{seconds[0] / seconds[1]:.2f}); "
            f"same outcome: {found[0] == found[1]}; load average {os.getloadavg()[0]:.2f}"
        )


if __name__ == "__main__":
    main()
