"""Data typed by the user or read from a file (YAML, JSON, Python literals), read with limits.

YAML anchors make a small text stand for a huge value: 1.4 kB of ``&a [1, ...]``,
``&b [*a, ...]`` is ten million elements once expanded. PyYAML shares the aliased
objects, so loading is quick, but whatever walks the value afterwards (building a
message, sending a parameter over XML-RPC, saving it) walks every copy, and the prompt
froze for twenty seconds. So everything read here is measured as it will be walked,
aliases counted every time they are used, and refused in one line beyond a limit no
ROS message or parameter comes near. Deep nesting (a RecursionError inside the parser)
is one line too.

Nothing here runs code: YAML is read with PyYAML's safe loader (no Python tags), Python
literals with :func:`ast.literal_eval`.
"""

from __future__ import annotations

import ast
import json
from typing import Any

import yaml

from .errors import DataError

__all__ = ["MAX_ELEMENTS", "MAX_TEXT", "load_json", "load_yaml", "literal_or_yaml", "measure"]

#: The most elements (scalars, list items, mapping entries) a value may expand to.
MAX_ELEMENTS = 1_000_000
#: The longest text read (characters): a model file with its handlers' sources is far below it.
MAX_TEXT = 16 * 1024 * 1024


def measure(value: Any, what: str, limit: int = MAX_ELEMENTS) -> Any:
    """``value`` if it expands to at most ``limit`` elements (shared parts counted each time), else a
    :class:`DataError`. Stops counting at the limit, so measuring a bomb costs no more than that."""
    count, stack = 0, [value]
    while stack:
        item = stack.pop()
        count += 1
        if count > limit:
            raise DataError(f"{what} expands to more than {limit:,} elements (YAML aliases, *name, repeat what "
                            "they name each time they are used); give the data without them")
        if isinstance(item, dict):
            stack.extend(item.keys())
            stack.extend(item.values())
        elif isinstance(item, (list, tuple)):
            stack.extend(item)
    return value


def _sized(text: str, what: str) -> str:
    if len(text) > MAX_TEXT:
        raise DataError(f"{what} is {len(text):,} characters long, more than the {MAX_TEXT:,} ipyros reads")
    return text


def _too_deep(what: str) -> DataError:
    return DataError(f"{what} is nested too deeply to read (no ROS message or parameter nests like that)")


def load_yaml(text: str, what: str) -> Any:
    """YAML ``text`` as data (safe loader), measured; a one-line :class:`DataError` naming ``what`` if bad."""
    try:
        return measure(yaml.safe_load(_sized(text, what)), what)
    except RecursionError:
        raise _too_deep(what) from None
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(error, "problem", None) or str(error).splitlines()[0]
        raise DataError(f"{what} is not valid YAML{where}: {problem}") from None


def load_json(text: str, what: str) -> Any:
    """JSON ``text`` as data, measured; a one-line :class:`DataError` naming ``what`` if bad."""
    try:
        return measure(json.loads(_sized(text, what)), what)
    except RecursionError:
        raise _too_deep(what) from None
    except json.JSONDecodeError as error:
        raise DataError(f"{what} is not valid JSON at line {error.lineno}: {error.msg}") from None


def literal_or_yaml(text: str, what: str) -> Any:
    """A Python literal if ``text`` is one (``{'data': 'x'}``, ``True``, ``None``), else YAML; empty gives None."""
    text = _sized(text.strip(), what)
    if not text:
        return None
    try:
        return measure(ast.literal_eval(text), what)
    except (ValueError, SyntaxError, TypeError, MemoryError, RecursionError):
        pass
    return load_yaml(text, what)

