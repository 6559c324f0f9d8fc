"""Limits every entry point checks a value against (the command line, the API and a stored run alike)."""

#: seeds must fit every random generator the optimisers use (NumPy's legacy seeding takes 32 bits)
MAX_SEED = 2**32 - 1

#: worker processes (or threads) one command may start: far above any machine simtune runs on (each worker holds
#: its engines), low enough that a mistyped count is refused rather than forking until the machine stalls
MAX_WORKERS = 256

#: bootstrap draws of `simtune uncertainty --bootstrap`: each refits the run's best point (a few seconds to minutes),
#: so a mistyped count is refused rather than running for days
MAX_BOOTSTRAP = 1000
#: ... and at least this many where any: a 95 % interval from the scatter of two or three draws is noise (probe 5)
MIN_BOOTSTRAP = 10

#: recordings per task `simtune synth --repeats` writes: each one a simulation of the task (a second or more), so a
#: mistyped count is refused rather than simulating for hours; real datasets hold tens of repeats
MAX_SYNTH_REPEATS = 1000
