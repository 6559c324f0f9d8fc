"""Terminal tables whose titles and headers are shown as written.

Rich reads square brackets as markup, so a header such as "wrist error [m]" or a
title naming a path would lose its brackets; every table the commands print is
made here.
"""

from __future__ import annotations

from collections.abc import Iterable

from rich.markup import escape
from rich.table import Table


def text_table(title: str, columns: Iterable[str], right: Iterable[str] = ()) -> Table:
    """A Rich table with literal ``title`` and column headers; columns in ``right`` are right-aligned."""
    right = set(right)
    table = Table(title=escape(title))
    for col in columns:
        table.add_column(escape(col), justify="right" if col in right else "left")
    return table
