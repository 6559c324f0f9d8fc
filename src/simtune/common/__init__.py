"""Foundations every layer may use: rotations (geometry), named-row tables (table), terminal tables (console),
limits of values (limits), the checks of a value a user gives (checks), how worker processes start (spawn_guard)
and the cache folder (cache).  Nothing here imports the rest of simtune beyond simtune.errors."""
