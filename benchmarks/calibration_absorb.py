"""What the calibration parameters absorb of a tuned run's residual.

The run's best parameters stay fixed; only the calibration parameters (encoder offsets and joint
compliances) are fitted to the recordings by least squares on the marker residual (SciPy's
``least_squares``, trust-region reflective within the parameters' ranges, as simtune's
refinement does).  Printed: the wrist and object errors before and after, and the fitted values.

    python benchmarks/calibration_absorb.py RUN_DIR [--data ROOT] [--max-evaluations 150] [--range-scale 1]

``--range-scale K`` widens every calibration range K times (offsets +-3K deg, compliances up to 2K deg of
deflection at full load): does the data ask for more than the space allows?
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np
from common import add_data_option, load_best, make_parser
from scipy.optimize import least_squares

from simtune.fitness import marker_positions
from simtune.objective import Objective, load_references
from simtune.params import get_space
from simtune.params.space import FULL_LOAD_DEFLECTION_DEG


def main() -> int:
    parser = make_parser(__doc__.split("\n\n")[0])
    parser.add_argument("run", type=Path)
    add_data_option(parser, default=None, help="the recordings' root (default: the tasks' own)")
    parser.add_argument("--max-evaluations", type=int, default=150)
    parser.add_argument("--range-scale", type=float, default=1.0)
    args = parser.parse_args()
    best, task = load_best(args.run)
    base = dict(best["params"])
    refs = load_references(args.data, [task])
    ref = refs[task.name]
    assert ref.wrist_mean is not None, "a wrist-tracking task"
    objective = Objective(best["engine"], [task], refs)
    space = get_space("calibrated", robot=task.robot)
    calibration = [p for p in space.parameters if p.name.startswith(("joint_offset_", "compliance_joint_"))]
    scale = np.array([p.high - p.low for p in calibration]) * args.range_scale
    low = np.array([p.low for p in calibration]) * args.range_scale

    def params_of(u: np.ndarray) -> dict[str, float]:
        return {**base, **{p.name: float(low[i] + u[i] * scale[i]) for i, p in enumerate(calibration)}}

    def residual(u: np.ndarray) -> np.ndarray:
        params = params_of(u)
        roll = objective.rollouts(params)[task.name]
        diff = (marker_positions(roll, params) - ref.wrist_mean).ravel() / np.sqrt(len(ref.times))
        return diff

    start = np.array([(base.get(p.name, 0.0) - low[i]) / scale[i] for i, p in enumerate(calibration)])
    before = objective.score(params_of(start))
    t0 = time.perf_counter()
    fit = least_squares(residual, start, bounds=(0.0, 1.0), diff_step=1e-3, max_nfev=args.max_evaluations)
    after = objective.score(params_of(fit.x))
    objective.close()
    widened = f", ranges x{args.range_scale:g}" if args.range_scale != 1 else ""
    print(
        f"\n#### Calibration fitted on top of {args.run.name} ({best['engine']} {task.name} {best['space']}{widened})\n"
    )
    print(
        f"{fit.nfev} residual evaluations (plus finite differences), {time.perf_counter() - t0:.0f} s; {fit.message}\n"
    )
    print("| | fitness | wrist [m] | object [m] |")
    print("|---|---:|---:|---:|")
    for label, s in (("tuned run", before), ("+ calibration fitted", after)):
        print(f"| {label} | {s.fitness:.4f} | {s.wrist_error:.4f} | {s.object_error or 0.0:.4f} |")
    print("\n| parameter | fitted | unit | at full load |")
    print("|---|---:|---:|---|")
    fitted = params_of(fit.x)
    for p in calibration:
        v = fitted[p.name]
        note = f"{v / p.high * FULL_LOAD_DEFLECTION_DEG:.2f} deg" if p.name.startswith("compliance_joint_") else ""
        print(f"| {p.name} | {v:.4g} | {p.unit} | {note} |")
    (args.run / "calibration-absorb.json").write_text(
        json.dumps({"before": before.fitness, "after": after.fitness, "params": fitted}, indent=1)
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
