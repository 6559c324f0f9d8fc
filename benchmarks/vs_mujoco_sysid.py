"""simtune against mujoco.sysid (MuJoCo 4.0's system identification), the same problems, one run, one table.

Needs the benchmark extra: ``pip install -e '.[sysid]'`` (``mujoco[sysid]``, the version simtune installs).

Problem A (mujoco.sysid's ground): synthetic recordings with a known truth.  ``simtune synth`` (MuJoCo) runs an
arm's task with a true command delay and the damping of two joints and the masses of two links (the MICO's
``double``; the Panda's ``reach`` from ``simtune init``: three joints' damping, as ``simtune synth --project``
refuses a Panda truth with link masses), and writes five repeats of the tracked link's marker (2 mm noise) and the
joint angles (0.05 deg noise).  Both tools fit the same
recordings (their 20 Hz average, as simtune reads them), from the same start (the generic values, delay 0) within
the same bounds (simtune's ranges):

- simtune: ``simtune tune --only <the five> --max-seconds S`` (its default ``auto``), closing its own 20 Hz
  controller (clamped P on the joint targets -> joint velocity servos) from the task's target schedule;
- mujoco.sysid: the same scene's MJCF (``simtune export`` of the generic model) with a site at the marker and
  jointpos/framepos sensors, fed the velocity commands the truth's controller actually sent (replayed open loop
  through the same velocity servos, ``ctrl`` at every physics step), as a lab would log them: stamped on the
  controller's clock, so the command delay is the lag of the recordings behind the log, which mujoco.sysid
  identifies with its per-sensor delay transform (``SignalTransform.delay``) on every sensor.  Damping and masses
  are MJCF attributes set by ``Parameter`` modifiers (mass with the inertia scaled alike, as simtune's engine
  does); ``optimize(..., optimizer="mujoco")``, its finite-difference Jacobian one batched ``mujoco.rollout``.

Problem B (simtune's ground): the real ``single`` recordings (qrg2019, wrist marker only, no joint or command
log).  Tuned: the command delay, the marker's offset in the hand frame (a site's ``pos`` for mujoco.sysid, a
``framepos`` sensor, its delay transform) and joint 2's velocity clamp.  No command was logged, so mujoco.sysid
gets simtune's controller as a ``custom_rollout`` (its documented hook): the 20 Hz clamped-P loop closed around
batched ``mujoco.rollout`` calls of one control period each, the clamp read from the candidate's parameters.

mujoco.sysid runs twice: as it comes (simtune's start, its default finite-difference step) and adjusted as its
pitfalls ask (``move_off_bounds()``, which its own warning advises for a start on a bound, and a step of 1e-6: MuJoCo
compiles a site within about 1e-7 m of its body's origin as the body's own frame, so the default step of 1.5e-8 on
a marker offset starting at 0 gives an exactly zero Jacobian column).

Per tool: wall time, rollouts (simulations of a whole recording; mujoco.sysid: compiled candidate models, each
one rollout per sequence), the final error in simtune's fitness (``simtune evaluate``) and in mujoco.sysid's
cost (1/2 |r|^2 of its normalised residual), and on A the parameter error against the truth (per parameter, as a
fraction of its range) and whether each 95 % interval (``simtune uncertainty``; ``calculate_intervals``) holds
the truth.  Both tools get 2 cores (simtune ``--workers 2``, mujoco.sysid ``n_threads=2``) and alternate.

    python benchmarks/vs_mujoco_sysid.py [--max-seconds 90] [--max-iters 60] [--problems mico,drive,panda,single]
        [--quick] [--out DIR] [--simtune-src /tmp/before/src] [--results benchmarks/results]

Writes ``vs-mujoco-sysid-<date>.md`` and ``.json`` to --results (not with --quick); prints the table.
"""

from __future__ import annotations

import compileall
import io
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np
from common import QRG2019_DATA, add_results_option, last_json, make_parser, write_json_result, write_result

import simtune
import simtune.api as st
from simtune.params import get_space  # simtune.api re-exports it since the refactor; /tmp/before's does not

try:
    from mujoco import sysid
    from mujoco.sysid import Parameter, ParameterDict, SignalTransform, TimeSeries
except ImportError:  # pragma: no cover - depends on the install
    sysid = None

CONTROL_PERIOD = 0.05  # simtune's controller runs at 20 Hz
THREADS = 2
NOISE_MM = 2.0
JOINT_NOISE_DEG = 0.05
REPEATS = 5
#: a whole number of control periods and physics steps whose remainder by 0.05 s is exactly 0 in floating point
#: (0.5 % 0.05 is 0.04999...: simtune's controller would then update a step before each sample), so the truth's
#: controller updates at the samples and the logged commands shift exactly
DELAY_S = 0.4
#: mujoco.sysid's finite-difference step in its adjusted run (its default: 1.5e-8, relative above 1)
ADJUSTED_EPS = 1e-6


