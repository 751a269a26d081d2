"""A table as plain data, and as plain text: what a record shows, whoever prints it.

A record (:mod:`ipyros.core.records`) says what its table holds: a title, columns, rows of
text, a style word on the cells that should stand out. ``print(nd.status())`` in a script or
a handler shows it as aligned text (:meth:`TextTable.text`); the IPython face draws the same
table with rich in a terminal and as HTML in Jupyter (:func:`ipyros.ipython.display.rich_table`),
so the two never tell different things.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Union

__all__ = ["Cell", "Column", "TextTable"]


@dataclass(frozen=True)
class Column:
    name: str
    right: bool = False  # numbers are aligned right
    fold: bool = False  # long text wraps in its cell (rich) instead of widening the table


@dataclass(frozen=True)
class Cell:
    """A cell that stands out: ``style`` is a rich style word (``"red"``, ``"dim"``, ``"bold yellow"``)."""

    text: str
    style: str = ""

    def __str__(self) -> str:
        return self.text


@dataclass(frozen=True)
class TextTable:
    """A title, its columns, and its rows; ``sections``: the rows a new section starts at (a rule above)."""

    title: str
    columns: tuple[Column, ...]
    rows: tuple[tuple[Union[str, Cell], ...], ...]
    sections: tuple[int, ...] = field(default=())

    def text(self) -> str:
        """The table as aligned plain text, a line a row (a cell's own lines go below it in its column)."""
        grid = [[str(cell).splitlines() or [""] for cell in row] for row in self.rows]
        headers = [column.name for column in self.columns]
        widths = [max([len(header), *(len(line) for row in grid for line in row[i])])
                  for i, header in enumerate(headers)]

        def line(cells: list[str]) -> str:
            return "  ".join(cell.rjust(width) if column.right else cell.ljust(width)
                             for cell, width, column in zip(cells, widths, self.columns)).rstrip()

        out = [self.title, line(headers), line(["-" * width for width in widths])]
        for number, row in enumerate(grid):
            if number in self.sections:
                out.append(line(["-" * width for width in widths]))
            for depth in range(max(len(cell) for cell in row)):
                out.append(line([cell[depth] if depth < len(cell) else "" for cell in row]))
        return "\n".join(out)
