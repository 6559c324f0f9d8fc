"""Format dispatch: one entry point for every recording file simtune reads."""

from __future__ import annotations

from pathlib import Path

from simtune.data._table import display_name
from simtune.data.csvformat import read_csv
from simtune.data.qualisys import read_qualisys_tsv
from simtune.data.recording import Recording
from simtune.errors import RecordingError

#: File endings load_recording understands (lower case).
RECORDING_SUFFIXES = (".tsv", ".tsv.gz", ".csv", ".csv.gz")


def is_recording_file(path: Path) -> bool:
    """True for names ending in one of RECORDING_SUFFIXES (case-insensitive)."""
    return Path(path).name.lower().endswith(RECORDING_SUFFIXES)


def load_recording(path: Path | str, body_names: list[str] | None = None) -> Recording:
    """Load a recording: ``.tsv[.gz]`` as Qualisys 6D TSV (mm), ``.csv[.gz]`` as simtune CSV (m).

    The name picks the format only: compression and text encoding are read
    from the content (see :func:`simtune.data._table.decode_content`).

    ``body_names`` names the bodies of a headerless TSV in column order
    (default QRG2019_BODIES); a TSV header's BODY_NAMES wins, and CSV files
    carry their own names.
    """
    path = Path(path)
    name = path.name.lower()
    if name.endswith((".tsv", ".tsv.gz")):
        return read_qualisys_tsv(path, body_names)
    if name.endswith((".csv", ".csv.gz")):
        return read_csv(path)
    raise RecordingError(f"{display_name(path)}: unknown recording format (expected {', '.join(RECORDING_SUFFIXES)})")