@dataclass
class Problem:
    key: str
    task: str
    robot_label: str
    params: list[str]  # simtune names, tuned by both
    truth: dict[str, float] = field(default_factory=dict)  # A only
    synthetic: bool = True
    project: Path | None = None
    space: str = "calibrated"  # simtune's space holding the parameters (the MICO's drive train: drivetrain)
    notes: list[str] = field(default_factory=list)


def simtune_cmd(args: list[object], src: str | None) -> str:
    """One simtune command through its CLI; its standard output (stops the benchmark on failure)."""
    env = dict(os.environ)
    if src:
        env["PYTHONPATH"] = src + os.pathsep + env.get("PYTHONPATH", "")
    command = [sys.executable, "-c", "from simtune.cli import main; main()", *map(str, args)]
    result = subprocess.run(command, check=False, capture_output=True, text=True, env=env)
    if result.returncode != 0:
        sys.exit(f"failed: simtune {' '.join(map(str, args))}\n{result.stdout[-2000:]}\n{result.stderr[-4000:]}")
    return result.stdout


def project_args(p: Problem) -> list[object]:
    return ["--project", p.project] if p.project is not None else []


# --- the model mujoco.sysid identifies ---------------------------------------------------------------------------


def generic_scene(p: Problem, data: Path, work: Path, src: str | None) -> Path:
    """The task's generic MuJoCo scene as simtune builds it: ``simtune export`` of a two-evaluation run that tunes
    the command delay alone (a controller setting, not in the MJCF)."""
    run = work / f"generic-{p.key}"
    simtune_cmd(
        [
            "tune",
            *project_args(p),
            "--engine",
            "mujoco",
            "--task",
            p.task,
            "--data",
            data,
            "--only",
            "command_delay",
            "--optimizer",
            "random",
            "--max-evaluations",
            2,
            "--out",
            run,
            "--quiet",
            "--json",
        ],
        src,
    )
    out = work / f"export-{p.key}"
    simtune_cmd(["export", run, "--out", out, "--force"], src)
    return out / f"scene_{p.task}.xml"


def make_spec(scene: Path, task, joint_sensors: bool) -> mujoco.MjSpec:
    """The exported scene with a site at the marker on the tracked link, a framepos sensor on it and (A) a
    jointpos sensor per driven joint."""
    spec = mujoco.MjSpec.from_file(str(scene))
    body = spec.body(task.robot.tracked_link)
    body.add_site(name="marker", pos=[0.0, 0.0, 0.0])
    spec.add_sensor(
        name="marker", type=mujoco.mjtSensor.mjSENS_FRAMEPOS, objtype=mujoco.mjtObj.mjOBJ_SITE, objname="marker"
    )
    if joint_sensors:
        for j in task.robot.arm_joints:
            spec.add_sensor(
                name=f"q_{j}", type=mujoco.mjtSensor.mjSENS_JOINTPOS, objtype=mujoco.mjtObj.mjOBJ_JOINT, objname=j
            )
    return spec


def sysid_parameters(p: Problem, task, spec: mujoco.MjSpec, bounds: dict) -> ParameterDict:
    """Each simtune parameter as a mujoco.sysid Parameter with simtune's range and its generic value as start."""
    model = spec.compile()
    joints, links = task.robot.arm_joints, task.robot.driven_links
    params = ParameterDict()
    for name in p.params:
        lo, hi = bounds[name]
        modifier, start = None, 0.0
        if name.startswith("joint_damping_"):
            joint = joints[int(name.rsplit("_", 1)[1]) - 1]
            start = float(model.dof_damping[model.jnt_dofadr[model.joint(joint).id]])

            def modifier(s, par, joint=joint):
                s.joint(joint).damping = [float(par.value[0]), 0.0, 0.0]

        elif name.startswith(("armature_joint_", "friction_joint_")):
            joint = joints[int(name.rsplit("_", 1)[1]) - 1]
            field_name = "armature" if name.startswith("armature") else "frictionloss"
            dof = model.jnt_dofadr[model.joint(joint).id]
            start = float((model.dof_armature if field_name == "armature" else model.dof_frictionloss)[dof])

            def modifier(s, par, joint=joint, field_name=field_name):
                setattr(s.joint(joint), field_name, float(par.value[0]))  # MjsJoint.armature / .frictionloss

        elif name.startswith("mass_link_"):
            link = links[int(name.rsplit("_", 1)[1]) - 1]
            b = model.body(link).id
            m0, i0 = float(model.body_mass[b]), model.body_inertia[b].copy()
            start = m0

            def modifier(s, par, link=link, m0=m0, i0=i0):
                body = s.body(link)
                body.mass = float(par.value[0])
                body.inertia = i0 * (float(par.value[0]) / m0)  # as simtune's engine: inertia scaled with mass

        elif name.startswith("marker_offset_"):
            axis = "xyz".index(name[-1])

            def modifier(s, par, axis=axis):
                pos = np.array(s.site("marker").pos, dtype=float)
                pos[axis] = float(par.value[0])
                s.site("marker").pos = pos

        elif name.startswith("max_velocity_joint_"):
            start = float(task.max_velocity_deg)  # read by the closed-loop rollout, not the model
        elif name != "command_delay":
            raise ValueError(f"no mujoco.sysid mapping for {name}")
        params.add(Parameter(name, float(np.clip(start, lo, hi)), lo, hi, modifier=modifier))
    return params


