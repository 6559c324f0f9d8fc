"""A script that calls simtune with worker processes at its top level gets one line naming the line to guard,
where it used to wait for ever (a real recording's objective is more than a pipe holds, and the spawned
worker that ran the script again died before reading it)."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from simtune.common.spawn_guard import unguarded_call

SCRIPT = """\
import simtune.api as st
# a comment
result = st.tune(out=OUT, workers=2, max_evaluations=4)
def later():
    return st.tune(out=OUT, workers=2)
if __name__ == "__main__":
    later()
else:
    later()
if "__main__" == __name__:
    later()
"""


@pytest.mark.parametrize(
    ("line", "runs_at_import"),
    [(1, True), (2, False), (3, True), (5, True), (7, False), (9, True), (11, False)],
)
def test_a_line_runs_at_import_unless_it_is_under_the_main_guard(line, runs_at_import):
    assert unguarded_call(SCRIPT, line) is runs_at_import


def _run(tmp_path, body: str, *args: str) -> subprocess.CompletedProcess:
    script = tmp_path / "user_script.py"
    script.write_text(textwrap.dedent(body))
    return subprocess.run(
        [sys.executable, *args, str(script)], capture_output=True, text=True, timeout=300, cwd=tmp_path
    )


def test_an_unguarded_tune_with_workers_says_which_line_to_guard_and_makes_no_run(tmp_path):
    out = tmp_path / "run"
    done = _run(tmp_path, f"import simtune.api as st\nst.tune(out={str(out)!r}, workers=2, max_evaluations=4)\n")
    last = done.stderr.strip().splitlines()[-1]
    assert done.returncode == 1
    assert last.startswith("simtune.errors.SimtuneError: ")
    assert "user_script.py, line 2: 2 workers" in last and 'if __name__ == "__main__":' in last
    assert not out.exists()  # refused before the run's folder was made


@pytest.mark.slow
def test_the_same_tune_under_the_guard_runs_on_two_workers(tmp_path):
    out = tmp_path / "run"
    done = _run(
        tmp_path,
        f"""\
        import simtune.api as st

        if __name__ == "__main__":
            result = st.tune(out={str(out)!r}, workers=2, max_evaluations=30, optimizer="de")
            print("evaluations", result.evaluations)
        """,
    )
    assert done.returncode == 0, done.stderr
    assert int(done.stdout.split()[-1]) >= 30


@pytest.mark.slow
def test_python_dash_m_simtune_cli_is_not_taken_for_an_unguarded_script(tmp_path):
    """``python -m simtune.cli`` calls main() at its top level, but spawn does not run a package's __main__
    again: the guard must not refuse it."""
    out = tmp_path / "run"
    done = subprocess.run(
        [sys.executable, "-m", "simtune.cli", "tune", "--out", str(out), "--workers", "2", "--max-evaluations", "10"],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
    )
    assert done.returncode == 0, done.stderr
    assert (out / "run.sqlite").exists()


def test_workers_fork_from_the_server_with_the_environment_of_the_moment_they_were_asked_for(monkeypatch, tmp_path):
    """Workers fork from a server started before the pool (start_worker_server, as `simtune tune` starts it before
    reading the recordings), yet see the environment as it was when the Evaluator opened, as spawned ones do."""
    from test_batch import objective

    from simtune.common.spawn_guard import start_worker_server, worker_context
    from simtune.optimize.evaluator import Evaluator
    from simtune.store import RunStore

    if sys.platform.startswith("linux"):
        assert worker_context().get_start_method() == "forkserver"
    start_worker_server()
    monkeypatch.setenv("SIMTUNE_WORKER_MARK", "set after the server started")
    store = RunStore(tmp_path / "run", create=True)
    with Evaluator(objective(), store, workers=2, threads=False) as evaluator:
        assert evaluator._pool is not None
        seen = evaluator._pool.schedule(os.getenv, ("SIMTUNE_WORKER_MARK",)).result(timeout=120)
        assert seen == "set after the server started"
        # and they evaluate: the batch path in each, as before
        x = evaluator.objective.vector_space().vector_within_bounds({})
        assert np.isfinite(evaluator.evaluate(np.array([x, x + 1e-9]))).all()
    store.close()


@pytest.mark.slow  # a kill test: the fork server sent SIGINT while it imports (about 3 s)
def test_a_ctrl_c_during_the_fork_servers_imports_leaves_no_traceback_and_no_dead_server():
    """The server does not keep the blocked SIGINT it was started with (an interpreter started anew): a Ctrl-C in its
    first second used to print a KeyboardInterrupt traceback beside the coordinator's one line."""
    script = textwrap.dedent(
        """\
        import os, signal, time
        from multiprocessing import forkserver
        from simtune.common.spawn_guard import start_worker_server
        start_worker_server()
        pid = forkserver._forkserver._forkserver_pid
        time.sleep(0.1)
        os.kill(pid, signal.SIGINT)
        time.sleep(4)
        print("alive" if os.waitpid(pid, os.WNOHANG) == (0, 0) else "dead")
        """
    )
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "alive" and "Traceback" not in proc.stderr, proc.stderr
