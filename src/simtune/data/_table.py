"""Byte-level reading of delimited numeric tables, shared by the TSV and CSV loaders.

Numbers are parsed with a vectorised numpy fast path; only when that path meets
anything unusual (text, exponents, ``nan``/``inf``, spaces) does a per-cell
Python scan run, which is slow but can name the exact line and column at fault.
"""

from __future__ import annotations

import bz2
import codecs
import gzip
import lzma
import math
import warnings
import zlib
from collections import Counter
from pathlib import Path

import numpy as np

from simtune.errors import RecordingError, RecordingWarning

# Powers of ten that are exact in float64; the fast path refuses numbers with
# more digits than this so that its result equals Python's correctly rounded float().
_MAX_DIGITS = 15
_POW10 = 10.0 ** np.arange(_MAX_DIGITS + 1)


def display_name(path: Path) -> str:
    """Short file name for messages: parent folder and file name (e.g. ``cube/x.tsv``)."""
    path = Path(path)
    return f"{path.parent.name}/{path.name}" if path.parent.name else path.name


def read_bytes(path: Path, display: str) -> bytes:
    """A file's text as UTF-8 bytes, whatever its compression or encoding (see :func:`decode_content`)."""
    path = Path(path)
    if not path.exists():
        raise RecordingError(f"{display}: no such file ({path})")
    if not path.is_file():
        raise RecordingError(f"{display}: not a file ({path})")
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise RecordingError(f"{display}: cannot read file ({exc})") from None
    return decode_content(data, display)


# Compressed content, told by its first bytes: (magic, what it is, how to decompress it).
_COMPRESSIONS = (
    (b"\x1f\x8b", "gzip", gzip.decompress),
    (b"BZh", "bzip2", bz2.decompress),
    (b"\xfd7zXZ\x00", "xz", lzma.decompress),
)
# Content that is no recording at all, told by its first bytes, and what it is.
_NOT_RECORDINGS = (
    (b"PK\x03\x04", "a zip archive (a spreadsheet or zipped folder?)"),
    (b"\x28\xb5\x2f\xfd", "zstd-compressed"),
    (b"\x00\x05\x16\x07", "a macOS AppleDouble metadata file (the '._' companion of a copied file)"),
)
# Byte-order marks, longest first: UTF-32's little-endian mark starts with UTF-16's.
_BOMS = (
    (codecs.BOM_UTF32_LE, "utf-32-le"),
    (codecs.BOM_UTF32_BE, "utf-32-be"),
    (codecs.BOM_UTF8, "utf-8"),
    (codecs.BOM_UTF16_LE, "utf-16-le"),
    (codecs.BOM_UTF16_BE, "utf-16-be"),
)


def decode_content(data: bytes, display: str) -> bytes:
    """Decompress and re-encode file content as UTF-8 text, judged by the bytes, never by the name.

    Excel, PowerShell and Windows editors save text with a byte-order mark or as
    UTF-16, and files get compressed or renamed on the way between machines; a
    reader that trusted the name would report a misleading "not a number" on
    line 1.  Encoding check: gzip, bzip2 and xz content is decompressed;
    UTF-8, UTF-16 and UTF-32 with a byte-order mark, and UTF-16 without one
    (told by its NUL high bytes), are decoded; archives and metadata files are
    refused, saying what they are.
    """
    for magic, kind, decompress in _COMPRESSIONS:
        if data.startswith(magic):
            try:
                data = decompress(data)
            except (OSError, EOFError, ValueError, zlib.error, lzma.LZMAError) as exc:
                # gzip.BadGzipFile is an OSError; truncated archives raise EOFError.
                raise RecordingError(
                    f"{display}: encoding check: cannot read its {kind}-compressed content ({exc})"
                ) from None
            break
    for magic, what in _NOT_RECORDINGS:
        if data.startswith(magic):
            raise RecordingError(f"{display}: encoding check: the file is {what}, not a recording")
    bom, encoding = next(((bom, enc) for bom, enc in _BOMS if data.startswith(bom)), (b"", None))
    data = data[len(bom) :]
    encoding = encoding or _utf16_without_bom(data)
    if encoding is None or encoding == "utf-8":
        return data
    try:
        return data.decode(encoding).encode("utf-8")
    except UnicodeDecodeError as exc:
        raise RecordingError(
            f"{display}: encoding check: looks like {encoding.upper()} text but cannot be decoded "
            f"(byte {exc.start}: {exc.reason})"
        ) from None


