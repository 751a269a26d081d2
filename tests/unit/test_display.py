"""How records look in Jupyter: real HTML tables whose alignment does not depend on the front end's style."""

from __future__ import annotations

from rich.table import Table

from ipyros.ipython.display import table_html


def test_names_are_left_aligned_and_numbers_right_aligned_whatever_the_notebooks_style():
    table = Table(title="2 topics")
    table.add_column("topic")
    table.add_column("rate Hz", justify="right")
    table.add_row("/turtle1/pose", "62.5")
    html = table_html(table)
    assert '<th style="text-align:left">topic</th>' in html and '<td style="text-align:left">/turtle1/pose</td>' in html
    assert '<td style="text-align:right">62.5</td>' in html