# --- simtune's 20 Hz controller around mujoco.rollout --------------------------------------------------------------


def closed_loop(models, datas, task, v_max_deg, duration: float):
    """Run simtune's controller (velocity = clamp(kp (target - angle), +-v_max) at 20 Hz, held between updates;
    no command delay) on each model from the task's start pose at rest: one batched ``mujoco.rollout`` call per
    control period.  Returns time (n,), state (b, n, nstate), sensordata (b, n, nsens), ctrl (b, n, nu) per step
    (state and sensors after each step, ctrl during it)."""
    m0 = models[0]
    dt = m0.opt.timestep
    per = int(round(CONTROL_PERIOD / dt))
    samples = int(round(duration / CONTROL_PERIOD))
    qadr = np.array([m0.jnt_qposadr[m0.joint(j).id] for j in task.robot.arm_joints])
    starts, table = task.schedule
    kp = float(task.kp)
    v_max = np.radians(np.asarray(v_max_deg, dtype=float)).reshape(len(models), -1)
    state0 = sysid.create_initial_state(m0, start_qpos(m0, task))
    state = np.tile(state0, (len(models), 1))
    states, sensors, ctrls = [], [], []
    for k in range(samples):
        target = np.radians(table[np.searchsorted(starts, k * CONTROL_PERIOD + 1e-12, side="right")])
        q = state[:, 1 + qadr]  # mjSTATE_FULLPHYSICS: time, then qpos
        u = np.clip(kp * (target - q), -v_max, v_max)
        control = np.repeat(u[:, None, :], per, axis=1)
        s, d = mujoco.rollout.rollout(list(models), datas, state, control)
        states.append(s)
        sensors.append(d)
        ctrls.append(control)
        state = s[:, -1]
    state = np.concatenate(states, axis=1)
    return state[0, :, 0], state, np.concatenate(sensors, axis=1), np.concatenate(ctrls, axis=1)


def start_qpos(model, task) -> np.ndarray:
    qpos = model.qpos0.copy()
    for j, a in zip(task.robot.arm_joints, task.start_pose_deg, strict=True):
        qpos[model.jnt_qposadr[model.joint(j).id]] = np.radians(a)
    return qpos


def closed_loop_rollout_fn(task, pad_s: float):
    """mujoco.sysid's ``custom_rollout``: simtune's controller closed around the candidates' models, the velocity
    clamps from each candidate's parameters; as long as the control series it is given."""
    n = task.robot.n_joints

    def rollout(
        *,
        models,
        datas,
        control_signal,
        initial_states,
        param_dicts,
        rollout_signal_mapping,
        rollout_state_mapping,
        ctrl_mapping,
    ):
        del initial_states
        v = [
            [
                pd[f"max_velocity_joint_{i}"].value[0] if f"max_velocity_joint_{i}" in pd else task.max_velocity_deg
                for i in range(1, n + 1)
            ]
            for pd in param_dicts
        ]
        # the candidates come in the order [column 0 x sequences, column 1 x sequences, ...]; one sequence here
        duration = control_signal[0].times[-1]
        times, state, sens, ctrl = closed_loop(models, datas, task, v, duration)
        out = []
        for i, model in enumerate(models):
            out.append(
                sysid.SystemTrajectory(
                    model=model,
                    control=TimeSeries(times, ctrl[i], ctrl_mapping),
                    sensordata=TimeSeries(times, sens[i], rollout_signal_mapping),
                    initial_state=state[i, 0],
                    state=TimeSeries(times, state[i], rollout_state_mapping),
                )
            )
        return out

    return rollout


# --- one problem, both tools ---------------------------------------------------------------------------------------


def measured_series(model, refs, task, joint_sensors: bool) -> TimeSeries:
    """The recordings simtune fits (the repeats' 20 Hz average) as mujoco.sysid's measured sensordata."""
    mapping = TimeSeries.compute_all_sensor_mapping(model)
    data = np.zeros((len(refs.times), model.nsensordata))
    data[:, mapping["marker"][1]] = refs.wrist_mean
    if joint_sensors:
        for j in task.robot.arm_joints:
            data[:, mapping[f"q_{j}"][1][0]] = refs.joint_mean[:, refs.joint_names.index(j)]
    keep = np.all(np.isfinite(data), axis=1)
    return TimeSeries(np.asarray(refs.times, dtype=float)[keep], data[keep], mapping)


