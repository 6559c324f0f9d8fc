"""Studies built on tuning runs: engines compared on the same tasks (compare), a tuned simulator scored on tasks
it never saw (transfer), how the fitness answers each parameter (sensitivity) and recordings synthesised from a
known truth (synth)."""
