"""How fast simtune evaluates, against what the engines themselves allow.

    python benchmarks/speed.py [--engines mujoco,pybullet,ode,dart,drake] [--repeats 5] [--evals 1000]
        [--section-seconds 10] [--data ../shared/datasets/qrg2019/mocap] [--target 0.05] [--seeds 3]
        [--skip-target]

Prints, per engine, on the `cube` task at the engine's generic time step:
1. raw engine throughput: physics steps per second and simulated seconds per wall
   second of a bare stepping loop (same scene, the generic evaluation's commands replayed,
   so the same contacts; no state reading, control law, checks or sampling);
2. one full fitness evaluation, and the overhead ratio evaluation time / bare
   stepping time for the same number of steps (target <= 1.15);
3. tuning throughput: evaluations per second with 1 and 2 worker processes on the
   same batch of parameter vectors, and the scaling efficiency (target >= 0.85);
4. pruning: the share of physics steps that stopping hopeless trials saves in a
   short tune (same search, same result);
5. memory: resident memory of a 2-worker tune (main process + workers) after 100
   evaluations, half-way and after --evals evaluations (target: flat; a leak grows in
   both halves, a cache warming up only in the first); these evaluations
   simulate only the first 0.25-2 s of the task (shorter for slower engines):
   engine handles leak per evaluation, not per step;
6. time to target: wall time for `tune --engine mujoco --task cube --space extended`
   to reach fitness --target on the real data, median of --seeds seeds.
Figures are medians over up to --repeats runs with [min, max]: the machine is shared
and noisy. The repeats of 1.-3., the batch sizes of 3. and the generations of 4. are
chosen from the engine's cost of one evaluation so that each takes about
--section-seconds (an engine as slow as Drake gets fewer repeats and smaller batches,
never a different measurement). The last line is the benchmark's own wall time.
"""

from __future__ import annotations

import dataclasses
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
from common import add_data_option, add_engines_option, make_parser

from simtune.engines import engine_class, make_engine
from simtune.objective import Objective, load_references
from simtune.optimize.evaluator import Evaluator
from simtune.params import get_space
from simtune.reference import REFERENCE_DIR
from simtune.runs import RunConfig, start_run
from simtune.store import RunStore
from simtune.tasks import get_task


def stats(values: list[float]) -> str:
    return f"{statistics.median(values):.4g} [{min(values):.4g}, {max(values):.4g}]"


class BareLoop:
    """A bare stepping loop of the cube scene.

    It replays the joint velocity commands and step counts of a generic
    evaluation (recorded once), so the arm pushes the cube through the same
    contacts, and leaves out everything else an evaluation does (reading the
    state, control law, checks, sampling, scoring).
    """

    def __init__(self, engine: str, n_samples: int):
        self.sim = sim = make_engine(engine, get_task("cube"))
        self.commands: list[list] = []  # [velocities, physics steps until the next command]
        set_velocities, step = sim.set_joint_velocities, sim.step
        sim.set_joint_velocities = lambda v: (self.commands.append([np.array(v), 0]), set_velocities(v))[-1]

        def counting_step(n: int) -> None:
            self.commands[-1][1] += n
            step(n)

        sim.step = counting_step
        sim.rollout({}, n_samples)
        sim.set_joint_velocities, sim.step = set_velocities, step
        self.steps = sum(n for _, n in self.commands)

    def run(self) -> float:
        """Seconds for one pass."""
        self.sim.reset({})
        t0 = time.perf_counter()
        for velocities, n in self.commands:
            self.sim.set_joint_velocities(velocities)
            self.sim.step(n)
        return time.perf_counter() - t0


def first_seconds(refs: dict, seconds: float) -> dict:
    """The recordings cut to their first ``seconds`` (the final object position kept)."""
    cut = {}
    for name, ref in refs.items():
        n = int(round(seconds * ref.rate)) + 1
        cut[name] = dataclasses.replace(
            ref, times=ref.times[:n], wrist_mean=ref.wrist_mean[:n], wrist_repeats=ref.wrist_repeats[:, :n]
        )
    return cut


