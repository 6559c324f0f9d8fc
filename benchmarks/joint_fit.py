"""One simulator for every task (issue 67): the MICO's generalisation table over seeds, and an own robot's.

For each seed it runs ``simtune generalise`` (each task tuned alone, both together, each scored held out with its
clock aligned) as a user would, in a fresh process, MuJoCo, the default ``tune`` settings unless given, and
prints per task the medians over the seeds beside the issue's done-when:

* tuned on ``single`` + ``cube`` together: ``single``'s part <= 0.0030 and ``cube``'s <= 0.0086 (2 x their floors);
* held out: tuned on ``cube``, ``single`` <= 0.0060; tuned on ``single``, ``cube``'s wrist part within 2 x its own
  alone-best wrist part.

``--robot panda`` runs the same study on the Franka Panda from ``pybullet_data`` (``simtune init``), its ``reach``
and the ``push`` of benchmarks/panda_recovery.py both synthesised from one truth: there the joint-fit penalty
should be <= 1.1, since one truth made both tasks.

    python benchmarks/joint_fit.py [--seeds 0,1,2] [--workers 2] [--robot mico|panda] [--data ROOT]
        [--out DIR] [--results benchmarks/results] [-- EXTRA SIMTUNE OPTIONS]

Writes ``joint-fit-<robot>-<date>.md`` and ``.json`` to --results; prints the table.  The runs stay in --out
(default: a temporary folder), so a second call with the same --out reuses them.
"""

from __future__ import annotations

import json
import statistics
import tempfile
import time
from pathlib import Path

from common import (
    QRG2019_DATA,
    add_data_option,
    add_results_option,
    last_json,
    make_parser,
    simtune,
    write_json_result,
    write_result,
)

#: the issue's done-when, as (task, what, limit): what is "joint", "held_out" or "held_out_wrist_over_alone"
MICO_LIMITS = (
    ("single", "joint", 0.0030),
    ("cube", "joint", 0.0086),
    ("single", "held_out", 0.0060),
    ("cube", "held_out_wrist_over_alone", 2.0),
)
PANDA_PENALTY_LIMIT = 1.1
#: the Panda's one truth, for both of its tasks (reach, push); the rest generic
PANDA_TRUTH = {"command_delay": 0.3, "max_velocity_joint_2": 22.0, "mass_cube_plastic": 0.085}


def panda_data(work: Path) -> tuple[Path, Path]:
    """The Panda project (reach and push) and its synthetic recordings of one truth."""
    from panda_recovery import SERVO_GAIN, make_project

    project = work / "panda"
    data = work / "panda-data"
    if not project.exists():
        make_project(work, SERVO_GAIN)
    if not data.exists():
        truth = work / "panda-truth.json"
        truth.write_text(json.dumps(PANDA_TRUTH))
        simtune(
            "synth", "--project", project, "--task", "reach,push", "--truth", truth, "--repeats", "5",
            "--noise-mm", "1", "--jitter-s", "0.02", "--seed", "7", "--out", data,
        )  # fmt: skip
    return project, data


def study(seed: int, args, work: Path, extra: list[str]) -> dict:
    """One seed's ``simtune generalise --json`` and how long it took."""
    if args.robot == "panda":
        project, data = panda_data(work)
        where = ["--project", project, "--task", "reach,push", "--data", data]
    else:
        where = ["--task", "single,cube", "--data", args.data]
    started = time.perf_counter()
    out = simtune(
        "generalise", *where, "--engine", "mujoco", "--seed", seed, "--workers", args.workers,
        "--out", work / f"{args.robot}-seed-{seed}", "--json", *extra,
    )  # fmt: skip
    result = last_json(out)
    result["command_s"] = time.perf_counter() - started
    return result


