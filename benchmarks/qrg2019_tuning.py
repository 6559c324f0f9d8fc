"""Tune every engine x task x space on the real qrg2019 recordings and print the table.

    python benchmarks/qrg2019_tuning.py [--data ../shared/datasets/qrg2019/mocap] [--max-seconds 300]
        [--workers 2] [--engines mujoco,pybullet] [--tasks single,cube] [--spaces shared,individual,extended]
        [--out runs/qrg2019] [--reference mean|aligned] [--loading description|paper] [--max-evaluations N]

``--reference mean`` scores as the table of docs/results.md was made (the paper's plain mean of the repeats);
``--loading paper`` loads PyBullet's robot as the paper did (its default before issue 69); ``--max-evaluations``
stops each run after that many evaluations, for a like-for-like rerun on a busy host.

Each run is a normal run folder (resumable); a finished one is read, not redone.
Prints a Markdown table of generic and tuned fitness (the table of docs/results.md).
"""

from __future__ import annotations

import time
from pathlib import Path

from common import add_data_option, add_engines_option, make_parser

from simtune.runs import RunConfig, start_run
from simtune.store import RunStore


def main() -> None:
    ap = make_parser(__doc__, whole_doc=True)
    add_data_option(ap)
    ap.add_argument("--max-seconds", type=float, default=300.0)
    ap.add_argument("--workers", type=int, default=2)
    add_engines_option(ap, "mujoco,pybullet")
    ap.add_argument("--tasks", default="single,cube")
    ap.add_argument("--spaces", default="shared,individual,extended")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="runs/qrg2019")
    ap.add_argument("--reference", default="", help="mean or aligned (default: simtune's, aligned)")
    ap.add_argument("--loading", default="", help="description or paper (default: simtune's, description)")
    ap.add_argument("--max-evaluations", type=int, default=None)
    args = ap.parse_args()
    rows = []
    for engine in args.engines.split(","):
        for task in args.tasks.split(","):
            for space in args.spaces.split(","):
                run_dir = Path(args.out) / f"{engine}-{task}-{space}"
                if not (run_dir / "run.sqlite").exists() or RunStore(run_dir).get("status") != "finished":
                    if run_dir.exists():
                        import shutil

                        shutil.rmtree(run_dir)
                    t0 = time.time()
                    start_run(
                        RunConfig(
                            optimizer="de",
                            engine=engine,
                            tasks=task,
                            space=space,
                            data=str(args.data),
                            seed=args.seed,
                            workers=args.workers,
                            max_seconds=args.max_seconds,
                            max_evaluations=args.max_evaluations,
                            reference=args.reference,
                            loading=args.loading,
                        ),
                        run_dir,
                        show_progress=False,
                    )
                    print(f"{engine} {task} {space}: {time.time() - t0:.0f} s", flush=True)
                store = RunStore(run_dir)
                best = store.best_evaluation()["score"]
                rows.append(
                    (
                        engine,
                        task,
                        space,
                        store.get("generic")["fitness"],
                        best["fitness"],
                        best["wrist_error"],
                        best["object_error"],
                        store.count_evaluations(),
                        store.get("elapsed_s"),
                    )
                )
    print("\n| engine | task | space | generic | tuned | wrist | object | evaluations | wall [s] |")
    print("|---|---|---|---|---|---|---|---|---|")
    for e, t, s, g, f, w, o, n, wall in rows:
        obj = "-" if o is None else f"{o:.4f}"
        print(f"| {e} | {t} | {s} | {g:.4f} | {f:.4f} | {w:.4f} | {obj} | {n} | {wall:.0f} |")


if __name__ == "__main__":
    main()
