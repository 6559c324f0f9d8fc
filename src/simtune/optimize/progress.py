"""A live progress line for tuning: generation, best fitness, evaluations per second."""

from __future__ import annotations

import time

from rich.console import Console
from rich.progress import BarColumn, Progress, ProgressBar, Task, TaskID, TextColumn, TimeElapsedColumn

from simtune.fitness import Score


class _ClockBar(BarColumn):
    """A bar that a time budget fills with the seconds elapsed at each of Rich's refreshes, not those of the last
    evaluation: a long evaluation (one candidate's many episodes, 9 s) left the bar standing still (probe 5)."""

    def render(self, task: Task) -> ProgressBar:
        bar = super().render(task)
        if task.total is not None and task.elapsed is not None:
            bar.completed = min(max(bar.completed, task.elapsed), task.total)
        return bar


class TuneProgress:
    """Rich progress bar (on stderr) fed by the tuner's per-evaluation and per-generation callbacks.

    With a time budget the bar fills with elapsed time, as the clock runs (:class:`_ClockBar`); otherwise it only
    counts.  The counts move with every evaluation that finishes (with a time budget the Evaluator's slices give
    results every few seconds: :data:`simtune.optimize.evaluator.SLICE_S`).  Its evaluation count is the
    run store's, as the summary after it says: the evaluations stored by earlier sessions (``stored``, a resumed run)
    plus those simulated in this one.  A point the search asks for again is taken from the store and is no new
    evaluation (the opening's best point in the first population, a least-squares point in a Jacobian's replay).
    """

    def __init__(self, enabled: bool = True, max_seconds: float | None = None, stored: int = 0):
        self.enabled = enabled
        self.max_seconds = max_seconds
        self.generation_no = 0
        self.best = float("inf")
        self.simulated = 0
        self.reused = 0  # answers taken from the store (counted, not shown: not new evaluations)
        self.stored = stored
        self._start = time.perf_counter()
        self._progress = Progress(
            TextColumn("[bold]tuning[/]"),
            _ClockBar(),
            TextColumn(
                "gen {task.fields[gen]:>4}  best {task.fields[best]}  {task.fields[rate]} eval/s"
                "  {task.fields[evals]} evals{task.fields[reused]}"
            ),
            TimeElapsedColumn(),
            console=Console(stderr=True),
            disable=not enabled,
            transient=False,
        )
        self._task: TaskID | None = None  # set on entering the context

    def __enter__(self) -> TuneProgress:
        self._progress.__enter__()
        self._task = self._progress.add_task(
            "tune", total=self.max_seconds, gen=0, best="-", rate="-", evals=0, reused=""
        )
        return self

    def __exit__(self, *exc) -> None:
        self._refresh()
        self._progress.__exit__(*exc)

    def _refresh(self) -> None:
        if self._task is None:
            return
        elapsed = time.perf_counter() - self._start
        rate = self.simulated / elapsed if elapsed > 0 else 0.0
        self._progress.update(
            self._task,
            completed=min(elapsed, self.max_seconds) if self.max_seconds else None,
            gen=self.generation_no,
            best=f"{self.best:.4f}" if self.best < float("inf") else "-",
            rate=f"{rate:.1f}",
            evals=self.stored + self.simulated,
            reused=f" ({self.stored} from earlier sessions)" if self.stored else "",
        )

    def evaluation(self, score: Score, reused: bool) -> None:
        if reused:
            self.reused += 1
        else:
            self.simulated += 1
        self.best = min(self.best, score.fitness)
        self._refresh()

    def generation(self, number: int, best: float) -> None:
        self.generation_no = number
        self.best = min(self.best, best)
        self._refresh()
