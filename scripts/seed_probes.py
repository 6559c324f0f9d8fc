"""Measure the inactive-parameter probe of every bundled task and space, and write what simtune ships of it.

A run's first step on a fresh machine is the probe (``simtune.activity``): which parameters change a task's
rollouts, measured with a few hundred rollouts, half a minute to minutes before the search.  Its outcome depends on
the engine's version, the task, the robot and the space, all fixed for the bundled MICO project, so simtune ships
it (``src/simtune/projects/probes.json.gz``) and a first run of a bundled task reads it instead (issue 44, a cold
start within seconds).  Each entry names the engine version it was measured on and keeps a witness (a few of its
rollouts, sampled), so that it also answers for another version of the engine that rolls the witness out the same
(issue 66: a patch release).  Run this after a change to a bundled task, the robot, a space or an engine that a test
(``tests/test_activity_cache.py``) says moved a key or no longer replays, with the locked versions installed
(``requirements/lock.txt``), and commit the file.

Each entry is measured afresh (the cache is neither read nor written), for each engine named, each bundled task
(each of its target sets: what the robot ran, and the published ones where a task corrects them) and each space.

    python scripts/seed_probes.py [--engines mujoco] [--tasks single,cube,double] [--workers 2]
"""

from __future__ import annotations

import argparse
import gzip
import json
import sys
import time

from simtune.activity import SHIPPED_PROBES, shipped_entry, shipped_name, task_activity
from simtune.params.space import SPACES
from simtune.run_config import RunConfig
from simtune.run_plan import plan_run
from simtune.tasks import TARGETS


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--engines", default="mujoco", help="comma-separated engines (default: mujoco)")
    parser.add_argument("--tasks", default="single,cube,double", help="bundled tasks (default: single,cube,double)")
    parser.add_argument("--spaces", default=",".join(SPACES), help=f"spaces (default: {','.join(SPACES)})")
    parser.add_argument("--workers", type=int, default=1, help="worker processes per probe (default: 1)")
    parser.add_argument("--keep", action="store_true", help="keep the file's other entries (default: only today's)")
    args = parser.parse_args()
    entries: dict[str, dict] = {}
    if args.keep and SHIPPED_PROBES.exists():
        entries.update(json.loads(gzip.decompress(SHIPPED_PROBES.read_bytes())))
    for engine in args.engines.split(","):
        for task_name in args.tasks.split(","):
            for space_name in args.spaces.split(","):
                for targets in TARGETS:
                    config = RunConfig(engine=engine, tasks=task_name, space=space_name, targets=targets)
                    plan = plan_run(config)
                    (task,) = plan.tasks
                    name = shipped_name(engine, task, plan.full_space)
                    if name in entries:
                        continue  # the published targets equal the task's where the task corrects none
                    started = time.monotonic()
                    found = task_activity(engine, task, plan.full_space, use_cache=False, workers=args.workers)
                    entries[name] = shipped_entry(engine, task, plan.full_space, found)
                    inactive = sum(not a.active for a in found.values())
                    print(
                        f"{name}: {inactive} of {len(found)} inactive ({time.monotonic() - started:.1f} s)",
                        flush=True,
                    )
    text = json.dumps(entries, sort_keys=True, indent=0) + "\n"
    # mtime 0: the same outcomes give the same bytes, so a rerun that changes nothing leaves git nothing to commit
    SHIPPED_PROBES.write_bytes(gzip.compress(text.encode(), mtime=0))
    print(f"{len(entries)} entries -> {SHIPPED_PROBES}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
