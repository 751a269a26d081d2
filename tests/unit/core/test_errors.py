"""ipyros's errors: one line each, whatever value they quote (:mod:`ipyros.core.errors`)."""

from __future__ import annotations

import pytest

from ipyros.core import errors


def test_a_short_message_is_kept_as_it_is():
    text = "no node /x is running in this session (running: none)"
    assert errors.shorten(text) == text
    assert str(errors.NotDeclaredError(text)) == text


def test_a_long_word_is_cut_to_its_start_and_its_size():
    name = "/" + "a" * 6_000
    text = errors.shorten(f"invalid topic name {name}: give a shorter one, e.g. '/cmd_vel'")
    assert text.startswith("invalid topic name /aaaa") and "... (6,001 characters)" in text
    assert text.endswith(": give a shorter one, e.g. '/cmd_vel'") and len(text) < 200, text


def test_many_short_words_are_cut_in_the_middle_keeping_the_end_that_says_what_to_do():
    text = errors.shorten("basenode /sleep exited with code 1 at start; last log lines: starting: /bin/sleep "
                          + "1 " * 100_000 + "| sleep: invalid time interval")
    assert len(text) <= errors.LONGEST + 60, len(text)
    assert "characters cut" in text and text.endswith("| sleep: invalid time interval"), text[-80:]


@pytest.mark.parametrize("cls", [errors.IpyrosError, errors.DeclarationError, errors.BaseNodeError,
                                 errors.TopicNameError])
def test_every_ipyros_error_is_shortened_and_stays_one_line(cls):
    error = cls("bad value " + "x" * 200_000 + " ; do this instead")
    assert len(str(error)) < 300 and str(error).endswith("; do this instead")
    assert "\n" not in str(error)


def test_an_error_made_from_another_keeps_its_type_and_its_shortened_text():
    first = errors.MessageTypeError("y" * 10_000)
    again = type(first)(f"call 2 of the chain failed: {first}")
    assert isinstance(again, errors.MessageTypeError) and len(str(again)) < 300


def test_cut_quotes_a_value_on_one_line_with_its_size():
    assert errors.cut("short") == "'short'"
    long = errors.cut(["x"] * 1_000)
    assert long.endswith("(5,000 characters)") and len(long) < 100
    assert "\n" not in errors.cut("a\nb" * 100)


def test_first_line_of_a_library_error():
    assert errors.first_line(ValueError("Invalid name:\n  'a b'\n   ^")) == "Invalid name"
    assert errors.first_line(RuntimeError()) == "RuntimeError"


def test_did_you_mean():
    assert errors.did_you_mean("cmd_vell", ["cmd_vel", "odom"]) == "did you mean cmd_vel?"
    assert errors.did_you_mean("zzz", ["cmd_vel"]) == ""
