"""What a rollout costs in each engine on public robot descriptions as published (tests/robot_corpus.py's corpus).

Per robot: ``simtune init`` from the installed package's file, then in each engine one generic rollout of the
example ``reach`` timed after a first one (the engine built and warm): seconds of wall time per simulated second,
the physics steps per second, and each engine's time against MuJoCo's.  ``--simtune-src`` times another simtune
(``git worktree add /tmp/before <commit>``) in the same run, each engine in a fresh process, before and after
alternated, and prints the ratio: what a change to an engine's model building did, on the same host, minutes apart.

    python benchmarks/engine_rollouts.py [--robots "SO-101,Franka Panda"] [--engines mujoco,pybullet,ode,dart,drake]
        [--repeats 3] [--simtune-src /tmp/before/src] [--results benchmarks/results]

Writes ``engine-rollouts-<date>.md`` and ``.json`` to --results; prints the table.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import add_engines_option, add_results_option, make_parser, write_json_result, write_result

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from robot_corpus import CORPUS, ENGINES, cli, init_args, slug

#: What one timing process runs: the project's reach in one engine, a first rollout, then ``repeats`` timed ones.
_TIMER = """
import json, sys, time, warnings
warnings.simplefilter("ignore")
from simtune.engines import engine_class
from simtune.engines.contact import rollout_samples
from simtune.project import load_project
project, engine, repeats = sys.argv[1], sys.argv[2], int(sys.argv[3])
task = load_project(project).task("reach")
sim = engine_class(engine)(task)
n = rollout_samples(task.duration)
first = sim.rollout({}, n)
walls = []
for _ in range(repeats):
    start = time.perf_counter()
    rollout = sim.rollout({}, n)
    walls.append(time.perf_counter() - start)
print(json.dumps({"walls": walls, "steps": rollout.steps, "simulated_s": task.duration, "stable": rollout.stable}))
"""


def time_engine(project: Path, engine: str, repeats: int, src: str | None) -> dict:
    """One engine's rollouts of ``project``'s reach in a process of their own (``src``: another simtune's code)."""
    env = dict(os.environ)
    if src is not None:
        env["PYTHONPATH"] = src
    result = subprocess.run(
        [sys.executable, "-c", _TIMER, str(project), engine, str(repeats)],
        check=False,
        capture_output=True,
        text=True,
        env=env,
        timeout=1800,
    )
    if result.returncode != 0:
        last = (result.stderr.strip().splitlines() or ["(no output)"])[-1]
        return {"error": last[:200]}
    return json.loads(result.stdout.strip().splitlines()[-1])


def per_second(row: dict) -> str:
    """Median wall seconds per simulated second, with min-max."""
    if "error" in row:
        return "failed"
    walls = [w / row["simulated_s"] for w in row["walls"]]
    return f"{statistics.median(walls):.3g} [{min(walls):.3g}, {max(walls):.3g}]"


def median_wall(row: dict) -> float | None:
    return None if "error" in row else statistics.median(row["walls"])


def table(rows: list[dict], engines: list[str], before: bool) -> str:
    """The markdown table: per robot and engine, wall seconds per simulated second (and before / after)."""
    head = "| robot | engine | wall s per simulated s, median [min, max] | steps/s | x MuJoCo |"
    line = "|---|---|---|---:|---:|"
    if before:
        head += " before: wall s per simulated s | after / before |"
        line += "---|---:|"
    out = [head, line]
    for row in rows:
        mujoco = median_wall(row["after"].get("mujoco", {"error": ""}))
        for engine in engines:
            after = row["after"][engine]
            wall = median_wall(after)
            steps = "-" if wall is None else f"{after['steps'] / wall:,.0f}"
            ratio = "-" if wall is None or not mujoco else f"{wall / mujoco:.1f}"
            cells = [row["robot"], engine, per_second(after), steps, ratio]
            if before:
                old = row["before"][engine]
                old_wall = median_wall(old)
                cells += [per_second(old), "-" if wall is None or not old_wall else f"{wall / old_wall:.2f}"]
            out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


def main() -> None:
    parser = make_parser(__doc__)
    parser.add_argument("--robots", default="SO-101,Franka Panda", help="corpus robot names joined by commas")
    add_engines_option(parser, ",".join(ENGINES))
    parser.add_argument("--repeats", type=int, default=3, help="timed rollouts per engine, after a first one")
    parser.add_argument("--simtune-src", help="also time this simtune's src folder (before), alternated")
    add_results_option(parser)
    args = parser.parse_args()
    engines = [e.strip() for e in args.engines.split(",") if e.strip()]
    wanted = [name.strip() for name in args.robots.split(",") if name.strip()]
    robots = {robot.name: robot for robot in CORPUS}
    unknown = [name for name in wanted if name not in robots]
    if unknown:
        sys.exit(f"--robots: unknown {', '.join(unknown)}; the corpus has {', '.join(robots)}")
    rows = []
    started = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        for name in wanted:
            robot = robots[name]
            if robot.path is None:
                print(f"{name}: its package ({robot.package}) is not installed: left out", flush=True)
                continue
            project = Path(tmp) / slug(robot)
            made = cli(*init_args(robot, project))
            if made.returncode != 0:
                print(f"{name}: simtune init failed: {made.stderr.strip()[:200]}", flush=True)
                continue
            row: dict = {"robot": name, "after": {}, "before": {}}
            for engine in engines:
                if args.simtune_src:
                    row["before"][engine] = time_engine(project, engine, args.repeats, args.simtune_src)
                row["after"][engine] = time_engine(project, engine, args.repeats, None)
                print(f"{name}, {engine}: {per_second(row['after'][engine])} s per simulated s", flush=True)
            rows.append(row)
    text = table(rows, engines, bool(args.simtune_src))
    note = (
        f"One generic rollout of each robot's example reach per engine, timed {args.repeats} times after a first "
        f"(each engine in a process of its own); {time.perf_counter() - started:.0f} s in all"
        + (f"; before = {args.simtune_src}, alternated with after" if args.simtune_src else "")
    )
    print(f"\n{note}\n\n{text}")
    write_result(args.results, "engine-rollouts", "md", f"{note}\n\n{text}\n")
    write_json_result(args.results, "engine-rollouts", {"note": note, "rows": rows})


if __name__ == "__main__":
    main()
