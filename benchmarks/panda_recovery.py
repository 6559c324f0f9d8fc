"""The Franka Panda done-when: a URDF robot from `simtune init` to a recovered fit, in MuJoCo and PyBullet.

Everything goes through the command line, as a new user would run it:

1. ``simtune init --robot <pybullet_data>/franka_panda/panda.urdf --out P`` (the URDF used in place);
   a push task is added to P: the hand comes down behind a 6 cm plastic box on the floor and pushes it
   along +x (``simtune tasks --contact`` checks in MuJoCo that the hand touches it and moves it).
2. ``simtune synth`` in MuJoCo with known non-generic parameters (``TRUTH``: a command delay, a velocity
   clamp, the box's mass, the box's friction) and injected noise (2 mm per axis on every marker sample,
   +-0.05 s start jitter, 10 repeats) on the reach and the push.
3. The noise floor: ``simtune evaluate`` of the truth itself in MuJoCo against the noisy recordings, per task
   (and the truth's values in each engine, its other parameters generic: the gap between the engines).
   The project's ``[robot] servo_gain`` is ``--servo-gain`` (default 300 N m s/rad, see ``SERVO_GAIN``).
4. ``simtune tune --only <the truth's parameters> --max-seconds 120`` on reach and push together, in MuJoCo
   and in PyBullet; then ``simtune evaluate`` of the tuned parameters per task.

"Within 2x the injected noise" means: per task, the tuned fitness (mean wrist distance [m], plus the
box's final-position error on the push) <= 2 x the noise floor of step 3.  PyBullet is tuned towards
MuJoCo's recordings, so its fit also has to bridge the gap between the two engines.

    python benchmarks/panda_recovery.py [--max-seconds 120] [--servo-gain 300] [--out DIR]
        [--results benchmarks/results]

Writes ``panda-recovery-<date>.md`` (the table) and ``.json`` to --results; prints the table.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

import pybullet_data
from common import add_results_option, last_json, make_parser, simtune, write_json_result, write_result

PANDA = Path(pybullet_data.getDataPath()) / "franka_panda" / "panda.urdf"
TASKS = ("reach", "push")
TRUTH = {
    "command_delay": 1.0,  # [s] generic 0
    "max_velocity_joint_2": 22.0,  # [deg/s] generic: the task's 30
    "mass_cube_plastic": 0.085,  # [kg] generic: the task's 0.07
    "lateral_friction_plastic": 0.4,  # generic: the engine's own (MuJoCo 1)
}
ENGINES = ("mujoco", "pybullet")
#: The project's servo gain [N m s/rad]: with MuJoCo's default (50, set for the MICO's light links) the
#: Panda's heavy shoulder joints lag their commands by about 50 ms, which PyBullet's constraint motors
#: cannot; 300 lets MuJoCo's servo follow as a real arm's velocity loop does (docs/task-files.md).
SERVO_GAIN = 300.0
NOISE_MM = 2.0

#: The push: start above and behind the box, come down, push along +x at constant height, lift.  The
#: joint targets were found with least squares on the Panda's own forward kinematics (the hand pointing
#: down, at x = 0.35 m, z = 0.30 m; then z = 0.14 m at x = 0.35, 0.45, 0.55, 0.62 m; then z = 0.30 m).
PUSH_TASK = """\
name = "push"
description = "the hand comes down behind a 6 cm plastic box and pushes it along +x"
duration = 13.0
joints = {joints}
start_pose_deg = [-6.9, -21.9, 7.7, -163.4, 4.7, 141.6, 86.6]

[controller]
law = "clamped-p-velocity"
gain = 10.0
max_velocity_deg = 30.0

[mocap]
link = "panda_hand"
body = "hand"

[object]
shape = "cube"
material = "plastic"
mass = 0.07
size = [0.06, 0.06, 0.06]
xy = [0.47, 0.0]
mocap_body = "box"

[[phases]]
start = 0.0
targets_deg = [-0.2, 12.5, 0.2, -162.9, 0.1, 175.4, 89.9]

[[phases]]
start = 3.0
targets_deg = [-0.1, 20.7, 0.0, -145.3, 0.0, 166.0, 90.0]

[[phases]]
start = 5.0
targets_deg = [0.0, 30.2, 0.0, -125.8, 0.0, 156.1, 90.0]

[[phases]]
start = 7.0
targets_deg = [0.0, 38.1, 0.0, -110.2, 0.0, 148.4, 90.0]

