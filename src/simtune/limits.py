"""Limits every entry point checks a value against (the command line, the API and a stored run alike)."""

#: seeds must fit every random generator the optimisers use (NumPy's legacy seeding takes 32 bits)
MAX_SEED = 2**32 - 1
