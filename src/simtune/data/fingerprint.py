"""Which files a task's recordings are, and a fingerprint of them (names, sizes, SHA-256).

A run store keeps the fingerprint of the data it was tuned on, so that a
resumed run can tell that its recordings changed, and an exported model can
say exactly which recordings it was fitted to.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable, Mapping
from pathlib import Path

from simtune.data.formats import format_of
from simtune.data.loaders import is_recording_file


def task_files(folder: Path | str) -> list[Path]:
    """The recordings of one task folder (files, rosbag2 and LeRobot dataset folders), sorted by name; a task
    folder that is itself a dataset (a format holding episodes) is its one source.

    macOS AppleDouble companions (``._name.tsv``, written beside every file
    copied from a Mac onto a foreign file system) hold metadata, not data.

    Args:
        folder: a task's folder of recordings.

    Returns:
        Its recordings.
    """
    folder = Path(folder)
    own = format_of(folder) if folder.is_dir() else None
    if own is not None and own.episodes:
        return [folder]
    return sorted(
        (
            p
            for p in folder.iterdir()
            if (p.is_file() or p.is_dir()) and is_recording_file(p) and not p.name.startswith("._")
        ),
        key=lambda p: p.name,
    )


def file_fingerprint(path: Path) -> dict:
    """The fingerprint of one recording.

    Args:
        path: a file, or a folder recording: a rosbag2 folder (its files' names and content), a LeRobot dataset
            (the files simtune reads, its format's ``members``: not its videos).

    Returns:
        ``{"file", "bytes", "sha256"}``.
    """
    digest = hashlib.sha256()
    fmt = format_of(path) if path.is_dir() else None
    if fmt is not None and fmt.members is not None:
        members = fmt.members(path)
    else:
        members = sorted(p for p in path.rglob("*") if p.is_file()) if path.is_dir() else [path]
    for member in members:
        if path.is_dir():
            digest.update(member.relative_to(path).as_posix().encode() + b"\0")
        with open(member, "rb") as fh:
            while block := fh.read(1 << 20):
                digest.update(block)
    return {"file": path.name, "bytes": sum(m.stat().st_size for m in members), "sha256": digest.hexdigest()}


def data_fingerprint(root: Path | str, task_names: Iterable[str]) -> dict[str, list[dict]]:
    """Task name -> fingerprints of its recording files under ``root/<task>/`` (missing folder: empty)."""
    return folders_fingerprint({name: Path(root) / name for name in task_names})


def folders_fingerprint(folders: Mapping[str, Path | str]) -> dict[str, list[dict]]:
    """Task name -> fingerprints of the recording files in its folder (missing folder: empty)."""
    result: dict[str, list[dict]] = {}
    for name, folder in folders.items():
        folder = Path(folder)
        result[name] = [file_fingerprint(p) for p in task_files(folder)] if folder.is_dir() else []
    return result


def fingerprint_changes(old: dict[str, list[dict]], new: dict[str, list[dict]]) -> list[str]:
    """What differs between two data fingerprints, one phrase per file (``task/file changed``)."""
    changes: list[str] = []
    for task in sorted(set(old) | set(new)):
        before = {f["file"]: f for f in old.get(task, [])}
        after = {f["file"]: f for f in new.get(task, [])}
        for name in sorted(set(before) | set(after)):
            if name not in after:
                changes.append(f"{task}/{name} removed")
            elif name not in before:
                changes.append(f"{task}/{name} added")
            elif before[name]["sha256"] != after[name]["sha256"]:
                changes.append(f"{task}/{name} changed")
    return changes
