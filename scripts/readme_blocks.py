"""Run the README's walk-through as a newcomer would: every fenced block that starts with ``# readme-run:``, as
written, one after the other in one empty folder (issue 48: "a fresh clone following the README as written
reaches a tuned model, a report and an export of cube on the real data").

Each block runs in ``bash -euo pipefail`` with the environment's ``bin`` folder first on ``PATH`` (the README says to
activate ``.venv``), in the same working folder, so that a later block finds what an earlier one made.  ``DATA`` is
the real recordings' folder (``--data``; the README's blocks default it to ``qrg2019/mocap``, the folder its data
section makes).  After the blocks, the files a newcomer should have are checked: the tuned run's best parameters,
the report's page and the exported model.

    python scripts/readme_blocks.py [--data ../shared/datasets/qrg2019/mocap] [--work DIR] [--readme README.md]

Prints each block's title, its wall time and its last lines; exits 1 when a block fails or an expected file is
missing, 2 on bad arguments.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MARK = "# readme-run:"
#: what the walk-through must leave in its folder
EXPECTED = ("runs/cube/best_params.json", "report/index.html", "exported/cube", "myarm/simtune.toml", "runs/reach")


def readme_blocks(readme: Path) -> list[tuple[str, str]]:
    """The README's runnable blocks, in order: (title, the block's text).

    Args:
        readme: the README file.
    Returns:
        Each fenced block whose first line starts with :data:`MARK`, with the title after the mark.
    """
    blocks = []
    for body in re.findall(r"^```[a-z]*\n(.*?)^```", readme.read_text(), flags=re.S | re.M):
        first = body.splitlines()[0] if body.strip() else ""
        if first.startswith(MARK):
            blocks.append((first[len(MARK) :].strip(), body))
    return blocks


def run_blocks(readme: Path, work: Path, data: Path | None, bin_dir: Path) -> list[str]:
    """Run the README's blocks in ``work``; the problems found (empty when the walk-through worked).

    Args:
        readme: the README file.
        work: an empty folder to run them in.
        data: the real recordings' folder, given to the blocks as ``DATA`` (None: the README's own default).
        bin_dir: the environment's ``bin`` folder (``simtune`` and ``python``), put first on ``PATH``.
    Returns:
        One line per failed block or missing file.
    """
    env = {**os.environ, "PATH": f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}", "COLUMNS": "100"}
    if data is not None:
        env["DATA"] = str(data.resolve())
    problems = []
    blocks = readme_blocks(readme)
    if not blocks:
        return [f"{readme}: no block starts with {MARK!r}"]
    for title, body in blocks:
        start = time.perf_counter()
        done = subprocess.run(
            ["bash", "-euo", "pipefail", "-c", body], cwd=work, env=env, capture_output=True, text=True, check=False
        )
        seconds = time.perf_counter() - start
        print(f"== {title}: exit {done.returncode} in {seconds:.0f} s", flush=True)
        tail = (done.stdout + done.stderr).strip().splitlines()[-6:]
        print("\n".join(f"   {line}" for line in tail), flush=True)
        if done.returncode != 0:
            problems.append(f"block {title!r} failed with exit status {done.returncode}")
            break  # the later blocks build on it
    problems += [f"missing after the walk-through: {name}" for name in EXPECTED if not (work / name).exists()]
    return problems


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--readme", type=Path, default=ROOT / "README.md")
    parser.add_argument("--data", type=Path, default=None, help="the real recordings (ROOT/<task>/*.tsv)")
    parser.add_argument("--work", type=Path, default=None, help="an empty folder to run in (default: a new one)")
    parser.add_argument("--bin", type=Path, default=Path(sys.executable).parent, help="the environment's bin folder")
    args = parser.parse_args()
    if args.data is not None and not args.data.is_dir():
        print(f"error: --data {args.data}: not a folder", file=sys.stderr)
        return 2
    if args.work is not None and args.work.exists() and any(args.work.iterdir()):
        print(f"error: --work {args.work}: not empty", file=sys.stderr)
        return 2
    work = args.work or Path(tempfile.mkdtemp(prefix="simtune-readme-"))
    work.mkdir(parents=True, exist_ok=True)
    print(f"running the README's blocks in {work}", flush=True)
    problems = run_blocks(args.readme, work, args.data, args.bin)
    for line in problems:
        print(f"problem: {line}")
    print("the README's walk-through works" if not problems else f"{len(problems)} problem(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
