"""A tuned run scored on the repeats it was tuned on and on the ones it never saw (issue 45's held-out split).

Tune on half of each task's repeats first (``simtune tune ... --repeats even --out RUN``), then:

    python benchmarks/heldout_split.py RUN [--data ROOT]

For each split (``even``, ``odd``) it prints the run's best parameters' fitness as tuned, and with each task's
command delay found again by the 1-D delay search (as ``simtune transfer`` aligns a test task's clock; the window
scanned, and for comparison the one bounded search used until 2026-11-29): the aligned
reference puts its clock at the median onset of the repeats that build it, so a delay tuned against one half is not
the other half's clock, while the physics is what a held-out split should judge.
"""

from __future__ import annotations

import json
import warnings
from dataclasses import replace
from pathlib import Path

from common import QRG2019_DATA, make_parser

from simtune.alignment import estimate_delay
from simtune.params.kinds import task_delay_name
from simtune.run_plan import plan_run
from simtune.runs import read_run_record


def main() -> int:
    parser = make_parser(__doc__)
    parser.add_argument("run", type=Path, help="a finished run tuned on some of the repeats")
    parser.add_argument("--data", type=Path, default=QRG2019_DATA, help="the recordings' root")
    args = parser.parse_args()
    stored = read_run_record(args.run).settings
    best = json.loads((args.run / "best_params.json").read_text())
    best = best.get("params", best)
    print(f"{args.run}: tuned on the {stored.repeats} repeats of {stored.tasks} ({stored.space}, {stored.engine})")
    for repeats in ("even", "odd"):
        config = replace(stored, data=str(args.data), repeats=repeats)
        config.check(str(args.run))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            objective = plan_run(config).objective()
        as_tuned = objective.score(dict(best)).fitness
        for scan in (True, False):
            params = dict(best)
            for task in objective.tasks:
                params[task_delay_name(task.name)] = estimate_delay(objective, task, params, scan=scan).delay_s
            aligned = objective.score(params)
            parts = ", ".join(f"{t.task} {t.fitness:.5f}" for t in aligned.tasks)
            seen = "fitted" if repeats == stored.repeats else "held out"
            how = "scanned" if scan else "one bounded search, as before 2026-11-29"
            line = f"{repeats} ({seen}): as tuned {as_tuned:.5f}; each task's clock aligned ({how})"
            print(f"{line} {aligned.fitness:.5f} ({parts})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
