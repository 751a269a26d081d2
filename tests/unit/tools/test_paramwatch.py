"""What %params --watch tells: each parameter that appeared, changed or went between two looks."""

from __future__ import annotations

from ipyros.tools.paramwatch import ABSENT, changes, watch


def test_changes_are_appeared_changed_and_gone_in_name_order():
    before = {"/n/gain": 1.5, "/n/mode": "auto", "/n/old": 3}
    after = {"/n/gain": 2.5, "/n/mode": "auto", "/n/new": [1, 2]}
    assert changes(before, after) == [("/n/gain", 1.5, 2.5), ("/n/new", ABSENT, [1, 2]), ("/n/old", 3, ABSENT)]
    assert changes(after, after) == []
    assert repr(ABSENT) == "(none)"


def test_watch_tells_each_change_until_the_count():
    looks = iter([{"a": 1}, {"a": 1}, {"a": 2}, {"a": 2, "b": 0}])
    told: list = []
    assert watch(lambda: next(looks), lambda *change: told.append(change), period=0.0, count=2) == 2
    assert told == [("a", 1, 2), ("b", ABSENT, 0)]
