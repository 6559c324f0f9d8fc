"""The report folder: which of its files the report may replace, and putting a finished report into it.

A report never deletes or overwrites a file it did not write.  It lists the files it wrote in
:data:`MANIFEST` in the folder; a later report into the same folder replaces or removes only those and
leaves every other file alone.  A folder that holds files but no manifest is refused, unless it is a
report of a simtune from before the manifest (recognised by its ``index.html``): then the files that
index.html links to are taken as the report's.

The report is drawn into a scratch folder first and moved into place only once it is complete, so
a bad input or a failure halfway leaves the folder as it was.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import tempfile
from pathlib import Path, PurePosixPath

import simtune
from simtune.errors import SimtuneError

MANIFEST = ".simtune-report.json"
INDEX = "index.html"
DR_FILE = "dr_ranges.yaml"
SUBFOLDERS = ("figures", "tables")  # made even when empty, as reports always have

#: what identifies index.html as simtune's: the generator tag it carries, or (reports from before the
#: tag) its title together with the meta line naming simtune's version
GENERATOR = "simtune report"
_LEGACY_MARKS = ("<title>simtune report: simulator tuning results</title>", '<p class="meta">simtune ')
_LEGACY_LINK = re.compile(r'href="((?:figures/[^"/]+\.(?:png|svg))|(?:tables/[^"/]+\.(?:csv|md)))"')
_DR_HEADER = "# Domain-randomisation ranges from simtune tuning runs"  # the first line dr.write_dr_yaml writes
_SHOWN = 3  # foreign files named in a refusal


def generator_tag() -> str:
    """The ``<meta name="generator">`` element that marks an index.html as simtune's.

    Returns:
        The HTML element, naming simtune's version.
    """
    return f'<meta name="generator" content="{GENERATOR} {simtune.__version__}">'


def owned_files(out: Path) -> set[str]:
    """Check that ``out`` can take a report, and say which of its files an earlier report wrote.

    Reads the folder only.  A missing folder, or one holding no files (empty sub-folders are allowed),
    can take a report.

    Args:
        out: The report folder (``--out``).

    Returns:
        The files (POSIX paths relative to ``out``) the earlier report there wrote, which the new one may
        replace or remove; empty for a new or empty folder.

    Raises:
        SimtuneError: ``out`` is a file; or it holds files but neither a manifest nor an earlier simtune
            report's index.html; or its manifest cannot be read.
    """
    if not out.exists():
        return set()
    if not out.is_dir():
        raise SimtuneError(f"--out {out} is a file, not a report folder")
    try:
        if (out / MANIFEST).exists():
            return _read_manifest(out)
        legacy = _legacy_report(out)
        if legacy is not None:
            return legacy
        found = _first_files(out)
    except OSError as exc:
        raise _cannot_use(out, exc) from None
    if found:
        raise SimtuneError(
            f"--out {out} holds files that simtune report did not write ({_listed(found)}): a report never "
            "deletes or overwrites them; choose a new or empty folder, or one an earlier report made"
        )
    return set()


def install(staging: Path, out: Path) -> None:
    """Move the complete report in ``staging`` into ``out``, replacing the earlier report there.

    Files of the earlier report that the new one does not have are removed; files of anybody else are
    left untouched.  The manifest first claims the old and the new files together, so that a report
    interrupted while moving its files can still be replaced by the next one.

    Args:
        staging: The folder the new report was written into (index.html, figures/, tables/ ...).
        out: The report folder (``--out``).

    Raises:
        SimtuneError: ``out`` cannot take the report (see :func:`owned_files`), a file of the new report
            would replace a file the earlier one did not write (named), or ``out`` cannot be written.
    """
    owned = owned_files(out)  # again: the folder may have changed while the report was drawn
    new = sorted(_files_below(staging))
    blocked = [rel for rel in new if _blocks(out, rel, owned)]
    blocked += [sub for sub in SUBFOLDERS if (out / sub).exists() and not (out / sub).is_dir()]
    if blocked:
        raise SimtuneError(
            f"--out {out}: the report would overwrite files it did not write ({_listed(blocked)}): "
            "move them away or choose another folder"
        )
    try:
        out.mkdir(parents=True, exist_ok=True)
        _write_manifest(out, owned | set(new))
        for rel in sorted(owned - set(new)):
            path = out / rel
            if path.is_file() or path.is_symlink():
                path.unlink()
        for sub in SUBFOLDERS:
            (out / sub).mkdir(exist_ok=True)
        for rel in new:
            target = out / rel
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.move(staging / rel, target)
        _write_manifest(out, set(new))
    except OSError as exc:
        raise _cannot_use(out, exc) from None


def _read_manifest(out: Path) -> set[str]:
    """The files the manifest in ``out`` lists; a manifest that is not simtune's, or names a path outside
    ``out``, is refused rather than trusted with deletions."""
    where = out / MANIFEST
    try:
        record = json.loads(where.read_text())
    except ValueError as exc:
        raise SimtuneError(
            f"--out {out}: {MANIFEST} is not readable ({exc}): empty the folder or choose another"
        ) from None
    files = record.get("files") if isinstance(record, dict) else None
    if (
        not isinstance(record, dict)
        or record.get("written_by") != GENERATOR
        or not isinstance(files, list)
        or not all(isinstance(f, str) and _inside(f) for f in files)
    ):
        raise SimtuneError(
            f"--out {out}: {MANIFEST} is not a list of files written by simtune report: "
            "empty the folder or choose another"
        )
    return set(files)


def _write_manifest(out: Path, files: set[str]) -> None:
    """Replace the manifest in one step, so that a crash leaves the old one or the new one, never half."""
    text = json.dumps({"written_by": GENERATOR, "version": simtune.__version__, "files": sorted(files)}, indent=1)
    # a fresh unique name: never a file of the user's
    fd, scratch = tempfile.mkstemp(dir=out, prefix=".simtune-report-", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text + "\n")
        os.replace(scratch, out / MANIFEST)
    except BaseException:
        Path(scratch).unlink(missing_ok=True)
        raise


def _legacy_report(out: Path) -> set[str] | None:
    """The files of a report that a simtune from before the manifest wrote into ``out``: its index.html,
    the figures and tables that index.html links to, and a dr_ranges.yaml with simtune's header.  None
    when index.html is missing or not simtune's."""
    index = out / INDEX
    if not index.is_file():
        return None
    page = index.read_text(errors="replace")
    if f'<meta name="generator" content="{GENERATOR}' not in page and not all(m in page for m in _LEGACY_MARKS):
        return None
    files = {INDEX} | {rel for rel in _LEGACY_LINK.findall(page) if (out / rel).is_file()}
    dr = out / DR_FILE
    if dr.is_file():
        with dr.open(errors="replace") as f:
            if f.readline().startswith(_DR_HEADER):
                files.add(DR_FILE)
    return files


