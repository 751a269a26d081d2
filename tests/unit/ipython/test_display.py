"""How records look in Jupyter: real HTML tables whose alignment does not depend on the front end's style."""

from __future__ import annotations

from rich.table import Table

from ipyros.ipython.display import LARGE_TABLE, is_large, render_html, render_plain, table_html, table_text


def test_names_are_left_aligned_and_numbers_right_aligned_whatever_the_notebooks_style():
    table = Table(title="2 topics")
    table.add_column("topic")
    table.add_column("rate Hz", justify="right")
    table.add_row("/turtle1/pose", "62.5")
    html = table_html(table)
    assert '<th style="text-align:left">topic</th>' in html and '<td style="text-align:left">/turtle1/pose</td>' in html
    assert '<td style="text-align:right">62.5</td>' in html


def large_topics_table(rows: int) -> Table:
    table = Table(title=f"{rows} live topics at here", caption="< N: one message per publisher")
    table.add_column("topic")
    table.add_column("type")
    table.add_column("rate Hz", justify="right")
    for i in range(rows):
        table.add_row(f"/bench/t{i:05d}", "[red]std_msgs/String[/]" if i == 7 else "std_msgs/String", f"{i % 100}")
    return table


def test_a_large_table_is_aligned_plain_text_with_every_row_title_and_caption():
    table = large_topics_table(LARGE_TABLE + 1)
    assert is_large(table) and not is_large(large_topics_table(LARGE_TABLE))
    lines = table_text(table).splitlines()
    assert lines[0] == f"{LARGE_TABLE + 1} live topics at here" and lines[-1] == "< N: one message per publisher"
    assert lines[1].split() == ["topic", "type", "rate", "Hz"]
    rows = lines[3:-1]
    assert len(rows) == LARGE_TABLE + 1
    assert rows[7].split() == ["/bench/t00007", "std_msgs/String", "7"]  # markup gone, text kept
    assert len({len(row) for row in rows}) == 1  # right-aligned numbers: every row as wide
    assert render_plain(table) == table_text(table)  # what Jupyter's text/plain and one-line messages get
    assert render_html(table).startswith("<pre") and "/bench/t00200" in render_html(table)
