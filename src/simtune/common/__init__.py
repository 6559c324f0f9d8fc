"""Foundations every layer may use: rotations (geometry), named-row tables (table), terminal tables (console),
limits of values (limits) and how worker processes start (spawn_guard). Nothing here imports the rest of simtune
beyond simtune.errors."""
