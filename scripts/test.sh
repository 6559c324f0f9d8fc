#!/usr/bin/env bash
# The test suite from a fresh clone, the README's test command and CI's (.ci/run) alike.
#
#   scripts/test.sh              the default tier: python -m pytest on 2 processes (pytest-xdist), 3.4 minutes on 2 cores
#   scripts/test.sh -m slow      the slow tier: end-to-end tuning, kill -9 and hang tests, real data
#   scripts/test.sh --ci         CI: ruff check, ruff format --check, mypy, the default tier, the slow tier
#   scripts/test.sh --latest     the default tier (or ARGS) against the newest versions pyproject.toml allows, in
#                                .venv-latest, instead of the tested set (requirements/lock.txt): an upgrade's test
#   scripts/test.sh ARGS...      any other arguments go to pytest
#
# It installs the tested set of versions, requirements/lock.txt (pip constraints), after checking that the lock and
# pyproject.toml agree (scripts/lock.py check: one line each where not, exit 2).  `python3.11 scripts/lock.py
# refresh` writes a new lock from the newest versions; see docs/contributing.md.
#
# The default tier runs on two pytest-xdist processes (-n 2): its tests are independent and mostly one-core
# work.  Each test file goes to one process (--dist loadfile), so that a file's module-wide fixture (a short
# run that several of its tests read) is made once, not once in each process.  The slow tier runs in one
# process: its kill, hang and time-out tests measure wall time themselves and must not share the two cores
# with another test.
#
# It installs the system packages the tests need when they are missing and it can (root, apt-get):
# Debian's libode8 (the library the ODE engine's binding loads), postgresql (a throwaway server
# for the grid's PostgreSQL index) and chromium with chromium-driver (the report's browser test).
# Without them the tests that need them skip, naming the command that installs them. Then it makes
# .venv (PYTHON, default python3.11) and installs simtune with its test extras (and, for --ci, its lint
# extras) into it.
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON="${PYTHON:-python3.11}"

ci=0
latest=0
if [ "${1:-}" = "--ci" ]; then
    ci=1
    shift
elif [ "${1:-}" = "--latest" ]; then
    latest=1
    shift
fi

if ! command -v "$PYTHON" >/dev/null; then
    echo "error: $PYTHON not found: simtune needs Python 3.11 or later (PYTHON=... names another)" >&2
    exit 2
fi

missing=()
# the ODE binding (ode-python) finds libode with ctypes.util.find_library, as checked here
"$PYTHON" -c "import ctypes.util, sys; sys.exit(ctypes.util.find_library('ode') is None)" || missing+=(libode8)
# the PostgreSQL index tests start a server from Debian's postgresql programs (tests/test_grid.py)
compgen -G "/usr/lib/postgresql/*/bin/initdb" >/dev/null || command -v initdb >/dev/null || missing+=(postgresql)
# the report's browser test (tests/test_report_first_screen.py) drives Debian's Chromium through its ChromeDriver
command -v chromium >/dev/null || missing+=(chromium)
command -v chromedriver >/dev/null || missing+=(chromium-driver)
# Debian's own Python makes virtual environments only with its -venv package
"$PYTHON" -c "import ensurepip" 2>/dev/null || missing+=("${PYTHON##*/}-venv")

if [ ${#missing[@]} -gt 0 ]; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        echo "installing ${missing[*]} (apt-get)"
        apt-get update -qq
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >/dev/null
    else
        echo "note: ${missing[*]} missing and not installable here (needs root and apt-get);" \
            "the tests that need them skip: apt-get install ${missing[*]}" >&2
    fi
fi

# the lock and pyproject.toml must agree before anything is installed from them (one line each where not)
"$PYTHON" scripts/lock.py check

venv=.venv
[ "$latest" = 1 ] && venv=.venv-latest
[ -x "$venv/bin/python" ] || "$PYTHON" -m venv "$venv"
extras="test"
[ "$ci" = 1 ] && extras="test,lint"
if [ "$latest" = 1 ]; then
    # the newest versions the ranges allow, every package upgraded
    "$venv/bin/python" -m pip install -q --upgrade --upgrade-strategy eager -e ".[$extras]"
else
    "$venv/bin/python" -m pip install -q -c requirements/lock.txt -e ".[$extras]"
fi
# simtune's own modules compiled once: the tests start many simtune processes (CLI commands, worker
# processes), and where the environment says PYTHONDONTWRITEBYTECODE (as on the project's development host) an editable
# install is otherwise compiled from source in every one of them (0.17 s of each command's start on 2 cores)
"$venv/bin/python" -m compileall -q src >/dev/null
"$venv/bin/python" -c "import mujoco; print(f'testing with MuJoCo {mujoco.__version__} ($venv)')"

if [ "$ci" = 1 ]; then
    "$venv/bin/ruff" check src tests benchmarks
    "$venv/bin/ruff" format --check src tests benchmarks
    "$venv/bin/mypy"
    # the slowest tests are listed so that the default tier's budget (4 minutes) stays visible in CI's log
    "$venv/bin/python" -m pytest -n 2 --dist loadfile --durations=25 "$@"
    "$venv/bin/python" -m pytest -m slow --durations=10 "$@"
elif [[ " $* " == *" -m "* ]]; then
    "$venv/bin/python" -m pytest "$@"  # a chosen tier (-m slow): one process
else
    "$venv/bin/python" -m pytest -n 2 --dist loadfile "$@"
fi
