"""Small text helpers for what ipyros says: counts that read as English."""

from __future__ import annotations

__all__ = ["counted"]


def counted(count: int, word: str) -> str:
    """``1 message``, ``3 messages``: a count with its word, plural when it is not one."""
    return f"{count} {word}" if count == 1 else f"{count} {word}s"