def _utf16_without_bom(data: bytes) -> str | None:
    """'utf-16-le' or 'utf-16-be' when the NUL bytes say so, else None.

    Text of a recording is ASCII, so in UTF-16 every other byte is NUL: the
    odd bytes (little-endian) or the even ones (big-endian).  A few stray NULs
    in a UTF-8 file are damage, left for the parser to report by line.
    """
    sample = data[:4096]
    half = len(sample) // 2
    if half < 2:
        return None
    even_nul = sample[0::2].count(0)
    odd_nul = sample[1::2].count(0)
    if odd_nul >= 0.9 * half and even_nul <= 0.1 * half:
        return "utf-16-le"
    if even_nul >= 0.9 * half and odd_nul <= 0.1 * half:
        return "utf-16-be"
    return None


def split_lines(data: bytes) -> list[bytes]:
    """Split into lines, accepting CRLF (as Qualisys writes), LF or bare CR endings."""
    if b"\r" in data:
        data = data.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    lines = data.split(b"\n")
    # A final newline leaves one empty string behind; it is not a line.
    if lines and lines[-1] == b"":
        lines.pop()
    return lines


def shorten(text: bytes | str, limit: int = 30) -> str:
    """Printable, bounded excerpt of a cell for an error message."""
    if isinstance(text, bytes):
        text = text.decode("utf-8", errors="replace")
    return text if len(text) <= limit else text[: limit - 3] + "..."


def check_columns(
    lines: list[bytes], linenos: np.ndarray, sep: bytes, display: str
) -> tuple[list[bytes], np.ndarray, int]:
    """Make every data line have the same number of fields.

    The expected count is the most common one.  A shorter *last* line is the
    typical result of an interrupted export: it is dropped with a warning.  Any
    other mismatch is an error naming the first offending line.
    """
    counts = [line.count(sep) + 1 for line in lines]
    ncols = Counter(counts).most_common(1)[0][0]
    if counts[-1] < ncols and len(lines) > 1:
        warnings.warn(
            f"{display} line {int(linenos[-1])}: last line is truncated "
            f"({counts[-1]} of {ncols} columns); dropped that frame",
            RecordingWarning,
            stacklevel=4,
        )
        lines = lines[:-1]
        linenos = linenos[:-1]
        counts = counts[:-1]
    for i, k in enumerate(counts):
        if k != ncols:
            raise RecordingError(f"{display} line {int(linenos[i])}: expected {ncols} columns, found {k}")
    return lines, linenos, ncols


