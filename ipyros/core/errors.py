"""Errors that ipyros raises for bad input or a broken ROS graph.

Every error is one line that says what is wrong and what to do about it. Inside
IPython the extension shows only that line (no traceback); outside IPython they are
ordinary exceptions. Each subclass is also a ``ValueError``/``RuntimeError`` where
that is what it is, so generic code can still catch them the usual way.
"""

from __future__ import annotations

import re
import types
from typing import Optional, Sequence


#: The most characters an error or notice line keeps: past it, the values quoted in it are cut (see :func:`shorten`).
LONGEST = 600


class IpyrosError(Exception):
    """Base class: a one-line, actionable message about something the user asked for.

    Its message is :func:`shorten`-ed: whatever value a message quotes (100,000 arguments, a name of
    5,000 characters), the line stays readable.
    """

    def __init__(self, *args: object) -> None:
        if len(args) == 1 and isinstance(args[0], str):
            args = (shorten(args[0]),)
        super().__init__(*args)


class DeclarationError(IpyrosError, ValueError):
    """A DSL declaration was rejected; nothing already running was changed."""


class MessageTypeError(DeclarationError):
    """A message or service type is unknown, malformed, or not the one expected."""


class TopicNameError(DeclarationError):
    """A topic, service or parameter name is not a valid ROS name."""


class HandlerError(DeclarationError):
    """A handler is not callable or does not take the arguments it will be given."""


class TopicTypeConflict(MessageTypeError):
    """The declared type differs from the type the live topic already has."""


class DataError(DeclarationError):
    """Data typed or read from a file cannot be read (malformed, nested too deeply, too large)."""


class NotDeclaredError(IpyrosError, LookupError):
    """The node does not have the topic, timer or service that was named."""


class MasterError(IpyrosError, RuntimeError):
    """No ROS master could be reached or started."""


class BaseNodeError(IpyrosError, RuntimeError):
    """The basenode could not be found, started, or kept running."""


class NodeStateError(IpyrosError, RuntimeError):
    """The node is not in a state where this operation makes sense (e.g. shut down)."""


def cut(value: object, limit: int = 80) -> str:
    """``repr(value)`` on one line, cut to about ``limit`` characters: what an error line may quote of a value."""
    text = " ".join(repr(value).split())
    return text if len(text) <= limit else f"{text[:limit - 20]}... ({len(text):,} characters)"


def shorten(text: str, longest: int = LONGEST) -> str:
    """``text`` cut to about ``longest`` characters, saying how much was cut: first each run of over 100 characters
    without a space (a long name, a path, a value) to its start and its size, then, if the line is still too long
    (a list of 100,000 short words), its middle; the end, which says what to do, stays whole."""
    if len(text) <= longest:
        return text
    text = re.sub(r"(\S{101,}?)([:;,.)'\"]*)(?=\s|$)",
                  lambda word: f"{word[1][:60]}... ({len(word[1]):,} characters){word[2]}", text)
    if len(text) <= longest:
        return text
    keep_end = longest // 3
    head, tail = text[:longest - keep_end - 40], text[-keep_end:]
    return f"{head} ... ({len(text) - len(head) - len(tail):,} characters cut) ... {tail}"


def first_line(error: BaseException) -> str:
    """An exception of a library as one line: its first line (rclpy's name errors draw a caret below the name)."""
    lines = [line.strip() for line in str(error).splitlines() if line.strip()]
    return (lines[0].rstrip(":") if lines else type(error).__name__)[:300]


def did_you_mean(word: str, candidates: "Sequence[str]") -> str:
    """``did you mean a or b?`` for the candidates close to ``word``, else ``""``."""
    import difflib

    close = difflib.get_close_matches(word, candidates, n=3, cutoff=0.6)
    return f"did you mean {' or '.join(close)}?" if close else ""


def warn_user(message: str, category: type[Warning]) -> None:
    """``warnings.warn`` attributed to the user's own line: the first caller outside ipyros and IPython.

    A fixed ``stacklevel`` is right for one path only: ``nd.save()`` typed at the prompt and
    ``%save_nodes`` reach the same code through different depths, and the magic's warning
    pointed into IPython's own file.
    """
    import sys
    import warnings

    frame: Optional[types.FrameType] = sys._getframe(1)
    level = 2  # stacklevel 2: the caller of warn_user
    while frame is not None and _internal(frame.f_code.co_filename):
        frame, level = frame.f_back, level + 1
    warnings.warn(message, category, stacklevel=level)


def _internal(filename: str) -> bool:
    import os

    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__))) + os.sep  # the package, ipyros/
    return (filename.startswith(here) or f"{os.sep}IPython{os.sep}" in filename
            or filename.startswith("<decorator-gen"))
