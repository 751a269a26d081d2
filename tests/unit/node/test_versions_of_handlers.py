"""Every function a handler slot was given, and which serves now (:mod:`ipyros.node.versions`)."""

from __future__ import annotations

import pytest

from ipyros.core.errors import DeclarationError, NotDeclaredError
from ipyros.node.versions import HandlerVersions, parse_versions


def first(msg):
    return 1


def second(msg):
    return 2


def test_each_new_function_is_a_version_and_the_pending_one_is_told_once():
    kept = HandlerVersions()
    kept.given("topic /x", first)
    kept.given("topic /x", second)
    found, current = kept.of("topic /x")
    assert [v.name for v in found] == ["first", "second"] and current == 2
    slot, version = kept.take_pending()
    assert (slot, version.number) == ("topic /x", 2) and kept.take_pending() is None


def test_a_revert_brings_an_old_version_back_without_a_new_one():
    kept = HandlerVersions()
    kept.given("timer t", first)
    kept.given("timer t", second)
    chosen = kept.choose("timer t", 1, "n timer t", "nd.versions('t')", dict)
    assert chosen.function is first
    kept.reverting = 1
    kept.given("timer t", first)
    assert kept.of("timer t") == (kept.of("timer t")[0], 1) and len(kept.of("timer t")[0]) == 2


@pytest.mark.parametrize("number", [0, 3, True, "1"])
def test_a_version_that_is_not_there_is_one_line(number):
    kept = HandlerVersions()
    kept.given("s", first)
    kept.given("s", second)
    with pytest.raises(NotDeclaredError, match=r"n s has versions 1 to 2, not .*; nd.versions\('s'\) lists them"):
        kept.choose("s", number, "n s", "nd.versions('s')", dict)


def test_a_version_read_from_a_file_is_compiled_when_chosen():
    restored, current = parse_versions("x", [("2026-11-21 10:00:00", "def h(msg):\n    return GAIN\n"),
                                             ("2026-11-21 10:05:00", "def h(msg):\n    return 0\n")], None)
    kept = HandlerVersions()
    kept.set("topic /x", restored, current)
    assert current == 2 and kept.choose("topic /x", 1, "n /x", "", lambda: {"GAIN": 7}).function(None) == 7


@pytest.mark.parametrize("versions, current, says", [
    ([], None, "current=0 is not one of the 0 versions given"),
    ([("t", "def h(m): pass")], 2, "current=2 is not one of the 1 versions given"),
    ([("t", "")], 1, "version 1 is not (time, source text)"),
])
def test_a_past_given_wrong_is_one_line(versions, current, says):
    with pytest.raises(DeclarationError, match=says.replace("(", r"\(").replace(")", r"\)")):
        parse_versions("x", versions, current)


def test_a_snapshot_and_back():
    kept = HandlerVersions()
    kept.given("s", first)
    saved = kept.snapshot()
    kept.given("s", second)
    kept.restore(saved)
    assert [v.name for v in kept.of("s")[0]] == ["first"] and kept.take_pending() is None
