"""The self-contained ``index.html``: figures embedded as base64 PNG, tables inline, links to the files."""

from __future__ import annotations

import base64
import html
from dataclasses import dataclass, field

from simtune.common.table import Table
from simtune.report.folder import generator_tag

LONG_TABLE = 40  # rows; longer tables start folded

CSS = """
body { font-family: -apple-system, "Segoe UI", Helvetica, Arial, sans-serif; color: #1b1b1b; margin: 0;
       background: #f6f7f9; line-height: 1.45; }
main { max-width: 1280px; margin: 0 auto; padding: 24px 32px 64px; background: #fff; }
h1 { margin: 0 0 4px; font-size: 1.7em; }
h2 { margin-top: 2.2em; padding-bottom: 4px; border-bottom: 2px solid #dfe3ea; }
h3 { margin: 1.4em 0 0.3em; font-size: 1.05em; }
p.meta { color: #555; margin: 0 0 1em; font-size: 0.92em; }
p.note { color: #444; font-size: 0.9em; margin: 0.2em 0 0.6em; max-width: 1100px; }
nav ol { columns: 2; font-size: 0.95em; }
.warnings { background: #fff7e0; border: 1px solid #e8c66a; border-radius: 4px; padding: 8px 16px; }
.warnings li { font-family: ui-monospace, Menlo, Consolas, monospace; font-size: 0.85em; }
.scroll { overflow-x: auto; max-width: 100%; }
table.data { border-collapse: collapse; font-size: 0.85em; margin: 4px 0 8px; }
table.data th, table.data td { border: 1px solid #d5d9e0; padding: 3px 8px; text-align: left; vertical-align: top; }
table.data th { background: #eef1f6; position: sticky; top: 0; }
table.data td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
table.data tbody tr:nth-child(even) { background: #fafbfc; }
figure { margin: 12px 0 28px; }
figure img { max-width: 100%; height: auto; border: 1px solid #e3e6eb; }
figcaption { font-size: 0.9em; color: #333; margin-top: 4px; }
a.file { font-size: 0.85em; margin-right: 10px; }
details > summary { cursor: pointer; color: #245; margin: 4px 0; }
"""


@dataclass
class FigureRef:
    stem: str  # figures/<stem>.png and .svg
    png: bytes
    caption: str


@dataclass
class Section:
    anchor: str
    title: str
    intro: str = ""
    items: list = field(default_factory=list)  # Table | FigureRef | str (HTML fragment)


def table_html(table: Table) -> str:
    links = (
        f'<a class="file" href="tables/{table.name}.csv">CSV</a>'
        f'<a class="file" href="tables/{table.name}.md">Markdown</a>'
    )
    body = f'<div class="scroll">{table.to_html()}</div>'
    if len(table.rows) > LONG_TABLE:
        body = f"<details><summary>show all {len(table.rows)} rows</summary>{body}</details>"
    note = f'<p class="note">{html.escape(table.note)}</p>' if table.note else ""
    return f'<h3 id="table-{table.name}">{html.escape(table.title)}</h3>{note}{body}<div>{links}</div>'


def figure_html(fig: FigureRef) -> str:
    data = base64.b64encode(fig.png).decode("ascii")
    return (
        f'<figure id="figure-{fig.stem}"><img alt="{html.escape(fig.caption)}" '
        f'src="data:image/png;base64,{data}"><figcaption>{html.escape(fig.caption)} '
        f'<a class="file" href="figures/{fig.stem}.png">PNG</a>'
        f'<a class="file" href="figures/{fig.stem}.svg">SVG</a></figcaption></figure>'
    )


def render(title: str, meta: list[str], warnings: list[str], sections: list[Section]) -> str:
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        generator_tag(),  # marks the page as simtune's, should the folder lose its manifest
        f"<title>{html.escape(title)}</title><style>{CSS}</style></head><body><main>",
        f"<h1>{html.escape(title)}</h1>",
    ]
    parts += [f'<p class="meta">{html.escape(line)}</p>' for line in meta]
    if warnings:
        parts.append(
            '<div class="warnings"><strong>Warnings</strong> (runs or files left out of the report, '
            "and doubts about what it shows):<ul>"
        )
        parts += [f"<li>{html.escape(w)}</li>" for w in warnings]
        parts.append("</ul></div>")
    parts.append(
        "<nav><ol>"
        + "".join(f'<li><a href="#{s.anchor}">{html.escape(s.title)}</a></li>' for s in sections)
        + "</ol></nav>"
    )
    for s in sections:
        parts.append(f'<section id="{s.anchor}"><h2>{html.escape(s.title)}</h2>')
        if s.intro:
            parts.append(f'<p class="note">{s.intro}</p>')
        for item in s.items:
            if isinstance(item, Table):
                parts.append(table_html(item))
            elif isinstance(item, FigureRef):
                parts.append(figure_html(item))
            else:
                parts.append(str(item))
        parts.append("</section>")
    parts.append("</main></body></html>")
    return "\n".join(parts) + "\n"
