"""A handler as code: its source, the globals it reads, and how a file can give them back.

The model (:mod:`ipyros.core.model`) is plain data, but handlers are live functions. What
keeps them is their *source*, as ``inspect.getsource`` finds it (which works for functions
typed at an IPython prompt: IPython keeps every cell in ``linecache``), and what their
source needs from outside: :class:`Bindings` sorts a handler's globals into imports, plain
literals and helper functions, which a saved file or an export writes back. Saving a model
file, saving a session as Python and exporting all stand on this.
"""

from __future__ import annotations

import ast
import builtins
import contextlib
import dis
import inspect
import linecache
import re
import sys
import textwrap
import types
from dataclasses import dataclass, field
from typing import Any, Callable, Iterable, Iterator, Optional

from . import plan as planning
from .errors import IpyrosError, cut
from .model import NodeModel

__all__ = ["WRITER", "Bindings", "define_function", "global_names", "handler_slots", "handler_source", "import_of",
           "import_statement", "lookup"]

_MISSING: Any = object()
#: A name the handlers call ``<name>.write(...)`` on: the node they were written for.
WRITER = re.compile(r"(?<![\w.])([A-Za-z_]\w*)\s*\.\s*write\s*\(")


def handler_slots(model: NodeModel) -> Iterator[tuple[str, str]]:
    """``(slot key, label)`` of every handler the model declares, in declaration order."""
    for t in model.topics:
        if t.role == "new" and t.direction == "subscribe":
            yield planning.topic_slot(t.resolved), f"subscription {t.resolved}"
    for timer in model.timers:
        yield planning.timer_slot(timer.name), f"timer {timer.name}"
    for s in model.services:
        if s.role == "new":
            yield planning.service_slot(s.resolved), f"service {s.resolved}"
    for a in model.actions:
        if a.role == "new":
            yield planning.action_slot(a.resolved), f"action {a.resolved}"


def handler_source(fn: Any, label: str, namespace: Optional[dict] = None) -> str:
    """The source of handler ``fn``: a dedented ``def``, or the expression of a lambda.

    A method of a list, dict or set that ``namespace`` holds by a name (``handler=poses.append``,
    the README's first lines) is kept as the lambda that calls it: ``lambda msg: poses.append(msg)``.
    """
    name = getattr(fn, "__name__", type(fn).__name__)
    give_def = f"give the handler of {label} a def (def handler(msg): ...) and declare it again"
    if not isinstance(fn, types.FunctionType):
        held = container_of(fn, namespace)
        if held is not None:
            return f"lambda msg: {held[0]}.{name}(msg)\n"
        raise IpyrosError(f"the handler of {label} is {type(fn).__name__} {name!r}, which has no source to keep; "
                          + give_def)
    try:
        source = textwrap.dedent(inspect.getsource(fn))
    except (OSError, TypeError):
        raise IpyrosError(f"cannot find the source of handler {name} for {label} (defined in "
                          f"{fn.__code__.co_filename}); {give_def}") from None
    return source if name != "<lambda>" else _lambda_expression(fn, source, label, give_def)


def container_of(fn: Any, namespace: Optional[dict]) -> Optional[tuple[str, Any]]:
    """For a handler that is a method of a list, dict or set (``poses.append``): the name ``namespace`` holds
    that container by, and the container; else None."""
    owner = getattr(fn, "__self__", None)
    if namespace is None or type(owner) not in (list, dict, set):
        return None
    name = next((k for k, v in list(namespace.items()) if v is owner and k.isidentifier() and not k.startswith("_")),
                None)
    return (name, owner) if name else None


def _lambda_expression(fn: types.FunctionType, text: str, label: str, give_def: str) -> str:
    """Cut the lambda out of the line(s) ``getsource`` gives for it (the whole statement around it).

    Every ``lambda`` in the text is grown to the longest piece that parses as one lambda;
    those taking the same arguments and reading the same names as ``fn`` are candidates.
    """
    code = fn.__code__
    want = (code.co_varnames[:code.co_argcount], set(code.co_names) | set(code.co_freevars))
    found = set()
    for start in (m.start() for m in re.finditer(r"\blambda\b", text)):
        for end in range(len(text), start, -1):
            piece = text[start:end].strip()
            try:
                tree = ast.parse(f"(\n{piece}\n)", mode="eval")
            except SyntaxError:
                continue
            if not isinstance(tree.body, ast.Lambda):  # e.g. "lambda m: f(m), other": a tuple, cut more
                continue
            inner = next(c for c in compile(tree, "<lambda>", "eval").co_consts if isinstance(c, types.CodeType))
            if (inner.co_varnames[:inner.co_argcount], set(inner.co_names)) == want:
                found.add(piece)
            break
    if len(found) != 1:
        why = "cannot be cut out of its source line" if not found else "looks like other lambdas on its line"
        raise IpyrosError(f"the handler of {label} is a lambda that {why}; {give_def}")
    return found.pop() + "\n"


