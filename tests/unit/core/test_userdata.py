"""Data typed by the user or read from a file, read with limits: every refusal one line
(:mod:`ipyros.core.userdata`)."""

from __future__ import annotations

import pytest

from ipyros.core import userdata
from ipyros.core.errors import DataError


def test_a_literal_first_then_yaml():
    assert userdata.literal_or_yaml("{'a': None}", "x") == {"a": None}
    assert userdata.literal_or_yaml("a: null", "x") == {"a": None}
    assert userdata.literal_or_yaml("True", "x") is True and userdata.literal_or_yaml("  ", "x") is None


def test_an_alias_bomb_is_refused_before_it_expands():
    bomb = "a: &a [x, x, x, x, x, x, x, x, x, x]\n" + "".join(
        f"{chr(98 + i)}: &{chr(98 + i)} [{', '.join([f'*{chr(97 + i)}'] * 10)}]\n" for i in range(8))
    with pytest.raises(DataError, match="expands to more than 1,000,000 elements") as caught:
        userdata.load_yaml(bomb, "the model file")
    assert "\n" not in str(caught.value) and "the model file" in str(caught.value)


def test_measure_counts_shared_parts_each_time_and_stops_at_the_limit():
    shared = [1] * 10
    assert userdata.measure([shared] * 5, "x", limit=100) == [shared] * 5
    with pytest.raises(DataError):
        userdata.measure([shared] * 20, "x", limit=100)


@pytest.mark.parametrize("load, text, says", [
    (userdata.load_yaml, "a: [1, 2", "the file is not valid YAML at line 1"),
    (userdata.load_json, '{"a": 1,}', "the file is not valid JSON at line 1"),
    (userdata.load_json, "[" * 100_000 + "]" * 100_000, "the file is nested too deeply to read"),
])
def test_malformed_data_is_one_line_naming_where(load, text, says):
    with pytest.raises(DataError) as caught:
        load(text, "the file")
    assert says in str(caught.value) and "\n" not in str(caught.value), str(caught.value)


def test_text_over_the_limit_is_refused_by_its_size():
    with pytest.raises(DataError, match="is 16,777,217 characters long"):
        userdata.load_yaml("a" * (userdata.MAX_TEXT + 1), "the file")