def run_problem(p: Problem, args, work: Path) -> dict:
    src = args.simtune_src
    project = st.load_project(p.project) if p.project is not None else st.load_project()
    task = project.tasks[p.task]
    space = get_space(p.space, only=p.params, robot=task.robot)
    bounds = dict(zip(space.names, space.bounds, strict=True))
    log = {"problem": p.key, "task": p.task, "robot": p.robot_label, "params": p.params, "truth": p.truth}

    # the recordings
    if p.synthetic:
        data = work / f"data-{p.key}"
        truth_file = work / f"truth-{p.key}.json"
        truth_file.write_text(json.dumps(p.truth))
        simtune_cmd(
            [
                "synth",
                *project_args(p),
                "--engine",
                "mujoco",
                "--task",
                p.task,
                "--truth",
                truth_file,
                "--noise-mm",
                NOISE_MM,
                "--joint-noise-deg",
                JOINT_NOISE_DEG,
                "--jitter-s",
                0,
                "--repeats",
                REPEATS,
                "--format",
                "csv",
                "--out",
                data,
            ],
            src,
        )
        clean = work / f"clean-{p.key}"
        simtune_cmd(
            [
                "synth",
                *project_args(p),
                "--engine",
                "mujoco",
                "--task",
                p.task,
                "--truth",
                truth_file,
                "--noise-mm",
                0,
                "--joint-noise-deg",
                0,
                "--jitter-s",
                0,
                "--repeats",
                1,
                "--format",
                "csv",
                "--out",
                clean,
            ],
            src,
        )
    else:
        data = args.data
    refs = st.load_references(data, [task])[task.name]
    scene = generic_scene(p, data, work, src)
    joint_sensors = p.synthetic
    spec = make_spec(scene, task, joint_sensors)
    params = sysid_parameters(p, task, spec, bounds)
    model = spec.compile()
    dt = model.opt.timestep
    measured = measured_series(model, refs, task, joint_sensors)
    pad = bounds["command_delay"][1]  # mujoco.sysid windows its data by the delay bound: simulate past the end
    duration = task.duration + pad
    n_steps = int(round(duration / dt))
    ctrl_times = np.arange(n_steps + 1) * dt

    if p.synthetic:
        # the commands the truth's controller sent, on its own clock: its closed loop without the delay (the arm
        # rests at its start pose until the schedule starts, so the delayed run sends the same, d seconds later)
        truth_params = params.copy()
        for name, value in p.truth.items():
            if name in truth_params:
                truth_params[name].update_from_vector(np.array([value]))
        truth_model = sysid.apply_param_modifiers(truth_params, spec.copy())
        n = task.robot.n_joints
        v = [float(p.truth.get(f"max_velocity_joint_{i}", task.max_velocity_deg)) for i in range(1, n + 1)]
        _, _, _, ctrl = closed_loop([truth_model], [mujoco.MjData(truth_model)], task, [v], duration)
        ctrl_log = np.vstack([ctrl[0], ctrl[0][-1:]])
        # check: the logged commands replayed open loop in the truth's MJCF, delayed, against simtune's noise-free
        # synth of the truth (the same physics, or the comparison would be unfair to mujoco.sysid)
        clean_refs = st.load_references(clean, [task])[task.name]
        state, sd = mujoco.rollout.rollout(
            truth_model,
            mujoco.MjData(truth_model),
            sysid.create_initial_state(truth_model, start_qpos(truth_model, task)),
            ctrl_log[:-1],
        )
        t_sim = state[0, :, 0] + p.truth["command_delay"]
        idx = model.sensor("marker").adr[0]
        replayed = np.stack([np.interp(clean_refs.times, t_sim, sd[0, :, idx + a], left=np.nan) for a in range(3)], 1)
        err = np.abs(replayed - clean_refs.wrist_mean)
        log["replay_check_m"] = float(np.nanmax(err))
        print(
            f"[{p.key}] logged commands replayed in mujoco.sysid's model vs simtune's noise-free truth: "
            f"max marker difference {log['replay_check_m'] * 1000:.3f} mm"
        )
        control = TimeSeries(ctrl_times, ctrl_log, TimeSeries.compute_all_control_mapping(model))
        custom = None
    else:
        unused = np.zeros((n_steps + 1, model.nu))  # its length sets the rollout's; the controller sets ctrl
        control = TimeSeries(ctrl_times, unused, TimeSeries.compute_all_control_mapping(model))
        custom = closed_loop_rollout_fn(task, pad)

    initial = sysid.create_initial_state(model, start_qpos(model, task))
    sequences = sysid.ModelSequences(p.key, spec, p.task, initial, control, measured)
    transform = SignalTransform()
    transform.delay("*", params["command_delay"])
    # every sensor (without a selection its residual's signal mappings are compared as arrays, and fail)
    transform.enable_sensors([model.sensor(i).name for i in range(model.nsensor)])
    built = {"n": 0}

    def build_model(pd, s):
        built["n"] += 1
        return sysid.apply_param_modifiers(pd, s)

    residual_fn = sysid.build_residual_fn(
        models_sequences=[sequences],
        build_model=build_model,
        modify_residual=transform.apply,
        custom_rollout=custom,
        n_threads=THREADS,
        resample_true=False,
    )

    def sysid_cost(values: dict[str, float]) -> float:
        x = np.array([values[n] for n in params.keys()], dtype=float)  # noqa: SIM118 (a ParameterDict)
        r = np.concatenate(residual_fn(x, params.copy())[0])
        return 0.5 * float(r @ r)

    # --- the two tools, alternating: mujoco.sysid first, then simtune
    results = {}
    # mujoco.sysid as it comes, from simtune's start; then adjusted as its pitfalls ask: the start moved off the
    # bounds (its own warning's advice) and a finite-difference step of 1e-6 instead of 1.5e-8, since MuJoCo's
    # compiler treats a site within about 1e-7 m of its body's origin as the body's own frame ("sameframe"), so a
    # marker offset starting at 0 gets an exactly zero Jacobian column with the default step
    variants = {
        "mujoco.sysid": (params, {}),
        "mujoco.sysid, adjusted": (params.copy().move_off_bounds(), {"eps": ADJUSTED_EPS}),
    }
    if args.quick:  # the smoke run: mujoco.sysid as it comes only
        variants.pop("mujoco.sysid, adjusted")
    for tool, (start, options) in variants.items():
        built["n"] = 0
        started = time.monotonic()
        printed = io.StringIO()
        opt_params, opt = sysid.optimize(
            start.copy(),
            residual_fn,
            optimizer="mujoco",
            verbose=False,
            max_iters=args.max_iters,
            output=printed,
            **options,
        )
        wall = time.monotonic() - started
        rollouts = built["n"]
        x_sysid = dict(zip(opt_params.keys(), map(float, opt_params.as_vector()), strict=True))
        res_star = residual_fn(opt_params.as_vector(), opt_params.copy())[0]
        _, half = sysid.calculate_intervals(res_star, np.asarray(opt.jac))
        results[tool] = {
            "wall_s": wall,
            "rollouts": rollouts,
            "x": x_sysid,
            "start": dict(zip(start.keys(), map(float, start.as_vector()), strict=True)),
            "intervals": {n: (x_sysid[n] - h, x_sysid[n] + h) for n, h in zip(opt_params.keys(), half, strict=True)},
            "stopped": next((line for line in printed.getvalue().splitlines() if line.startswith("Terminated")), ""),
        }

    run = work / f"tune-{p.key}"
    started = time.monotonic()
    out = last_json(
        simtune_cmd(
            [
                "tune",
                *project_args(p),
                "--engine",
                "mujoco",
                "--task",
                p.task,
                "--data",
                data,
                "--only",
                ",".join(p.params),
                "--space",
                p.space,
                "--max-seconds",
                args.max_seconds,
                "--workers",
                THREADS,
                "--seed",
                0,
                "--out",
                run,
                "--quiet",
                "--json",
            ],
            src,
        )
    )
    wall = time.monotonic() - started
    best = json.loads((run / "best_params.json").read_text())
    x_simtune = {n: float(best.get("params", best)[n]) for n in p.params}
    unc = last_json(simtune_cmd(["uncertainty", run, "--json"], src))
    results["simtune"] = {
        "wall_s": wall,
        "rollouts": int(out.get("evaluations", 0)),
        "x": x_simtune,
        "intervals": simtune_intervals(unc, p.params),
        "optimizer_wall_s": out.get("wall_s"),
    }

    if p.synthetic:
        # mujoco.sysid's cost along the delay alone, the other parameters at the start: one batched residual call
        delays = np.round(np.arange(0.0, p.truth["command_delay"] + 0.1, 0.0125), 4)
        x0 = params.as_vector()
        k = params.keys().index("command_delay")
        xs = np.repeat(x0[:, None], len(delays), axis=1)
        xs[k] = delays
        costs = 0.5 * np.sum(residual_fn(xs, params.copy())[0][0] ** 2, axis=0)
        minima = [float(delays[i]) for i in range(len(delays)) if _local_min(costs, i)]
        log["delay_profile"] = {"delays": delays.tolist(), "costs": costs.tolist(), "local_minima": minima}

    # --- both errors for both results (and the truth, on A)
    points = {tool: r["x"] for tool, r in results.items()}
    if p.synthetic:
        points["truth"] = {n: p.truth[n] for n in p.params}
    points["start"] = dict(zip(params.keys(), map(float, params.as_vector()), strict=True))
    scores = {}
    for label, x in points.items():
        file = work / f"x-{p.key}-{label}.json"
        # within simtune's ranges: a value mujoco.sysid leaves on a bound can lie an ulp outside it (and a range
        # computed in another process from the robot's inertias can differ in its last digits): a hair inside
        file.write_text(json.dumps({k: _inside(v, *bounds[k]) if k in bounds else v for k, v in x.items()}))
        fit = last_json(
            simtune_cmd(
                [
                    "evaluate",
                    *project_args(p),
                    "--engine",
                    "mujoco",
                    "--task",
                    p.task,
                    "--data",
                    data,
                    "--params-file",
                    file,
                    "--json",
                ],
                src,
            )
        )["fitness"]
        scores[label] = {"simtune_fitness": float(fit), "sysid_cost": sysid_cost(x)}
    for tool, r in results.items():
        r.update(scores[tool])
        if p.synthetic:
            r["param_error"] = {n: abs(r["x"][n] - p.truth[n]) / (bounds[n][1] - bounds[n][0]) for n in p.params}
            r["covered"] = {
                n: bool(
                    r["intervals"].get(n) is not None and r["intervals"][n][0] <= p.truth[n] <= r["intervals"][n][1]
                )
                for n in p.params
            }
    log.update({"bounds": bounds, "results": results, "scores": scores, "notes": p.notes, "start_x": points["start"]})
    return log


