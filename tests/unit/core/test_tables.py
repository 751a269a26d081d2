"""A table as plain data and as aligned text (:mod:`ipyros.core.tables`)."""

from __future__ import annotations

from ipyros.core.tables import Cell, Column, TextTable


def test_columns_are_aligned_numbers_right_and_a_styled_cell_shows_its_text():
    table = TextTable("status of /n", (Column("name"), Column("calls", right=True)),
                      (("/a", "3"), ("/long/topic", Cell("120", "red"))))
    assert table.text().splitlines() == [
        "status of /n",
        "name         calls",
        "-----------  -----",
        "/a               3",
        "/long/topic    120",
    ]


def test_a_cell_of_several_lines_goes_on_below_in_its_column_and_sections_get_a_rule():
    table = TextTable("t", (Column("a"), Column("b")), (("x", "one\ntwo"), ("y", "z")), sections=(1,))
    assert table.text().splitlines() == ["t", "a  b", "-  ---", "x  one", "   two", "-  ---", "y  z"]


def test_an_empty_cell_row_is_one_line():
    assert TextTable("t", (Column("a"),), (("",),)).text().split("\n") == ["t", "a", "-", ""]