[[phases]]
start = 9.5
targets_deg = [-0.1, 20.8, 0.1, -110.6, 0.0, 131.4, 90.0]
"""


def make_project(folder: Path, servo_gain: float | None) -> Path:
    project = folder / "panda"
    simtune("init", "--robot", PANDA, "--out", project)
    joints = json.dumps([f"panda_joint{i}" for i in range(1, 8)])
    (project / "tasks" / "push.toml").write_text(PUSH_TASK.format(joints=joints))
    file = project / "simtune.toml"
    text = file.read_text()
    text = text.replace('tasks = ["tasks/reach.toml"]', 'tasks = ["tasks/reach.toml", "tasks/push.toml"]')
    if servo_gain is not None:
        text = text.replace("[robot]\n", f"[robot]\nservo_gain = {servo_gain:g}\n")
    file.write_text(text)
    return project


def fitness_per_task(project: Path, engine: str, data: Path, params: Path) -> dict[str, float]:
    out = {}
    for task in TASKS:
        args = ("--project", project, "--engine", engine, "--task", task, "--data", data, "--params-file", params)
        out[task] = float(last_json(simtune("evaluate", *args, "--json"))["fitness"])
    return out


def main() -> None:
    parser = make_parser(__doc__)
    parser.add_argument("--max-seconds", type=float, default=120.0, help="time budget of each tune [s]")
    parser.add_argument("--out", type=Path, help="working folder (default: a temporary one)")
    add_results_option(parser)
    parser.add_argument(
        "--servo-gain",
        type=float,
        default=SERVO_GAIN,
        help="the project's [robot] servo_gain [N m s/rad]; 0: the engines' own (MuJoCo 50)",
    )
    args = parser.parse_args()
    if not PANDA.is_file():
        sys.exit(f"no Franka Panda URDF at {PANDA}")
    with tempfile.TemporaryDirectory() as tmp:
        work = args.out or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        project = make_project(work, args.servo_gain or None)
        contact = last_json(
            simtune("tasks", "--contact", "--project", project, "--engine", "mujoco", "--task", "push", "--json")
        )
        print("contact (mujoco, generic):", json.dumps(contact))

        truth_file = work / "truth-input.json"
        truth_file.write_text(json.dumps(TRUTH))
        data = work / "recordings"
        simtune("synth", "--project", project, "--engine", "mujoco", "--task", ",".join(TASKS), "--truth", truth_file,
                "--noise-mm", NOISE_MM, "--out", data)  # fmt: skip
        floor = fitness_per_task(project, "mujoco", data, data / "truth.json")

        rows = []
        for engine in ENGINES:
            run = work / f"tune-{engine}"
            started = time.monotonic()
            simtune("tune", "--project", project, "--engine", engine, "--task", ",".join(TASKS), "--data", data,
                    "--only", ",".join(TRUTH), "--max-seconds", args.max_seconds, "--out", run, "--quiet",
                    "--optimizer", "de", "--json")  # fmt: skip
            wall = time.monotonic() - started
            best_file = run / "best_params.json"
            tuned = fitness_per_task(project, engine, data, best_file)
            # the truth's values in this engine (its other parameters generic): what tuning starts to beat
            truth_here = fitness_per_task(project, engine, data, truth_file)
            best = json.loads(best_file.read_text())
            values = best.get("params", best)
            rows.append(
                {
                    "engine": engine,
                    "wall_s": round(wall, 1),
                    "tuned": tuned,
                    "truth_here": truth_here,
                    "ratio": {t: tuned[t] / floor[t] for t in TASKS},
                    "within_2x": all(tuned[t] <= 2 * floor[t] for t in TASKS),
                    # tuned together, each task's recordings get their own command delay (command_delay_<task>)
                    "params": {k: values.get(k, _task_values(values, k)) for k in TRUTH},
                }
            )

    lines = [
        f"Franka Panda (pybullet_data URDF), servo gain {args.servo_gain or 'MuJoCo default 50':} N m s/rad, "
        f"synthetic MuJoCo recordings: noise {NOISE_MM:g} mm, truth "
        + ", ".join(f"{k}={v:g}" for k, v in TRUTH.items()),
        "",
        "| engine | task | noise floor (truth) [m] | truth here [m] | tuned [m] | tuned / floor | within 2x |",
        "|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        for t in TASKS:
            ratio = row["ratio"][t]
            lines.append(
                f"| {row['engine']} | {t} | {floor[t]:.4f} | {row['truth_here'][t]:.4f} | {row['tuned'][t]:.4f} | "
                f"{ratio:.2f} | "
                f"{'yes' if ratio <= 2 else 'no'} |"
            )
    lines += ["", "| engine | tune wall [s] | " + " | ".join(TRUTH) + " |", "|---|---|" + "---|" * len(TRUTH)]
    lines.append("| truth | - | " + " | ".join(f"{v:g}" for v in TRUTH.values()) + " |")
    for row in rows:
        shown = [_shown(v) for v in row["params"].values()]
        lines.append(f"| {row['engine']} | {row['wall_s']:g} | " + " | ".join(shown) + " |")
    table = "\n".join(lines)
    print(table)
    write_result(args.results, "panda-recovery", "md", table + "\n")
    summary = {"truth": TRUTH, "noise_mm": NOISE_MM, "floor": floor, "contact": contact, "engines": rows}
    write_json_result(args.results, "panda-recovery", summary)


def _task_values(values: dict, name: str) -> dict[str, float] | None:
    """A per-task parameter's values (``<name>_<task>`` -> task: value), or None if there are none."""
    found = {t: values[f"{name}_{t}"] for t in TASKS if f"{name}_{t}" in values}
    return found or None


def _shown(value) -> str:
    if isinstance(value, dict):
        return ", ".join(f"{t} {v:.3g}" for t, v in value.items())
    return f"{value:.3g}" if isinstance(value, int | float) else "-"


if __name__ == "__main__":
    main()