def _local_min(values: np.ndarray, i: int) -> bool:
    left = values[i - 1] if i > 0 else np.inf
    right = values[i + 1] if i + 1 < len(values) else np.inf
    return bool(values[i] < left and values[i] < right)


def simtune_intervals(unc: dict, names: list[str]) -> dict:
    """The 95 % intervals of ``simtune uncertainty --json`` by parameter (None where unbounded)."""
    rows = unc.get("parameters", unc.get("intervals", unc))
    found = {}
    if isinstance(rows, dict):
        rows = [dict(v, name=k) if isinstance(v, dict) else {"name": k, "value": v} for k, v in rows.items()]
    for row in rows if isinstance(rows, list) else []:
        name = row.get("name") or row.get("parameter")
        if name not in names:
            continue
        lo, hi = row.get("low", row.get("lo")), row.get("high", row.get("hi"))
        if lo is None and "interval" in row and row["interval"]:
            lo, hi = row["interval"]
        found[name] = (float(lo), float(hi)) if lo is not None and hi is not None else None
    return found


# --- the table -----------------------------------------------------------------------------------------------------


def table(logs: list[dict]) -> str:
    lines = [
        "| problem | tool | how it saw the controller | wall [s] | rollouts | simtune fitness [m(+rad)] | "
        "mujoco.sysid cost | mean / max param error [% of range] | truth in 95 % interval | "
        "95 % interval width, median [% of range] |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for log in logs:
        synthetic = bool(log["truth"])
        for tool, r in log["results"].items():
            how = (
                "closes its 20 Hz clamped-P loop on the target schedule"
                if tool == "simtune"
                else (
                    "replays the truth controller's logged velocity commands (open loop)"
                    if synthetic
                    else "custom_rollout: simtune's 20 Hz loop closed around mujoco.rollout"
                )
            )
            if synthetic:
                errs = list(r["param_error"].values())
                perr = f"{100 * np.mean(errs):.1f} / {100 * np.max(errs):.1f}"
                # (a JSON written before the values were plain bools holds them as "True"/"False")
                cov = f"{sum(v in (True, 'True') for v in r['covered'].values())}/{len(r['covered'])}"
                widths = [_width(r["intervals"].get(n), log["bounds"][n]) for n in log["params"]]
                width = f"{100 * float(np.median(widths)):.1f}"
            else:
                perr = cov = width = "-"
            lines.append(
                f"| {log['robot']} {log['task']} | {tool} | {how} | {r['wall_s']:.1f} | {r['rollouts']} | "
                f"{r['simtune_fitness']:.4f} | {r['sysid_cost']:.4g} | {perr} | {cov} | {width} |"
            )
        s = log["results"]["simtune"]
        ref = log["scores"].get("truth")
        ref_txt = (
            f"; the truth itself: fitness {ref['simtune_fitness']:.4f}, cost {ref['sysid_cost']:.4g}" if ref else ""
        )
        st_ = log["scores"]["start"]
        for tool, m in log["results"].items():
            if tool == "simtune":
                continue
            lines.append(
                f"| {log['robot']} {log['task']} | simtune / {tool} | - | {s['wall_s'] / m['wall_s']:.2f} | "
                f"{s['rollouts'] / max(m['rollouts'], 1):.2f} | {s['simtune_fitness'] / m['simtune_fitness']:.2f} | "
                f"{s['sysid_cost'] / m['sysid_cost']:.2f} | - | - | - |"
            )
        log["ratio_note"] = f"start: fitness {st_['simtune_fitness']:.4f}, cost {st_['sysid_cost']:.4g}{ref_txt}"
    lines.append("")
    for log in logs:
        lines.append(f"- {log['robot']} {log['task']}: {log['ratio_note']}.")
        for tool, r in log["results"].items():
            if r.get("stopped"):
                lines.append(f"  {tool} stopped: {r['stopped']}")
        own = log["results"]["simtune"].get("optimizer_wall_s")
        if own is not None:
            lines.append(
                f"  simtune's own wall_s (its search, in the run's JSON): {own:.1f} s; the rest of its wall time is "
                "the CLI's start, recordings and the activity probe."
            )
        if "delay_profile" in log:
            prof = log["delay_profile"]
            lines.append(
                "  mujoco.sysid's cost along the delay alone (others at the start, 12.5 ms grid from 0): local minima "
                f"at {', '.join(f'{d:g}' for d in prof['local_minima'])} s (truth {log['truth']['command_delay']:g})."
            )
        if "replay_check_m" in log:
            lines.append(
                f"  Logged commands replayed open loop in mujoco.sysid's model at the truth, vs simtune's noise-free "
                f"synth: max marker difference {log['replay_check_m'] * 1000:.3f} mm."
            )
        tools = list(log["results"])
        lines.append("  | parameter | range | truth | start | " + " | ".join(f"{t} | 95 %" for t in tools) + " |")
        lines.append("  |---|---|---:|---:|" + "---:|---|" * len(tools))
        for n in log["params"]:
            lo, hi = log["bounds"][n]
            cells = " | ".join(f"{r['x'][n]:.4g} | {_iv(r['intervals'].get(n))}" for r in log["results"].values())
            lines.append(
                f"  | {n} | [{lo:.4g}, {hi:.4g}] | {log['truth'].get(n, '-') if log['truth'] else '-'} | "
                f"{log['start_x'][n]:.4g} | {cells} |"
            )
        off = log["results"].get("mujoco.sysid, adjusted")
        if off:
            lines.append(
                "  - mujoco.sysid, adjusted: started from `move_off_bounds()` (what its warning advises when a start "
                "sits on a bound: " + ", ".join(f"{n} {v:.4g}" for n, v in off["start"].items()) + f"), finite-"
                f"difference step {ADJUSTED_EPS:g} (MuJoCo treats a site within ~1e-7 m of its body's origin as the "
                "body's frame: with the default 1.5e-8 a marker offset starting at 0 has a zero Jacobian column)."
            )
        for note in log["notes"]:
            lines.append(f"  - {note}")
    return "\n".join(lines)


def _width(iv, bounds) -> float:
    """An interval's width as a fraction of the parameter's range (inf: unbounded)."""
    if iv is None or not np.all(np.isfinite(iv)):
        return float("inf")
    return (iv[1] - iv[0]) / (bounds[1] - bounds[0])


def _inside(value: float, low: float, high: float) -> float:
    """``value`` clipped to a hair inside [low, high] (1e-9 of the range)."""
    hair = 1e-9 * (high - low)
    return float(np.clip(value, low + hair, high - hair))


def _iv(iv) -> str:
    if iv is None:
        return "unbounded"
    return f"[{iv[0]:.4g}, {iv[1]:.4g}]"


NOT_EXPRESSED = (
    "Left out of problems mico and panda (problem drive has armature and frictionloss): the actuator gain "
    "(MuJoCo's velocity servo kv, simtune's servo_gain_joint_<i> since 2026-11-28, in none of these problems yet; "
    "its position controller's kp_joint_<i> is another gain), the controller's velocity clamp on A (mujoco.sysid "
    "replays the commands the clamp already shaped: nothing to identify)."
)


def problems(args, work: Path) -> list[Problem]:
    chosen = args.problems.split(",")
    out = []
    if "mico" in chosen:
        out.append(
            Problem(
                "mico",
                "double",
                "MICO",
                ["command_delay", "joint_damping_2", "joint_damping_5", "mass_link_3", "mass_link_6"],
                truth={
                    "command_delay": DELAY_S,
                    "joint_damping_2": 0.5,
                    "joint_damping_5": 0.3,
                    "mass_link_3": 0.70,
                    "mass_link_6": 0.85,
                },
                notes=[NOT_EXPRESSED],
            )
        )
    if "drive" in chosen:
        out.append(
            Problem(
                "drive",
                "double",
                "MICO",
                ["command_delay", "armature_joint_2", "armature_joint_5", "friction_joint_2", "friction_joint_5"],
                truth={
                    "command_delay": DELAY_S,
                    "armature_joint_2": 0.3,
                    "armature_joint_5": 0.006,
                    "friction_joint_2": 2.0,
                    "friction_joint_5": 1.5,
                },
                space="drivetrain",
                notes=[
                    "The drive train: armature (MJCF `armature`, simtune's `armature_joint_<i>`) and Coulomb joint "
                    "friction (MJCF `frictionloss`, `friction_joint_<i>`) of joints 2 and 5, in the MICO's "
                    "`drivetrain` space; MjsJoint.armature / .frictionloss modifiers for mujoco.sysid.",
                ],
            )
        )
    if "panda" in chosen:
        import pybullet_data

        urdf = Path(pybullet_data.getDataPath()) / "franka_panda" / "panda.urdf"
        project = work / "panda"
        if not (project / "simtune.toml").exists():
            simtune_cmd(["init", "--robot", urdf, "--out", project], args.simtune_src)
        out.append(
            Problem(
                "panda",
                "reach",
                "Panda",
                ["command_delay", "joint_damping_2", "joint_damping_4", "joint_damping_6"],
                truth={
                    "command_delay": DELAY_S,
                    "joint_damping_2": 0.6,
                    "joint_damping_4": 0.3,
                    "joint_damping_6": 0.15,
                },
                project=project,
                notes=[
                    "No link masses on the Panda: when this problem was first measured (2026-11-25) `simtune synth "
                    "--project P --truth T` checked a truth's link masses against the bundled MICO's ranges and "
                    "refused the Panda's (fixed 2026-11-26); the problem keeps the damping of three joints and the "
                    "delay, so that its rows compare across measurements.",
                    NOT_EXPRESSED,
                ],
            )
        )
    if "single" in chosen:
        out.append(
            Problem(
                "single",
                "single",
                "MICO (real)",
                ["command_delay", "marker_offset_x", "marker_offset_y", "marker_offset_z", "max_velocity_joint_2"],
                synthetic=False,
                notes=[
                    "Real recordings: no truth. The marker offset is a site's pos in the hand frame for "
                    "mujoco.sysid, simtune's marker_offset_* (the same quantity); the clamp is read by the "
                    "custom rollout's controller.",
                    "cube (real) not run: mujoco.sysid could hold the object (a free body with a framepos sensor) "
                    "and simtune's controller (custom_rollout), but its contact parameters (friction per geom "
                    "pair, simtune's per-material groups) and its final-position error need a custom residual; "
                    "not built in this session.",
                ],
            )
        )
    return out


def main() -> None:
    parser = make_parser(__doc__)
    parser.add_argument("--max-seconds", type=float, default=90.0, help="simtune's budget per problem [s]")
    parser.add_argument("--max-iters", type=int, default=60, help="mujoco.sysid's iteration limit per problem")
    parser.add_argument(
        "--problems", default="mico,drive,panda,single", help="mico, drive, panda, single (comma-separated)"
    )
    parser.add_argument("--quick", action="store_true", help="smoke run: MICO only, 5 s and 3 iterations")
    parser.add_argument("--data", type=Path, default=QRG2019_DATA, help="the real recordings' root (problem B)")
    parser.add_argument("--out", type=Path, help="working folder (default: a temporary one)")
    parser.add_argument("--simtune-src", help="run simtune's CLI from this src folder (e.g. /tmp/before/src)")
    parser.add_argument("--render", type=Path, help="only print the table of an earlier run's JSON (no measuring)")
    add_results_option(parser)
    args = parser.parse_args()
    if args.render is not None:
        saved = json.loads(args.render.read_text())
        print(saved["head"] + "\n\n" + table(saved["problems"]))
        return
    if sysid is None:
        sys.exit("mujoco.sysid needs its extra: pip install -e '.[sysid]'")
    if args.quick:
        args.problems, args.max_seconds, args.max_iters = "mico", 5.0, 3
    # simtune's modules compiled before any command is timed, as an installed package's are: where the environment
    # says PYTHONDONTWRITEBYTECODE (this project's development host) an editable install is otherwise compiled from
    # source at every command's start (0.17 s on 2 cores), which a user's install does not pay
    compileall.compile_dir(args.simtune_src or Path(simtune.__file__).parent, quiet=1)
    load = {"before": os.getloadavg()}
    with tempfile.TemporaryDirectory() as tmp:
        work = args.out or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        logs = []
        for p in problems(args, work):
            log = run_problem(p, args, work)
            logs.append(log)
            print(table([log]))
    load["after"] = os.getloadavg()
    uptime = subprocess.run(["uptime"], check=False, capture_output=True, text=True).stdout.strip()
    head = (
        f"simtune vs mujoco.sysid (mujoco {mujoco.__version__}), simtune --max-seconds {args.max_seconds:g} "
        f"(auto, --workers {THREADS}), mujoco.sysid optimizer='mujoco' max_iters={args.max_iters} "
        f"(n_threads={THREADS}); simtune {simtune.__version__} from {Path(simtune.__file__).parent}; "
        f"host load before {load['before'][0]:.2f}, after {load['after'][0]:.2f} "
        f"(`uptime`: {uptime})"
    )
    text = head + "\n\n" + table(logs)
    print("\n" + text)
    if not args.quick:
        write_result(args.results, "vs-mujoco-sysid", "md", text + "\n")
        saved = {"head": head, "load": load, "uptime": uptime, "problems": logs}
        write_json_result(args.results, "vs-mujoco-sysid", saved)


if __name__ == "__main__":
    main()
