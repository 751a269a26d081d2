"""Editing a live handler in place: find it, show its source, swap in the new version.

The flow behind ``%handler nd /turtle1/pose``:

1. the node's engine says what ``/turtle1/pose`` is on ``nd`` (``handlers_of.find_target``: a
   subscription with a handler, a timer or a service) and :func:`handler_source` gets the
   source of the function serving it. ``inspect.getsource`` works for functions typed at an IPython
   prompt, because IPython keeps every cell in ``linecache``; it fails for lambdas
   (whose "source" is the whole line around them), builtins, and code made by ``exec``.
2. The user edits that source and runs it, which rebinds the function's name. An
   :class:`EditWatch`, checked after every cell, sees the name bound to a new function
   and the engine's ``redeclare`` declares the handler again with it: for a subscription that is
   ``nd.new.subscribe(topic, handler=new, msgType=<declared type>)``, the DSL's own
   live swap (one attribute assignment in the handler slot, no message lost).

Nothing here knows about IPython: the magics in :mod:`ipyros.ipython.magics.nodes` drive it.
"""

from __future__ import annotations

import ast
import inspect
import re
import textwrap
import types
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Optional

from ..core.errors import IpyrosError
from ..dsl import engine_of, rosNode
from ..node.engine import HandlerTarget

__all__ = ["EditWatch", "PendingEdit", "handler_source", "lambda_as_def", "new_functions"]


def handler_source(handler: Any, node_name: str, target: HandlerTarget) -> str:
    """The source of ``handler``, dedented, ready to be edited and run again.

    Raises a one-line :class:`IpyrosError` saying why the source cannot be had and what
    to do instead (write the new handler in a ``%%handler`` cell).
    """
    instead = f"write the new one in a cell: %%handler {node_name} {target.name}"
    name = getattr(handler, "__name__", repr(handler))
    if not isinstance(handler, types.FunctionType):
        raise IpyrosError(f"the handler of {target.label} is {type(handler).__name__} {name!r}, not a function "
                          f"defined with def, so it cannot be edited in place; {instead}")
    if name == "<lambda>":
        raise IpyrosError(f"the handler of {target.label} is a lambda, which cannot be edited in place; {instead}")
    try:
        source = inspect.getsource(handler)
    except (OSError, TypeError):
        where = handler.__code__.co_filename
        raise IpyrosError(f"cannot find the source of handler {name} (defined in {where}); {instead}") from None
    return textwrap.dedent(source)


def lambda_as_def(handler: Any, name: str) -> Optional[str]:
    """The lambda ``handler`` written as ``def name(...): return ...``, to edit at the prompt.

    A lambda has no name to rebind, so ``%handler`` offers it as a def under a fresh name.
    Its source is found as ``inspect`` finds any function's (the prompt's cells are in
    ``linecache``); of the lambdas on its line, the one whose body starts where its code
    does. None when the source cannot be had.
    """
    try:
        lines, _ = inspect.findsource(handler)
    except (OSError, TypeError):
        return None
    source = "".join(lines)
    try:
        tree = ast.parse(source)
    except SyntaxError:
        return None
    code = handler.__code__
    starts = {(line, column) for line, _, column, _ in code.co_positions() if line is not None}
    found = [n for n in ast.walk(tree) if isinstance(n, ast.Lambda) and n.lineno == code.co_firstlineno]
    lam = next((n for n in found if (n.body.lineno, n.body.col_offset) in starts), found[0] if found else None)
    body = ast.get_source_segment(source, lam.body) if lam is not None else None
    if lam is None or body is None:
        return None
    return f"def {name}({ast.unparse(lam.args)}):\n    return {body}\n"


def fresh_name(target: HandlerTarget, taken: Mapping[str, Any]) -> str:
    """A name for the def a lambda handler of ``target`` becomes: on_<last part>, unused in ``taken``."""
    last = target.name.rsplit("/", 1)[-1]
    base = f"on_{target.kind}" if last == "<lambda>" else f"on_{re.sub(r'[^0-9A-Za-z_]', '_', last)}"
    name, number = base, 2
    while name in taken:
        name, number = f"{base}_{number}", number + 1
    return name


def new_functions(before: Mapping[str, Any], after: Mapping[str, Any]) -> dict[str, types.FunctionType]:
    """The names ``after`` binds to a function they were not bound to in ``before``."""
    return {name: value for name, value in after.items()
            if isinstance(value, types.FunctionType) and before.get(name) is not value}


@dataclass
class PendingEdit:
    """A handler shown for editing; swapped when ``name`` is bound to another function."""

    node: rosNode
    target: HandlerTarget
    name: str
    old: Optional[Callable[..., Any]]  # None: a relayed topic, which the new function takes over


@dataclass
class EditWatch:
    """The handlers being edited; :meth:`check` after each cell swaps in the redefined ones."""

    pending: list[PendingEdit] = field(default_factory=list)

    def expect(self, edit: PendingEdit) -> None:
        """Watch ``edit.name``; replaces an earlier edit of the same target."""
        self.forget(edit.node, edit.target)
        self.pending.append(edit)

    def forget(self, node: rosNode, target: HandlerTarget) -> None:
        self.pending = [e for e in self.pending if not (e.node is node and e.target == target)]

    def check(self, user_ns: Mapping[str, Any]) -> list[str]:
        """Swap every handler whose name now holds a new function; one line of news per swap.

        An edit stays pending until its name is rebound; it is dropped without a swap if
        the node's handler was changed some other way meanwhile (e.g. by the same cell).
        """
        news = []
        for edit in list(self.pending):
            new = user_ns.get(edit.name)
            if new is None or new is edit.old:
                continue
            self.pending.remove(edit)
            where = f"{edit.node.name} {edit.target.label}"
            if edit.node.handler(edit.target.name) is not edit.old:
                continue
            if not callable(new):
                news.append(f"{edit.name} is now a {type(new).__name__}, not a function; "
                            f"{where} keeps its handler")
                continue
            try:
                engine_of(edit.node).handlers_of.redeclare(edit.target, new)
            except IpyrosError as error:
                news.append(f"{where} keeps its handler: {error}")
                continue
            news.append(f"{where} is now handled by the new {edit.name}")
        return news
