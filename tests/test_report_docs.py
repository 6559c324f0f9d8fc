"""The report's numbers and docs/report.md's list of its sections, each from one home: the builder numbers the
tables in the order the page shows them, and the list is written from the report's list of sections."""

from __future__ import annotations

from pathlib import Path

import pytest

from simtune.common.table import Column, Table
from simtune.report import sections
from simtune.report.sections import APPENDICES, SECTIONS, ReportOutput, ReportSection, docs_section_list

ROOT = Path(__file__).resolve().parents[1]
WRITE = "python -c \"from simtune.report.sections import write_docs; write_docs('docs/report.md')\""


def test_docs_section_list_is_the_reports():
    """docs/report.md lists every section in the report's order, titled as the page titles it, each described."""
    text = (ROOT / "docs/report.md").read_text(encoding="utf-8")
    assert f"-->\n{docs_section_list(text)}<!-- end sections -->" in text, (
        f"docs/report.md's list of the sections is not the report's (SECTIONS, APPENDICES): run {WRITE}"
    )
    assert "not described yet" not in text, "a section of the report has no description in docs/report.md"
    for number, entry in enumerate(SECTIONS, start=1):
        assert f"\n{number}. **{entry.title}**" in text
    for entry in APPENDICES:
        assert f"\n- **{entry.title}**" in text


def _doc(items: str) -> str:
    return f"# Report\n\n<!-- sections: written by write_docs -->\n{items}<!-- end sections -->\nafter\n"


def test_docs_list_is_renumbered_reindented_and_a_new_section_gets_an_item(monkeypatch):
    def shown(data, out):  # the makers are not called
        return "", []

    entries = tuple(ReportSection(a, t, shown) for a, t in [("a", "Alpha"), ("n", "New"), ("b", "Beta")])
    monkeypatch.setattr(sections, "SECTIONS", entries)
    monkeypatch.setattr(sections, "APPENDICES", (ReportSection("z", "Appendix: Z", shown),))
    old = (
        "1. **Beta** (b).\n   body of beta\n\n   ```\n     indented\n   ```\n"
        "2. **Alpha**: alpha.\n- **Appendix: Z** z.\n"
    )
    assert docs_section_list(_doc(old)) == (
        "1. **Alpha**: alpha.\n2. **New**: not described yet.\n"
        "3. **Beta** (b).\n   body of beta\n\n   ```\n     indented\n   ```\n- **Appendix: Z** z.\n"
    )
    ten = tuple(ReportSection(str(k), f"S{k}", shown) for k in range(1, 11))
    monkeypatch.setattr(sections, "SECTIONS", ten)
    numbered = docs_section_list(_doc("1. **S10**: ten,\n   its second line.\n- **Appendix: Z** z.\n"))
    assert "10. **S10**: ten,\n    its second line.\n" in numbered  # indented to its number's width
    # an item the report has no section for is refused, not dropped
    with pytest.raises(ValueError, match="Gone"):
        docs_section_list(_doc("1. **Gone**: text.\n"))


def test_tables_are_numbered_in_the_order_they_are_written(tmp_path):
    (tmp_path / "tables").mkdir()
    out = ReportOutput(tmp_path, warn=lambda message: None)
    first = Table("first", "The first", [Column("x", "d")], [[1]])
    shown = [out.table(first), out.table(Table("second", "The second", [Column("x", "d")], [[2]]))]
    assert [t.title for t in shown] == ["Table 1. The first", "Table 2. The second"]
    assert (tmp_path / "tables" / "second.md").read_text().startswith("## Table 2. The second")
    assert first.title == "The first"  # the table handed in is left as it was
