"""A named table of plain rows, written as CSV (full precision), Markdown and HTML (rounded).

Used by ``simtune report`` and by the commands whose results it shows (``simtune
sensitivity``); it sits below both, so neither imports the other for it.
"""

from __future__ import annotations

import csv
import html
import io
import math
from dataclasses import dataclass, field


@dataclass
class Column:
    name: str
    fmt: str = ""  # format spec for Markdown/HTML ("" -> str()); CSV always keeps full precision


@dataclass
class Table:
    """A named table: ``rows`` are lists of str / int / float / None, one per column."""

    name: str  # file stem: tables/<name>.csv, tables/<name>.md
    title: str
    columns: list[Column]
    rows: list[list]
    note: str = ""
    highlight: set[tuple[int, int]] = field(default_factory=set)  # (row, column) cells to show in bold

    @property
    def headers(self) -> list[str]:
        return [c.name for c in self.columns]

    # --- output ------------------------------------------------------------------------------
    def cell(self, value, col: Column) -> str:
        """``value`` as shown in Markdown and HTML."""
        if value is None or (isinstance(value, float) and math.isnan(value)):
            return "-"
        if isinstance(value, bool):
            return "yes" if value else "no"
        if isinstance(value, (int, float)) and col.fmt:
            return format(value, col.fmt)
        return str(value)

    def to_csv(self) -> str:
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(self.headers)
        for row in self.rows:
            writer.writerow(["" if v is None else repr(v) if isinstance(v, float) else v for v in row])
        return buf.getvalue()

    def to_markdown(self) -> str:
        def esc(text: str) -> str:
            return text.replace("|", "\\|").replace("\n", " ")

        lines = [f"## {esc(self.title)}", ""]
        if self.note:
            lines += [esc(self.note), ""]
        lines.append("| " + " | ".join(esc(h) for h in self.headers) + " |")
        lines.append("|" + "|".join("---" if c.fmt == "" else "---:" for c in self.columns) + "|")
        for i, row in enumerate(self.rows):
            cells = []
            for j, (v, c) in enumerate(zip(row, self.columns)):
                text = esc(self.cell(v, c))
                cells.append(f"**{text}**" if (i, j) in self.highlight else text)
            lines.append("| " + " | ".join(cells) + " |")
        return "\n".join(lines) + "\n"

    def to_html(self) -> str:
        head = "".join(f"<th>{html.escape(h)}</th>" for h in self.headers)
        body = []
        for i, row in enumerate(self.rows):
            cells = []
            for j, (v, c) in enumerate(zip(row, self.columns)):
                cls = ' class="num"' if c.fmt and isinstance(v, (int, float)) else ""
                text = html.escape(self.cell(v, c))
                if (i, j) in self.highlight:
                    text = f"<strong>{text}</strong>"
                cells.append(f"<td{cls}>{text}</td>")
            body.append("<tr>" + "".join(cells) + "</tr>")
        return f'<table class="data"><thead><tr>{head}</tr></thead><tbody>' + "".join(body) + "</tbody></table>"
