"""A Markdown table as the Rerun viewer's TextDocument renders it (media type text/markdown)."""

from __future__ import annotations


def markdown_table(header: list[str], rows: list[list]) -> list[str]:
    """The lines of a table of `header` and `rows` (cells as text, `|` escaped so that a cell
    cannot split its row)."""
    def cell(value) -> str:
        return str(value).replace("|", "\\|").replace("\n", " ")

    lines = ["| " + " | ".join(cell(h) for h in header) + " |", "|" + "---|" * len(header)]
    return lines + ["| " + " | ".join(cell(c) for c in row) + " |" for row in rows]
