"""The magics reference, read from the magics' own argument parsers so that it cannot drift from them.

Every magic is declared once, with ``@magic_arguments`` and :func:`ipyros.ipython.arguments.argument`
(usage, options, help, completion). The guide's reference page (``docs/magics-reference.rst``) and
``%magic?`` both come from that one declaration: :func:`entries` reads each registered ``Magics``
class, and each :class:`MagicEntry` lays itself out as plain text blocks (``title``, ``blocks()``) for whoever
draws it (the Sphinx directive in ``docs/_ext``; a test).
"""

from __future__ import annotations

import argparse
import textwrap
from dataclasses import dataclass
from typing import Iterable, Optional

from . import magics as _magics

__all__ = ["MagicEntry", "Option", "entries", "magics_classes"]


@dataclass(frozen=True)
class Option:
    """One argument of a magic: how it is written (``-r RATE``, ``topic``) and what it does."""

    spelling: str
    help: str
    positional: bool


@dataclass(frozen=True)
class MagicEntry:
    """One magic: its name, whether it is a line and/or cell magic, usage, what it does, its arguments."""

    name: str
    kinds: tuple[str, ...]  # ("line",), ("cell",) or ("line", "cell")
    owner: str  # the Magics class that declares it
    usage: str
    description: str
    options: tuple[Option, ...]

    @property
    def title(self) -> str:
        return " / ".join(("%" if kind == "line" else "%%") + self.name for kind in self.kinds)

    def blocks(self) -> list[tuple[str, str]]:
        """The description as (kind, text) blocks: "text" paragraphs and "code" (its indented examples)."""
        out: list[tuple[str, str]] = []
        for chunk in self.description.split("\n\n"):
            if not chunk.strip():
                continue
            lines = chunk.split("\n")
            if all(line.startswith("    ") or not line.strip() for line in lines):
                out.append(("code", textwrap.dedent(chunk).strip("\n")))
            else:
                out.append(("text", " ".join(line.strip() for line in lines)))
        return out


def magics_classes() -> list[type]:
    """The ``Magics`` classes the extension registers (:mod:`ipyros.ipython.magics` lists each once)."""
    return [getattr(_magics, name) for name in _magics.__all__]


def entries(classes: Optional[Iterable[type]] = None) -> list[MagicEntry]:
    """Every magic of ``classes`` (default: all of ipyros's), sorted by name, a line and a cell magic of
    one name (``%pub`` and ``%%pub``) as one entry."""
    found: dict[str, MagicEntry] = {}
    for cls in magics_classes() if classes is None else classes:
        for kind in ("line", "cell"):
            for name, method_name in cls.magics.get(kind, {}).items():
                if name in found:
                    entry = found[name]
                    found[name] = MagicEntry(entry.name, (*entry.kinds, kind), entry.owner, entry.usage,
                                             entry.description, entry.options)
                    continue
                found[name] = _entry(name, kind, cls, getattr(cls, method_name))
    return [found[name] for name in sorted(found)]


def _entry(name: str, kind: str, cls: type, method: object) -> MagicEntry:
    parser: Optional[argparse.ArgumentParser] = getattr(method, "parser", None)
    if parser is None:  # every ipyros magic declares its arguments; a plain one still gets its docstring
        doc = textwrap.dedent(getattr(method, "__doc__", "") or "").strip()
        return MagicEntry(name, (kind,), cls.__name__, f"%{name}", doc, ())
    usage = " ".join(parser.format_usage().replace("::", "").split())
    description = textwrap.dedent(_dedent_tail(parser.description or "")).strip()
    options = tuple(_option(action) for action in parser._actions if action.help != argparse.SUPPRESS)
    return MagicEntry(name, (kind,), cls.__name__, usage, description, options)


def _dedent_tail(doc: str) -> str:
    """A docstring's first line has no indent and the rest has the method's: make them one."""
    first, _, rest = doc.partition("\n")
    return first + "\n" + textwrap.dedent(rest)


def _option(action: argparse.Action) -> Option:
    help_text = " ".join((action.help or "").replace("%%", "%").split())
    if not action.option_strings:
        return Option(action.metavar or action.dest, help_text, True)
    takes = action.nargs != 0
    value = f" {action.metavar or action.dest.upper()}" if takes else ""
    return Option(", ".join(f"{flag}{value}" for flag in action.option_strings), help_text, False)