def _first_files(out: Path) -> list[str]:
    """Up to one more than :data:`_SHOWN` files below ``out``, shallowest first (a refusal names a few, and
    says whether there are more, without walking a large folder to its end)."""
    found: list[str] = []
    level = [out]
    while level and len(found) <= _SHOWN:
        below = []
        for folder in level:
            for entry in sorted(folder.iterdir()):
                if entry.is_dir() and not entry.is_symlink():
                    below.append(entry)
                else:
                    found.append(entry.relative_to(out).as_posix())
        level = below
    return found


def _files_below(folder: Path) -> list[str]:
    """Every file below ``folder``, as POSIX paths relative to it."""
    return [p.relative_to(folder).as_posix() for p in folder.rglob("*") if not p.is_dir()]


def _blocks(out: Path, rel: str, owned: set[str]) -> bool:
    """Whether writing ``out/rel`` would replace something the earlier report did not write: a file of
    that name, a folder of that name, or a file where one of its folders should be."""
    target = out / rel
    if target.is_dir() or ((target.exists() or target.is_symlink()) and rel not in owned):
        return True
    folders = [out / p for p in PurePosixPath(rel).parents if p != PurePosixPath(".")]
    return any(f.exists() and not f.is_dir() for f in folders)


def _inside(rel: str) -> bool:
    """Whether ``rel`` names a path inside the folder (relative, no ``..``): the only kind a manifest may list."""
    path = PurePosixPath(rel)
    return bool(rel) and not path.is_absolute() and ".." not in path.parts and "\\" not in rel


def _listed(names: list[str]) -> str:
    shown = ", ".join(names[:_SHOWN])
    return shown + (" and more" if len(names) > _SHOWN else "")


def _cannot_use(out: Path, exc: OSError) -> SimtuneError:
    """One line for a report folder that cannot be read or written (permissions, a full disk)."""
    name = f" ({exc.filename})" if exc.filename else ""
    return SimtuneError(f"--out {out}: cannot write the report folder: {exc.strerror or exc}{name}")