def table(results: list[dict], robot: str) -> str:
    """The medians over the seeds, per task, with the done-when's limits where the robot has them."""
    lines = [
        f"| task | floor | alone | joint | joint/alone | held out (clock aligned) | held out / alone | "
        f"held-out wrist / alone wrist | seeds ({robot}) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    names = [r["task"] for r in results[0]["rows"]]
    for name in names:
        rows = [next(r for r in result["rows"] if r["task"] == name) for result in results]

        def median(pick, rows=rows) -> float:
            return statistics.median(pick(r) for r in rows)

        floor = rows[0]["floor"]
        wrist = [r for r in rows if r["alone"]["wrist"] and r["held_out"]["wrist"] is not None]
        wrist_ratio = statistics.median(r["held_out"]["wrist"] / r["alone"]["wrist"] for r in wrist) if wrist else None
        lines.append(
            f"| {name} | {'-' if floor is None else f'{floor:.4f}'} | {median(lambda r: r['alone']['fitness']):.4f} "
            f"| {median(lambda r: r['joint']['fitness']):.4f} | {median(lambda r: r['penalty']):.2f} "
            f"| {median(lambda r: r['held_out']['fitness']):.4f} | {median(lambda r: r['transfer']):.2f} "
            f"| {'-' if wrist_ratio is None else f'{wrist_ratio:.2f}'} | {len(rows)} |"
        )
    return "\n".join(lines)


def verdicts(results: list[dict], robot: str) -> list[str]:
    """Each done-when line with the measured median and whether it holds."""
    lines = []
    if robot == "panda":
        penalty = statistics.median(r["joint_penalty"] for r in results)
        mark = "holds" if penalty <= PANDA_PENALTY_LIMIT else "does not hold"
        return [f"- joint-fit penalty (median of tasks and seeds) {penalty:.2f} <= {PANDA_PENALTY_LIMIT}: {mark}"]
    for task, what, limit in MICO_LIMITS:
        values = []
        for result in results:
            row = next(r for r in result["rows"] if r["task"] == task)
            if what == "held_out_wrist_over_alone":
                values.append(row["held_out"]["wrist"] / row["alone"]["wrist"])
            else:
                values.append(row[what]["fitness"])
        value = statistics.median(values)
        mark = "holds" if value <= limit else "does not hold"
        lines.append(f"- {task} {what.replace('_', ' ')}: {value:.4f} <= {limit}: {mark}")
    return lines


def main() -> int:
    parser = make_parser(__doc__, whole_doc=True)
    parser.add_argument("--seeds", default="0,1,2", help="seeds joined by commas (default 0,1,2)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--robot", choices=("mico", "panda"), default="mico")
    parser.add_argument("--out", type=Path, help="working folder for the runs (default: a temporary one)")
    add_data_option(parser, QRG2019_DATA)
    add_results_option(parser)
    args, extra = parser.parse_known_args()
    extra = [e for e in extra if e != "--"]
    seeds = [int(s) for s in args.seeds.split(",")]
    with tempfile.TemporaryDirectory() as tmp:
        work = args.out or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        results = []
        for seed in seeds:
            result = study(seed, args, work, extra)
            results.append(result)
            print(f"seed {seed}: {result['command_s']:.0f} s, evaluations {result['evaluations']}", flush=True)
    settings = f"{results[0]['space']}, {results[0]['optimizer']}, {args.workers} workers"
    text = "\n".join(
        [
            f"# One simulator for every task: {args.robot}, MuJoCo, {settings}, medians of seeds {args.seeds}",
            "",
            table(results, args.robot),
            "",
            *verdicts(results, args.robot),
            "",
            f"Command: `python benchmarks/joint_fit.py --robot {args.robot} --seeds {args.seeds} "
            f"--workers {args.workers}{' ' + ' '.join(extra) if extra else ''}`; "
            f"{sum(r['command_s'] for r in results):.0f} s in all.",
        ]
    )
    print(text)
    write_result(args.results, f"joint-fit-{args.robot}", "md", text + "\n")
    write_json_result(args.results, f"joint-fit-{args.robot}", results)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