def parse_numbers(
    lines: list[bytes],
    linenos: np.ndarray,
    sep: bytes,
    ncols: int,
    numeric_cols: list[int],
    display: str,
) -> np.ndarray:
    """Parse ``lines`` (all with ``ncols`` fields) into an (n, ncols) float array.

    Empty fields and ``nan`` give NaN.  Only ``numeric_cols`` are checked (and,
    on the slow path, parsed); text or an infinite value in one of them is a
    RecordingError naming line and column.
    """
    # Chunks of ~128 kB keep the per-byte work arrays in cache (about 2x faster
    # than one pass over a whole file), and confine the slow path to one chunk.
    avg = max(1, sum(len(x) for x in lines[:50]) // min(len(lines), 50) + 1)
    step = max(1, _CHUNK_BYTES // avg)
    parts = []
    for i in range(0, len(lines), step):
        chunk = lines[i : i + step]
        values = _fast_parse(b"\n".join(chunk) + b"\n", len(chunk), ncols, sep[0])
        if values is None:
            values = _slow_parse(chunk, linenos[i : i + step], sep, ncols, numeric_cols, display)
        parts.append(values)
    return np.concatenate(parts) if len(parts) > 1 else parts[0]


# Byte classes for the fast parser (the delimiter is added per call).
_OTHER, _DIGIT, _DOT, _MINUS, _PLUS, _DELIM = range(6)
_CLASS = np.full(256, _OTHER, dtype=np.uint8)
_CLASS[48:58] = _DIGIT
_CLASS[46] = _DOT
_CLASS[45] = _MINUS
_CLASS[43] = _PLUS
_CLASS[10] = _DELIM
_DIGIT_VALUE = np.zeros(256)
_DIGIT_VALUE[48:58] = np.arange(10)
_CHUNK_BYTES = 1 << 17


def _fast_parse(block: bytes, nrows: int, ncols: int, sep: int) -> np.ndarray | None:
    """Vectorised parser for plain decimals (``-12.345``); None if anything else is present.

    Each field's digits form an integer mantissa (exact: below 2**53), which
    one division by a power of ten turns into the same correctly rounded
    float that Python's float() gives.
    """
    a = np.frombuffer(block, dtype=np.uint8)
    lut = _CLASS.copy()
    lut[sep] = _DELIM
    cls = lut.take(a)
    if not cls.all():  # _OTHER is 0: any other byte means text, exponent, space ...
        return None
    is_delim = cls == _DELIM
    delim_pos = np.flatnonzero(is_delim)
    nfields = delim_pos.size
    if nfields != nrows * ncols:
        return None
    is_sign = (cls == _MINUS) | (cls == _PLUS)
    if is_sign[1:].any() and np.any(is_sign[1:] & ~is_delim[:-1]):
        return None  # a sign that does not start its field
    starts = np.empty(nfields, dtype=np.int64)
    starts[0] = 0
    starts[1:] = delim_pos[:-1] + 1
    lengths = delim_pos - starts
    digits_upto = np.cumsum(cls == _DIGIT, dtype=np.int32)
    at_end = digits_upto[delim_pos]
    ndigits = np.diff(at_end, prepend=0)
    if np.any((lengths > 0) & (ndigits == 0)) or ndigits.max() > _MAX_DIGITS:
        return None  # "-" or "." alone, or too many digits to be exact
    # Digits after each byte within its field = its decimal power in the mantissa.
    power = np.repeat(at_end, lengths + 1)
    power -= digits_upto
    mantissa = np.add.reduceat(_DIGIT_VALUE.take(a) * _POW10.take(power), starts)
    # Per field: 256 per dot plus the digits after it (the fraction length).
    dots = np.add.reduceat(np.where(cls == _DOT, power + 256, 0), starts)
    if np.any(dots >= 512):
        return None  # two dots in one field
    values = mantissa / _POW10.take(dots & 255)
    first = cls.take(np.minimum(starts, a.size - 1))
    values[first == _MINUS] *= -1.0
    values[lengths == 0] = np.nan
    return values.reshape(nrows, ncols)


def _slow_parse(
    lines: list[bytes],
    linenos: np.ndarray,
    sep: bytes,
    ncols: int,
    numeric_cols: list[int],
    display: str,
) -> np.ndarray:
    """Cell-by-cell parser that reports the first bad cell by line and column."""
    values = np.full((len(lines), ncols), np.nan)
    for i, line in enumerate(lines):
        fields = line.split(sep)
        row = values[i]
        for c in numeric_cols:
            cell = fields[c].strip()
            if not cell:
                continue
            try:
                v = float(cell)
            except ValueError:
                raise RecordingError(
                    f"{display} line {int(linenos[i])}, column {c + 1}: {shorten(cell)!r} is not a number"
                ) from None
            if math.isinf(v):
                raise RecordingError(
                    f"{display} line {int(linenos[i])}, column {c + 1}: {shorten(cell)!r} is not a finite number"
                )
            row[c] = v
    return values


def write_bytes(path: Path, payload: bytes, display: str) -> None:
    """Write ``payload``, gzip-compressed when the name ends in ``.gz``."""
    path = Path(path)
    if path.name.lower().endswith(".gz"):
        # mtime=0 keeps the archive byte-identical across runs (reproducible outputs).
        payload = gzip.compress(payload, mtime=0)
    try:
        path.write_bytes(payload)
    except OSError as exc:
        raise RecordingError(f"{display}: cannot write file ({exc})") from None


def format_column(values: np.ndarray, spec: str) -> list[str]:
    """Format floats with ``spec``; NaN becomes an empty field (a lost marker)."""
    return ["" if math.isnan(v) else format(v, spec) for v in values.tolist()]
