"""The robot corpus table of docs/robots.md: public arm descriptions as published, through the new user's path.

Per robot of ``tests/robot_corpus.py`` (URDFs used in place from pybullet_data, example-robot-data and
airo-models): ``simtune init``, ``check``, ``synth`` (MuJoCo, generic parameters, the default command delay
of 1.5 s, 2 mm noise, 3 repeats), ``evaluate`` in all five engines (the generic fitness against those
recordings), and ``tune --only command_delay`` in MuJoCo and PyBullet; plus each engine's forward
kinematics of the tracked link against the description's own at 3 random poses.

    python benchmarks/robot_corpus.py [--robots "SO-101,UR5"] [--tune-seconds 60] [--results benchmarks/results]

Writes ``robot-corpus-<date>.md`` (the table) and ``.json`` to --results; prints the table.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

from common import add_results_option, make_parser, today, write_json_result, write_result

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from robot_corpus import CORPUS, ENGINES, TRUE_DELAY_S, TUNED_IN, walk


def table(rows: list[dict]) -> str:
    head = (
        "| robot | package | driven joints | tracked link | loads in | FK vs description, worst [m] | "
        + " | ".join(f"generic {e} [m]" for e in ENGINES)
        + " | "
        + " | ".join(f"delay {e} [s]" for e in TUNED_IN)
        + " | commands failed |"
    )
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in rows:
        failed = [name for name, (code, _) in r["steps"].items() if code != 0]
        loads = [e for e in ENGINES if e in r["generic"]]
        fk = max(r["fk_m"].values()) if r["fk_m"] else float("nan")
        lines.append(
            f"| {r['robot']} | {r['package']} | {r.get('joints', '-')} | {r.get('tracked_link', '-')} | "
            f"{len(loads)}/{len(ENGINES)} | {fk:.1e} | "
            + " | ".join(f"{r['generic'][e]:.4f}" if e in r["generic"] else "-" for e in ENGINES)
            + " | "
            + " | ".join(f"{r['delay'][e]:.3f}" if e in r["delay"] else "-" for e in TUNED_IN)
            + f" | {', '.join(failed) or 'none'} |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = make_parser(__doc__)
    parser.add_argument("--robots", default="", help="robot names joined by commas (default: the whole corpus)")
    parser.add_argument("--tune-seconds", type=float, default=60.0)
    add_results_option(parser)
    args = parser.parse_args()
    chosen = [r for r in CORPUS if not args.robots or r.name in args.robots.split(",")]
    rows = []
    for robot in chosen:
        if robot.path is None:
            print(f"{robot.name}: package {robot.package} not installed: skipped", flush=True)
            continue
        start = time.perf_counter()
        with tempfile.TemporaryDirectory() as folder:
            row = walk(robot, Path(folder), tune_seconds=args.tune_seconds)
        row["package"], row["wall_s"] = robot.package, time.perf_counter() - start
        rows.append(row)
        print(f"{robot.name}: {row['wall_s']:.0f} s {json.dumps(row, default=str)}", flush=True)
    text = table(rows)
    date = today()
    header = (
        f"Robot corpus, {date}: `python benchmarks/robot_corpus.py --tune-seconds {args.tune_seconds:g}`; "
        f"recordings with a command delay of {TRUE_DELAY_S} s, 2 mm noise, 3 repeats: by MuJoCo for the generic "
        "columns (each engine against MuJoCo's recordings), by the engine tuned for the delay columns.\n\n"
    )
    write_result(args.results, "robot-corpus", "md", header + text + "\n")
    write_json_result(args.results, "robot-corpus", rows, indent=1, newline=False)
    print(text)


if __name__ == "__main__":
    main()
