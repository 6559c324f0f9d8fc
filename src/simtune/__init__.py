"""simtune: tune robot simulators to real motion-capture recordings."""

__version__ = "0.1.0"