def global_names(source: str) -> list[str]:
    """The global names ``source`` reads, first use first: not builtins, not what it defines itself.

    Compiled as a module, a handler's free names (its closure's too) all become globals,
    so the bytecode's LOAD_GLOBAL/LOAD_NAME list them exactly (attributes are not among them).
    """
    top = compile(source, "<handler>", "exec")
    defined = {i.argval for i in dis.get_instructions(top) if i.opname == "STORE_NAME"}
    names: dict[str, None] = {}
    stack = [top]
    while stack:
        code = stack.pop()
        names.update((i.argval, None) for i in dis.get_instructions(code) if i.opname in ("LOAD_GLOBAL", "LOAD_NAME"))
        stack.extend(reversed([c for c in code.co_consts if isinstance(c, types.CodeType)]))
    return [n for n in names if n not in defined and not hasattr(builtins, n)]


def lookup(name: str, fn: Callable[..., Any], namespace: Optional[dict]) -> Any:
    """What ``name`` means to ``fn``: its closure, then ``namespace``, then its own globals."""
    if name in fn.__code__.co_freevars:
        cell = fn.__closure__[fn.__code__.co_freevars.index(name)]  # type: ignore[index]
        with contextlib.suppress(ValueError):  # an empty cell: not assigned yet
            return cell.cell_contents
        return _MISSING
    return next((scope[name] for scope in (namespace or {}, fn.__globals__) if name in scope), _MISSING)


def import_of(value: Any, own_module: str) -> Optional[tuple[str, Optional[str]]]:
    """``(module, attribute)`` to import ``value`` from (attribute None: the module itself), if any.

    Things of the handler's own module (``__main__`` at the prompt) are the user's, not importable.
    A class from a private submodule is imported from its package (``std_msgs.msg._String`` → ``std_msgs.msg``).
    """
    if isinstance(value, types.ModuleType):
        return value.__name__, None
    module, attr = getattr(value, "__module__", None), getattr(value, "__name__", None)
    if not isinstance(module, str) or not isinstance(attr, str) or module in (own_module, "__main__"):
        return None
    parent, _, last = module.rpartition(".")
    for candidate in ([parent] if parent and last.startswith("_") else []) + [module]:
        if getattr(sys.modules.get(candidate), attr, None) is value:
            return candidate, attr
    return None


def import_statement(name: str, origin: tuple[str, Optional[str]]) -> str:
    module, attr = origin
    if attr is None:
        return f"import {module}" + (f" as {name}" if name != module else "")
    return f"from {module} import {attr}" + (f" as {name}" if name != attr else "")


def _is_literal(value: Any) -> bool:
    """Plain data whose repr is Python source for an equal value."""
    if value is None or type(value) in (bool, int, str):
        return True
    if type(value) is float:
        return value == value and value not in (float("inf"), float("-inf"))
    if type(value) in (list, tuple):
        return all(_is_literal(v) for v in value)
    return type(value) is dict and all(_is_literal(k) and _is_literal(v) for k, v in value.items())


def _fills(source: str, name: str) -> bool:
    """Whether ``source`` adds to the container ``name`` (``poses.append(msg)``, ``seen[key] = ...``)."""
    return re.search(rf"\b{re.escape(name)}\s*(?:\.(?:append|extend|add|update|insert|setdefault|appendleft)\s*\("
                     rf"|\[[^\]]*\]\s*=(?!=))", source) is not None


