"""Experiment grids: engines x tasks x spaces x repeats, one optimisation per unit of work.

Each unit is an ordinary run folder (``GRID/runs/<engine>-<task>-<space>-s<seed>``)
with its own run store, written only by the worker running it.  The grid's index
(``GRID/grid.sqlite``, or tables in a PostgreSQL database that many grids
share) is written only by the coordinating process, so no store ever needs
locking across machines.

Running the same grid again skips finished units and resumes unfinished ones
from their stores; a unit whose worker dies is retried (on another worker,
under Dask) and resumes from what the dead worker committed, so nothing is
lost or counted twice.

- :mod:`.spec`: :class:`GridSpec`, its :class:`Unit` s and :func:`run_unit`, the work one unit does;
- :mod:`.index`: the :class:`GridIndex` interface and its SQLite and PostgreSQL classes;
- :mod:`.executors`: :func:`run_grid`, with a local process pool or a Dask cluster;
- :mod:`.planner`: :func:`plan_grid`, the size and measured cost of a grid.
"""

from simtune.grid.executors import EXECUTORS, run_grid
from simtune.grid.index import INDEX_FILE, GridIndex, PostgresGridIndex, SQLiteGridIndex, open_index
from simtune.grid.planner import plan_grid
from simtune.grid.spec import GridSpec, Unit, run_unit

__all__ = [
    "EXECUTORS",
    "INDEX_FILE",
    "GridIndex",
    "GridSpec",
    "PostgresGridIndex",
    "SQLiteGridIndex",
    "Unit",
    "open_index",
    "plan_grid",
    "run_grid",
    "run_unit",
]
