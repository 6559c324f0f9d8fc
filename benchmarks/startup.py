"""From `simtune tune` to its first search evaluation, on a cold and on a warm probe cache, and the whole command
against its `--max-seconds` (issue 44, "Start-up").

Each run is the command a user types, as a new process: `simtune tune --task TASK --max-seconds S --out RUN`
(bundled MICO project; `--data ROOT` where given).  "First evaluation" is the earliest ``finished_at`` the run
store holds (the search's first batch finishing; the generic score before it is not stored) less the moment
the process was started; "whole" is the process's wall time.  Cold: an empty ``SIMTUNE_CACHE_DIR`` (the
inactive-parameter probe runs); warm: the same folder again (the probe is read).

    python benchmarks/startup.py [--task cube] [--data ROOT] [--max-seconds 20] [--repeats 3]
"""

from __future__ import annotations

import os
import sqlite3
import statistics
import subprocess
import sys
import tempfile
import time
from contextlib import closing
from pathlib import Path

from common import RESULTS_DIR, Transcript, make_parser, today


def one_run(task: str, data: Path | None, max_seconds: float, cache: Path, out: Path) -> tuple[float, float]:
    """(seconds to the first stored evaluation, seconds of the whole command) of one `simtune tune`."""
    command = [sys.executable, "-m", "simtune.cli", "tune", "--task", task, "--max-seconds", f"{max_seconds:g}"]
    command += ["--out", str(out), "--quiet", "--json"] + (["--data", str(data)] if data else [])
    env = {**os.environ, "SIMTUNE_CACHE_DIR": str(cache)}
    started = time.time()
    done = subprocess.run(command, env=env, capture_output=True, text=True, check=False)
    whole = time.time() - started
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed ({done.returncode}): {done.stderr.strip()[-400:]}")
    with closing(sqlite3.connect(out / "run.sqlite")) as db:
        first = db.execute("SELECT MIN(finished_at) FROM evaluations").fetchone()[0]
    return float(first) - started, whole


def main() -> int:
    parser = make_parser(__doc__, whole_doc=True)
    parser.add_argument("--task", default="cube")
    parser.add_argument("--data", type=Path, default=None, help="the recordings' root (default: the project's)")
    parser.add_argument("--max-seconds", type=float, default=20.0)
    parser.add_argument("--repeats", type=int, default=3, help="warm runs (one cold run first)")
    args = parser.parse_args()
    transcript = Transcript(RESULTS_DIR / f"startup-{today()}.txt")
    say = transcript.say
    say(
        f"# python benchmarks/startup.py --task {args.task} --max-seconds {args.max_seconds:g} "
        f"--repeats {args.repeats}{f' --data {args.data}' if args.data else ''}"
    )
    with tempfile.TemporaryDirectory() as scratch:
        root = Path(scratch)
        rows = []
        for k in range(1 + args.repeats):
            kind = "cold" if k == 0 else "warm"
            first, whole = one_run(args.task, args.data, args.max_seconds, root / "cache", root / f"run{k}")
            rows.append((kind, first, whole))
            say(f"{kind}: first search evaluation {first:.2f} s, whole command {whole:.1f} s")
    warm = [r for r in rows if r[0] == "warm"]
    say(
        f"cold: {rows[0][1]:.2f} s to the first evaluation; warm median {statistics.median(r[1] for r in warm):.2f} s "
        f"(targets 4 s and 1.5 s); whole command - max-seconds: cold {rows[0][2] - args.max_seconds:+.1f} s, warm "
        f"median {statistics.median(r[2] for r in warm) - args.max_seconds:+.1f} s (target <= +5 s)"
    )
    transcript.save()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