def rss_mb(pid: int) -> float:
    with open(f"/proc/{pid}/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return 0.0


def family_rss_mb() -> float:
    """Resident memory of this process and all its descendants [MB]."""
    total, stack = 0.0, [os.getpid()]
    while stack:
        pid = stack.pop()
        try:
            total += rss_mb(pid)
            with open(f"/proc/{pid}/task/{pid}/children") as fh:
                stack += [int(c) for c in fh.read().split()]
        except OSError:
            continue
    return total


def throughput(objective: Objective, vectors: np.ndarray, workers: int) -> float:
    """Evaluations per second of ``vectors`` with ``workers`` processes (engines built beforehand)."""
    with tempfile.TemporaryDirectory() as tmp:
        store = RunStore(Path(tmp), create=True)
        with Evaluator(objective, store, workers) as evaluator:
            evaluator(None, vectors[: workers * 2])  # warm-up: start workers, build engines
            t0 = time.perf_counter()
            evaluator(None, vectors[workers * 2 :])
            rate = (len(vectors) - workers * 2) / (time.perf_counter() - t0)
        store.close()
    return rate


def main() -> None:
    ap = make_parser(__doc__, whole_doc=True)
    add_engines_option(ap, "mujoco,pybullet,ode,dart,drake")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--evals", type=int, default=1000)
    ap.add_argument(
        "--section-seconds",
        type=float,
        default=10.0,
        help="about how long the throughput and pruning measurements take per engine",
    )
    add_data_option(ap)
    ap.add_argument("--target", type=float, default=0.05)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--skip-target", action="store_true", help="skip the time-to-target runs (minutes)")
    args = ap.parse_args()
    start = time.perf_counter()
    if args.evals < 200 or args.evals % 50:
        ap.error("--evals must be a multiple of 50, at least 200")
    data = args.data if args.data.is_dir() else REFERENCE_DIR
    task = get_task("cube")
    refs = load_references(data, [task])
    print(f"simtune speed benchmark, cube task, data {data}, {os.cpu_count()} cores, {time.strftime('%Y-%m-%d')}")
    for engine in args.engines.split(","):
        engine_start = time.perf_counter()
        objective = Objective(engine, [task], refs)
        objective.score({})  # build the engine
        bare_loop = BareLoop(engine, len(refs[task.name].times))
        t0 = time.perf_counter()
        objective.score({})
        first_eval = time.perf_counter() - t0
        # slow engines get fewer repeats (at least 3), so each engine costs about the same time
        repeats = int(np.clip(args.section_seconds / (2 * first_eval), 3, args.repeats))
        evals, bare = [], []
        for _ in range(repeats):  # interleaved, so a slow spell of the machine hits both alike
            t0 = time.perf_counter()
            score = objective.score({})
            evals.append(time.perf_counter() - t0)
            bare.append(bare_loop.run())
        steps = score.tasks[0].steps
        assert bare_loop.steps == steps, f"bare loop {bare_loop.steps} steps, evaluation {steps}"
        bare_loop.sim.close()
        dt = make_engine(engine, task).timestep
        ratio = [e / b for e, b in zip(evals, bare)]
        print(f"\n== {engine} (generic time step {dt:.4g} s, {steps} steps per evaluation)")
        print(
            f"  1. bare stepping: {stats([steps / b for b in bare])} steps/s, "
            f"{stats([steps * dt / b for b in bare])} simulated s per wall s"
        )
        print(
            f"  2. one evaluation ({repeats} repeats): {stats(evals)} s; overhead ratio {stats(ratio)} (target <= 1.15)"
        )

        space = get_space("extended", engine_class(engine).supported())
        lo, hi = np.array(space.bounds).T
        rng = np.random.default_rng(0)
        per_eval = statistics.median(evals)
        n_vectors = 2 * int(np.clip(args.section_seconds / per_eval / 2, 4, 12))
        vectors = lo + rng.random((n_vectors, len(space))) * (hi - lo)
        vectors[:, space.names.index("timestep")] = dt  # the generic step: comparable to 1. and 2.
        tuned = Objective(engine, [task], refs, space)
        batch_repeats = int(
            np.clip(round(2 * args.section_seconds / (n_vectors * per_eval)), 1, max(1, args.repeats // 2))
        )
        one = [throughput(tuned, vectors, 1) for _ in range(batch_repeats)]
        two = [throughput(tuned, vectors, 2) for _ in range(batch_repeats)]
        eff = [t / (2 * statistics.median(one)) for t in two]
        print(
            f"  3. tuning throughput ({n_vectors} evaluations, the first 2 per worker as warm-up, "
            f"{batch_repeats} repeat(s)): "
            f"{stats(one)} eval/s with 1 worker, {stats(two)} with 2; scaling efficiency {stats(eff)} (target >= 0.85)"
        )

        # a generation is about len(space) evaluations (population 1 x D), on 2 workers
        generation_s = per_eval * len(space) / 2
        generations = int(min(2 * args.section_seconds / generation_s, 8))
        if generations < 2:
            # the first generation's trials face random parents, which hardly any trial
            # provably loses to part-way: one generation would print a meaningless 0 %
            print(
                f"  4. pruning: skipped, a generation takes about {generation_s:.0f} s here "
                f"(--section-seconds {generation_s:.0f} or more measures two)"
            )
        else:
            with tempfile.TemporaryDirectory() as tmp:
                cfg = dict(
                    engine=engine,
                    tasks="cube",
                    space="extended",
                    data=str(REFERENCE_DIR),
                    seed=1,
                    max_generations=generations,
                    workers=2,
                    optimizer="de",
                )
                full = start_run(RunConfig(**cfg, prune=False), Path(tmp) / "full", show_progress=False)
                pruned = start_run(RunConfig(**cfg), Path(tmp) / "pruned", show_progress=False)
                same = "same result" if pruned.fitness == full.fitness else "DIFFERENT RESULT"
                print(
                    f"  4. pruning ({generations} generations, {full.evaluations} evaluations, 2 workers): "
                    f"{pruned.pruned_evaluations} trials stopped early, physics steps {full.steps} -> {pruned.steps} "
                    f"({100 * (1 - pruned.steps / full.steps):.0f} % saved), wall {full.wall_s:.1f} -> "
                    f"{pruned.wall_s:.1f} s, {same}"
                )

        memory = []
        # rollouts short enough that --evals of them on 2 workers take about 2 x --section-seconds
        rollout_s = float(np.clip(4 * args.section_seconds / args.evals / (per_eval / task.duration), 0.25, 2.0))
        short = Objective(engine, [task], first_seconds(refs, rollout_s), space)
        with tempfile.TemporaryDirectory() as tmp:
            store = RunStore(Path(tmp), create=True)
            # a leak grows in both halves; a cache warming up (Drake builds a plant per new
            # time step, up to a few hundred builds) grows in the first only
            checkpoints = (100, 50 * round((100 + args.evals) / 100), args.evals)
            with Evaluator(short, store, 2) as evaluator:
                done = 0
                for _ in range(0, args.evals, 50):
                    xs = lo + rng.random((50, len(space))) * (hi - lo)
                    xs[:, space.names.index("timestep")] = np.maximum(xs[:, space.names.index("timestep")], 0.01)
                    evaluator(None, xs)
                    done += 50
                    if done in checkpoints:
                        memory.append((done, family_rss_mb()))
            store.close()
        print(
            f"  5. memory (main + 2 workers, {rollout_s:.2g} s rollouts): "
            + ", ".join(f"{mb:.0f} MB after {n} evaluations" for n, mb in memory)
            + f" (growth {memory[1][1] - memory[0][1]:+.0f} MB, then {memory[-1][1] - memory[1][1]:+.0f} MB)"
        )
        print(f"  ({time.perf_counter() - engine_start:.0f} s for {engine})", flush=True)

    if not args.skip_target and "mujoco" in args.engines and data != REFERENCE_DIR:
        print()
        times = []
        for seed in range(args.seeds):
            with tempfile.TemporaryDirectory() as tmp:
                res = start_run(
                    RunConfig(
                        optimizer="de",
                        engine="mujoco",
                        tasks="cube",
                        space="extended",
                        data=str(data),
                        seed=seed,
                        workers=2,
                        max_seconds=900,
                        target_fitness=args.target,
                    ),
                    Path(tmp) / "run",
                    show_progress=False,
                )
                times.append(res.wall_s if res.fitness <= args.target else float("inf"))
                print(f"  6. seed {seed}: fitness {res.fitness:.4f} after {res.wall_s:.0f} s", flush=True)
        print(
            f"  6. time to fitness {args.target} (mujoco, cube, extended, 2 workers, real data): "
            f"median {statistics.median(times):.0f} s [{min(times):.0f}, {max(times):.0f}]"
        )
    print(f"\nwhole benchmark: {(time.perf_counter() - start) / 60:.1f} min")


if __name__ == "__main__":
    main()
