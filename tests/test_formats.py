"""The registry of recording formats (simtune.data.formats): one record per format, read by everything that
names formats."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from simtune.data.formats import (
    FORMATS,
    RECORDING_SUFFIXES,
    WRITERS,
    RecordingFormat,
    expected_names,
    format_of,
    markdown_tables,
    recording_kinds,
    writer,
)
from simtune.errors import ConfigError

ROOT = Path(__file__).resolve().parents[1]


def test_docs_tables_are_the_registry():
    """docs/recordings.md's tables are written from the records (write_docs rewrites them)."""
    text = (ROOT / "docs/recordings.md").read_text(encoding="utf-8")
    for name, table in markdown_tables().items():
        assert f"<!-- formats: {name} -->\n{table}\n<!-- end formats -->" in text, (
            f"docs/recordings.md's {name} table is not the registry's: run "
            "python -c \"from simtune.data.formats import write_docs; write_docs('docs/recordings.md')\""
        )


def test_extras_are_the_package_extras():
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]["optional-dependencies"]
    assert {fmt.extra for fmt in FORMATS if fmt.extra} <= set(extras)


def test_names_and_lists():
    """The lists that messages, help and init print are the records'."""
    assert len({fmt.name for fmt in FORMATS}) == len(FORMATS)
    assert len(WRITERS) == sum(len(fmt.writers) for fmt in FORMATS)
    assert tuple(ending for fmt in FORMATS for ending in fmt.endings) == RECORDING_SUFFIXES
    for fmt in FORMATS:
        assert fmt.shown in recording_kinds()
        assert (fmt.shown in recording_kinds("joints")) == fmt.joints
        assert all(ending in expected_names() for ending in fmt.endings)
        for written in fmt.writers:
            assert writer(written.name) is written
    assert recording_kinds().startswith("*.tsv, *.csv, *.c3d, *.mcap, rosbag2 folders")
    with pytest.raises(ConfigError, match=r"--format: unknown format 'xyz' \(known: tsv, csv, joints-csv"):
        writer("xyz")


def test_format_of(tmp_path):
    assert format_of(tmp_path / "a.TSV.GZ").name == "tsv"
    assert format_of(tmp_path / "a.txt") is None
    bag = tmp_path / "bag"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("")
    assert format_of(bag).name == "rosbag2"
    (bag / "meta").mkdir()
    (bag / "meta/info.json").write_text("{}")
    assert format_of(bag).name == "lerobot"  # a dataset wins, whatever else its folder holds


def test_a_record_is_told_one_way():
    with pytest.raises(ValueError, match="either endings or a folder"):
        RecordingFormat("x", "x", lambda path, o: [], endings=(".x",), folder="x folder", is_folder=Path.is_dir)
    with pytest.raises(ValueError, match="either endings or a folder"):
        RecordingFormat("x", "x", lambda path, o: [])
