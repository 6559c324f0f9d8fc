"""From `simtune tune` to its first search evaluation, on a cold and on a warm cache, and the whole command
against its `--max-seconds` (issue 44, "Start-up").

Each run is the command a user types, as a new process: `simtune tune --task TASK --max-seconds S --out RUN`
(bundled MICO project; `--data ROOT` where given), run from this checkout's `src` (PYTHONPATH).  "First
evaluation" is the earliest ``finished_at`` the run store holds (the search's first evaluation; the generic score
before it is not stored) less the moment the process was started; "whole" is the process's wall time.  Cold: an
empty ``SIMTUNE_CACHE_DIR`` (the inactive-parameter probe runs, the recordings are read and aligned, the opening's
delay searched); warm: the same folder again (all of it read back).

`--baseline SRC` measures another version of simtune beside this one, paired: SRC is its `src` folder (a worktree
or `git archive COMMIT src | tar -x -C DIR` of the commit before), each version with its own cache folder, the
cold runs first (before, then after), then the warm runs alternating before/after, so that the host's drift
weighs on both alike.  `--write-bytecode` lets Python keep the compiled modules (a host that sets
PYTHONDONTWRITEBYTECODE compiles simtune's own modules again on every start).

    python benchmarks/startup.py [--task cube] [--data ROOT] [--max-seconds 20] [--repeats 3] [--baseline SRC]
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

#: this checkout's code, the version measured ("after" beside a baseline)
SRC = Path(__file__).resolve().parents[1] / "src"


def one_run(
    src: Path, task: str, data: Path | None, max_seconds: float, cache: Path, out: Path, bytecode: bool
) -> tuple[float, float]:
    """(seconds to the first stored evaluation, seconds of the whole command) of one `simtune tune` of ``src``."""
    command = [sys.executable, "-m", "simtune.cli", "tune", "--task", task, "--max-seconds", f"{max_seconds:g}"]
    command += ["--out", str(out), "--quiet", "--json"] + (["--data", str(data)] if data else [])
    env = {**os.environ, "SIMTUNE_CACHE_DIR": str(cache), "PYTHONPATH": str(src)}
    if bytecode:
        env.pop("PYTHONDONTWRITEBYTECODE", None)
    started = time.time()
    done = subprocess.run(command, env=env, capture_output=True, text=True, check=False)
    whole = time.time() - started
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed ({done.returncode}): {done.stderr.strip()[-400:]}")
    with closing(sqlite3.connect(out / "run.sqlite")) as db:
        first = db.execute("SELECT MIN(finished_at) FROM evaluations").fetchone()[0]
    return float(first) - started, whole


def summary(label: str, rows: list[tuple[str, float, float]], max_seconds: float) -> str:
    """One version's line: cold and warm median seconds to the first evaluation, the whole command against its cap."""
    cold = [r for r in rows if r[0] == "cold"]
    warm = [r for r in rows if r[0] == "warm"]
    text = f"{label}cold: {cold[0][1]:.2f} s to the first evaluation; " if cold else label
    text += f"warm median {statistics.median(r[1] for r in warm):.2f} s (targets 4 s and 1.5 s); whole command - "
    text += f"max-seconds: cold {cold[0][2] - max_seconds:+.1f} s, " if cold else ""
    return text + f"warm median {statistics.median(r[2] for r in warm) - max_seconds:+.1f} s (target <= +5 s)"


def main() -> int:
    parser = make_parser(__doc__, whole_doc=True)
    parser.add_argument("--task", default="cube")
    parser.add_argument("--data", type=Path, default=None, help="the recordings' root (default: the project's)")
    parser.add_argument("--max-seconds", type=float, default=20.0)
    parser.add_argument("--repeats", type=int, default=3, help="warm runs of each version (one cold run first)")
    parser.add_argument("--baseline", type=Path, default=None, help="the src folder of the version to compare with")
    parser.add_argument("--write-bytecode", action="store_true", help="let Python keep compiled modules")
    args = parser.parse_args()
    versions = [("before", args.baseline.resolve()), ("after", SRC)] if args.baseline else [("", SRC)]
    transcript = Transcript(RESULTS_DIR / f"startup-{today()}.txt")
    say = transcript.say
    say(
        f"# python benchmarks/startup.py --task {args.task} --max-seconds {args.max_seconds:g} "
        f"--repeats {args.repeats}{f' --data {args.data}' if args.data else ''}"
        f"{f' --baseline {args.baseline}' if args.baseline else ''}{' --write-bytecode' * args.write_bytecode}"
    )
    rows: dict[str, list[tuple[str, float, float]]] = {label: [] for label, _ in versions}
    with tempfile.TemporaryDirectory() as scratch:
        root = Path(scratch)
        for k in range(1 + args.repeats):
            kind = "cold" if k == 0 else "warm"
            for label, src in versions:
                name = label or "run"
                cache, out = root / f"cache-{name}", root / f"{name}{k}"
                first, whole = one_run(src, args.task, args.data, args.max_seconds, cache, out, args.write_bytecode)
                rows[label].append((kind, first, whole))
                shown = f"{label} {kind}" if label else kind
                say(f"{shown}: first search evaluation {first:.2f} s, whole command {whole:.1f} s")
    for label, _ in versions:
        say(summary(f"{label}: " if label else "", rows[label], args.max_seconds))
    transcript.save()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
