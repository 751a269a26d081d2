"""Counts that read as English (:mod:`ipyros.core.text`)."""

from ipyros.core.text import counted


def test_one_and_many():
    assert counted(1, "message") == "1 message" and counted(0, "message") == "0 messages"
    assert counted(3, "node") == "3 nodes"