@dataclass
class Bindings:
    """What handlers need from outside their own source, sorted into what a file can hold.

    For every global a handler reads (:func:`global_names`): an import if its value is
    importable, an assignment if it is a plain literal, the source if it is a helper
    function of the user's (whose own globals are bound in turn), else *unbound*, with
    why, for the caller to report.
    """

    imports: dict[str, tuple[str, Optional[str]]] = field(default_factory=dict)
    values: dict[str, str] = field(default_factory=dict)  # name → its assignment line
    functions: dict[str, str] = field(default_factory=dict)  # name → source defining it
    unbound: dict[str, str] = field(default_factory=dict)  # name → why it could not be bound

    def has(self, name: str) -> bool:
        return any(name in d for d in (self.imports, self.values, self.functions, self.unbound))

    def bind(self, fn: Callable[..., Any], source: str, namespace: Optional[dict],
             skip: Callable[[str, Any], bool] = lambda name, value: False) -> None:
        """Bind the globals of ``fn`` (whose source is ``source``); ``skip(name, value)`` leaves one out."""
        for name in global_names(source):
            value = lookup(name, fn, namespace)
            if skip(name, value):
                continue
            origin = None if value is _MISSING else import_of(value, fn.__module__)
            if self.has(name):
                self._same(name, value, origin, fn)
                continue
            if origin is not None:
                self.imports[name] = origin
            elif isinstance(value, types.FunctionType) and value.__module__ == fn.__module__:
                helper = handler_source(value, f"helper {name} of {fn.__name__}")
                self.functions[name] = f"{name} = {helper}" if value.__name__ == "<lambda>" else \
                    helper if value.__name__ == name else f"{helper}{name} = {value.__name__}\n"
                self.bind(value, helper, namespace, skip)
            elif type(value) in (list, dict, set) and _fills(source, name):
                # what a handler fills is its data, not its configuration: the file starts it empty again
                self.values[name] = f"{name} = {type(value).__name__}()  # filled by {fn.__name__}: its data is not kept"
            elif value is not _MISSING and _is_literal(value):
                self.values[name] = f"{name} = {value!r}"
            else:
                self.unbound[name] = (f"used by {fn.__name__}, not defined when saved" if value is _MISSING else
                                      f"used by {fn.__name__}, a {type(value).__name__}: not a literal, not importable")

    def _same(self, name: str, value: Any, origin: Optional[tuple[str, Optional[str]]],
              fn: Callable[..., Any]) -> None:
        """``name`` is bound already (an import of the file's own, another handler's global): refuse a value that
        means something else under it, rather than let the file change what ``fn`` reads without a word."""
        if name in self.imports:
            if value is _MISSING or origin == self.imports[name]:
                return
            module, attr = self.imports[name]
            meant = f"the module {module}" if attr is None else f"{attr} from {module}"
        elif name in self.values:
            literal = _is_literal(value) and f"{name} = {value!r}" == self.values[name]
            if value is _MISSING or literal or self.values[name].startswith(f"{name} = {type(value).__name__}()"):
                return
            meant = self.values[name].partition(" = ")[2]
        else:  # a function's source (compared where handlers are named), or a name already unbound
            return
        raise IpyrosError(f"handler {fn.__name__} reads the global {name} = {cut(value, 40)}, but {name} is "
                          f"{meant} in the file; rename the global (it would silently read the other)")

    def import_lines(self, skip: Iterable[str] = ()) -> list[str]:
        """``import m`` lines, then ``from m import a, b`` lines (one per module), sorted."""
        lines: list[str] = []
        froms: dict[str, list[str]] = {}
        for name, (module, attr) in self.imports.items():
            if name in skip:
                continue
            if attr == name:
                froms.setdefault(module, []).append(name)
            else:
                lines.append(import_statement(name, (module, attr)))
        lines += [f"from {module} import {', '.join(sorted(names))}" for module, names in froms.items()]
        return sorted(lines, key=lambda line: (line.startswith("from"), line))


def define_function(name: str, source: str, namespace: dict, what: str,
                    filename: Optional[str] = None) -> Callable[..., Any]:
    """Run the ``def`` (or lambda expression) ``source`` in ``namespace``; return the function ``name``."""
    filename = filename or f"<ipyros: {what}>"
    # Kept in linecache like an IPython cell, so inspect.getsource (%handler, save) finds it again.
    linecache.cache[filename] = (len(source), None, source.splitlines(True), filename)
    lambda_ = name == "<lambda>"
    try:
        code = compile(source, filename, "eval" if lambda_ else "exec")
    except SyntaxError as error:
        raise IpyrosError(f"{what} does not compile: {error.msg} at line {error.lineno}") from None
    try:
        if lambda_:
            fn = eval(code, namespace)  # noqa: S307 - the user's own handler source
        else:
            exec(code, namespace)  # noqa: S102 - the user's own handler source
            fn = namespace.get(name)
    except Exception as error:  # noqa: BLE001
        raise IpyrosError(f"{what}: running its definition failed: {error!r}") from None
    if not callable(fn):
        raise IpyrosError(f"{what}: its source does not define a function {name}")
    return fn
