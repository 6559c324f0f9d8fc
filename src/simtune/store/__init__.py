"""The run store: one SQLite file per run folder, holding every evaluation.

Tables
- ``meta``: key -> JSON value (the run's configuration, versions, command line, status);
- ``evaluations``: one row per finished evaluation: its key, the parameter vector, its fitness and parts,
  generation, wall time, whether the simulation was stable, and whether it was pruned (stopped once it could not
  beat its parent: its fitness is then a lower bound);
- ``generations``: one row per generation: the best fitness, the evaluation count and the run's elapsed time, a
  digest of the population and its energies (a replayed generation is recognised by it), and the population
  itself only where ``resume --rescore`` may need it: the latest checkpoint that holds a population;
- ``residuals``: for the evaluations of a least-squares refinement, the residual vector (float64 bytes), so a
  resumed refinement replays without simulating;
- ``retried``: the keys of failed evaluations already given their one retry (:meth:`RunStore.release_failures`).

How values are held in them is the schema version's: one codec per version (:mod:`.codec`: the protocol;
:mod:`.v1`, :mod:`.v2`, :mod:`.v3`: the versions, :mod:`.v3` the current one and where its format is
described). :class:`RunStore` (:mod:`.runstore`) opens a store through the codec of its version and never asks
the version itself. A new store is of the current version; a store of an older version is read and resumed in
its own format: its rows are appended as its version wrote them, so a resumed store stays one version
throughout, the simtune that made it still reads it, and no old row is ever rewritten (an upgrade in place would
rewrite every row of a finished run to gain nothing a reader needs).

:func:`read_record` reads a run once into a :class:`RunRecord`: the one reader of a run for the API, export and
the report. No SQL runs outside this package.

Every evaluation is committed as soon as it finishes (WAL journal), so a kill loses at most the evaluations still
running.  Evaluations are keyed by the exact bytes of their parameter vector: a resumed run replays the optimiser
with the same seed and takes every evaluation it already has from here instead of simulating it again.
"""

from simtune.store.codec import Codec, vector_key
from simtune.store.record import RunRecord, RunView, read_record
from simtune.store.runstore import (
    _SCHEMA,
    MIN_FREE_BYTES,
    READABLE_VERSIONS,
    SCHEMA_VERSION,
    STORE_FILE,
    RunStore,
    check_store_file,
)

__all__ = [
    "MIN_FREE_BYTES",
    "READABLE_VERSIONS",
    "SCHEMA_VERSION",
    "STORE_FILE",
    "_SCHEMA",
    "Codec",
    "RunRecord",
    "RunStore",
    "RunView",
    "check_store_file",
    "read_record",
    "vector_key",
]
