"""The tested set of versions: requirements/lock.txt, a pip constraints file of every package the README's commands
and CI install (simtune's core, its `test` and `lint` extras and what they pull in), pinned to what the test suite
last passed with.

    python3.11 scripts/lock.py check      the lock against pyproject.toml: every requirement of the core and of the
                                          locked extras pinned within its range, and every other extra's
                                          requirement on a locked package met by the pin; one line each where not
                                          (exit 2). scripts/test.sh runs it before it installs anything.
    python3.11 scripts/lock.py refresh    the newest versions pyproject.toml's ranges allow, installed into
                                          .venv-latest (made when missing, upgraded when there), then written to
                                          the lock. Then `scripts/test.sh` tests them; commit the lock where it passes.
    python3.11 scripts/lock.py refresh --venv .venv --no-upgrade
                                          the lock written from an environment as it is (one a test run passed in).

`scripts/test.sh --latest` runs the suite in .venv-latest against the newest versions without writing the lock: an
upgrade is a deliberate step, tested before it is locked.  Only the standard library is needed (pip's own copy of
`packaging` reads the requirements), so that the check runs before any environment exists.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tomllib
from pathlib import Path

try:
    from packaging.requirements import Requirement
    from packaging.utils import canonicalize_name
except ImportError:  # a bare interpreter: pip carries its own copy
    from pip._vendor.packaging.requirements import Requirement
    from pip._vendor.packaging.utils import canonicalize_name

ROOT = Path(__file__).resolve().parent.parent
PYPROJECT = ROOT / "pyproject.toml"
LOCK = ROOT / "requirements" / "lock.txt"
#: the extras the lock pins as a whole set: what CI installs (scripts/test.sh --ci)
LOCKED_EXTRAS = ("test", "lint")
#: where `refresh` and `scripts/test.sh --latest` install the newest versions
LATEST_VENV = ROOT / ".venv-latest"

HEADER = """\
# The tested set: every package simtune's core and its {extras} extras install, at the version the test suite last
# passed with. pip takes it as constraints (scripts/test.sh, the README's commands, .ci/run):
#   pip install -c requirements/lock.txt -e '.[test]'
# Written by `python3.11 scripts/lock.py refresh` ({python}, {platform}); checked against pyproject.toml by
# `python3.11 scripts/lock.py check`. Edit pyproject.toml's ranges, not this file.
"""


def read_lock(path: Path = LOCK) -> dict[str, str]:
    """The lock's pins: canonical package name -> version."""
    pins = {}
    for number, line in enumerate(path.read_text().splitlines(), 1):
        text = line.split("#", 1)[0].strip()
        if not text:
            continue
        name, sep, version = text.partition("==")
        if not sep or not version.strip():
            raise SystemExit(f"error: {path}:{number}: expected NAME==VERSION, got {text!r}")
        pins[canonicalize_name(name.strip())] = version.strip()
    return pins


def requirements() -> tuple[list[Requirement], dict[str, list[Requirement]]]:
    """The core's requirements and each extra's, as pyproject.toml states them."""
    project = tomllib.loads(PYPROJECT.read_text())["project"]
    core = [Requirement(r) for r in project["dependencies"]]
    extras = {name: [Requirement(r) for r in reqs] for name, reqs in project["optional-dependencies"].items()}
    return core, extras


def disagreements(pins: dict[str, str]) -> list[str]:
    """Where the lock and pyproject.toml disagree, one phrase each (empty: they agree)."""
    core, extras = requirements()
    found = []
    locked = [("core", r) for r in core] + [(e, r) for e in LOCKED_EXTRAS for r in extras.get(e, [])]
    for extra in LOCKED_EXTRAS:
        if extra not in extras:
            found.append(f"pyproject.toml has no extra {extra!r}, which the lock covers")
    for where, req in locked:
        if req.marker is not None and not req.marker.evaluate({"extra": where}):
            continue
        name = canonicalize_name(req.name)
        if name not in pins:
            found.append(f"{LOCK.name} pins no version of {req.name} ({where} asks {req})")
        elif not req.specifier.contains(pins[name], prereleases=True):
            found.append(f"{LOCK.name} pins {req.name}=={pins[name]}, outside {where}'s {req}")
    for extra, reqs in extras.items():
        if extra in LOCKED_EXTRAS:
            continue
        for req in reqs:  # an extra may add packages the lock does not hold, but one it holds must fit the pin
            name = canonicalize_name(req.name)
            if name in pins and not req.specifier.contains(pins[name], prereleases=True):
                found.append(
                    f"extra {extra!r} asks {req}, which the tested {req.name}=={pins[name]} does not meet "
                    "(an extra must install the same version as the core)"
                )
    return found


def check() -> int:
    if not LOCK.is_file():
        print(f"error: {LOCK} is missing: `python3.11 scripts/lock.py refresh` writes it", file=sys.stderr)
        return 2
    found = disagreements(read_lock())
    for phrase in found:
        print(f"error: the lock and pyproject.toml disagree: {phrase}", file=sys.stderr)
    if found:
        print(
            "error: change the range in pyproject.toml or refresh the lock (`python3.11 scripts/lock.py refresh`, "
            "then `scripts/test.sh`)",
            file=sys.stderr,
        )
        return 2
    return 0


def refresh(python: str, venv: Path, upgrade: bool) -> int:
    venv_python = venv / "bin" / "python"
    if upgrade:
        if not venv_python.exists():
            subprocess.run([python, "-m", "venv", str(venv)], check=True)
        extras = ",".join(LOCKED_EXTRAS)
        install = [str(venv_python), "-m", "pip", "install", "-q", "--upgrade", "--upgrade-strategy", "eager"]
        subprocess.run([*install, "-e", f".[{extras}]"], cwd=ROOT, check=True)
    elif not venv_python.exists():
        print(f"error: {venv} is not a virtual environment (no bin/python)", file=sys.stderr)
        return 2
    frozen = subprocess.run(
        [str(venv_python), "-m", "pip", "freeze", "--exclude-editable", "--all"],
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    # pip, setuptools and wheel belong to the environment, not to simtune's set
    tools = {"pip", "setuptools", "wheel"}
    lines = sorted(
        (line for line in frozen.splitlines() if "==" in line and canonicalize_name(line.split("==")[0]) not in tools),
        key=str.lower,
    )
    version = subprocess.run(
        [str(venv_python), "-c", "import platform; print(platform.python_version(), platform.machine())"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout.split()
    LOCK.parent.mkdir(exist_ok=True)
    header = HEADER.format(extras=" and ".join(LOCKED_EXTRAS), python=f"Python {version[0]}", platform=version[1])
    LOCK.write_text(header + "\n".join(lines) + "\n")
    print(f"{len(lines)} packages -> {LOCK.relative_to(ROOT)}; now run scripts/test.sh and commit it where it passes")
    return check()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("command", choices=("check", "refresh"))
    parser.add_argument(
        "--python", default=os.environ.get("PYTHON", "python3.11"), help="the interpreter of a new .venv-latest"
    )
    parser.add_argument(
        "--venv", type=Path, default=LATEST_VENV, help="the environment refresh installs into and reads (.venv-latest)"
    )
    parser.add_argument(
        "--no-upgrade",
        action="store_true",
        help="write the lock from --venv as it is (what a passing test run used), installing nothing",
    )
    args = parser.parse_args()
    return check() if args.command == "check" else refresh(args.python, args.venv.resolve(), not args.no_upgrade)


if __name__ == "__main__":
    sys.exit(main())
