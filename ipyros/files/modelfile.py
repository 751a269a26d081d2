"""Keeping the work: save a DSL node to YAML, load it back, export it as a plain rospy script.

The model (:mod:`ipyros.core.model`) is plain data, but handlers are live functions. A saved
node is the model plus each handler's *source*, as ``inspect.getsource`` finds it (which
works for functions typed at an IPython prompt: IPython keeps every cell in ``linecache``):

    ipyros_node_format: 1
    node: {name: ..., topics: [...], timers: [...], services: [...], params: {...}}
    handlers:
    - slot: topic /turtle1/pose          # the handler's slot key (see ipyros.core.plan)
      name: showPose
      imports: [from turtlesim.msg import Pose]   # what its global names were bound to
      source: |
        def showPose(data): ...

:func:`load` runs each source in a namespace (IPython's ``user_ns``: the handlers see the
user's globals and stay editable with ``%handler``) and replays the declarations through
the public DSL, so every check applies as if typed. :func:`export` writes a standalone
rospy script doing what the node does, by walking the same plan the runtime opens
(:func:`ipyros.core.plan.plan`): so the script and the live node cannot disagree on wrapping.

A saved file keeps code, not state: the values of the handlers' other globals (``speed``)
and helper functions they call come from the namespace they are loaded into. An export
has no such namespace later, so it copies them in: plain literals, helper sources, imports.
"""

from __future__ import annotations

import ast
import builtins
import contextlib
import dis
import inspect
import json
import linecache
import os
import re
import shlex
import sys
import tempfile
import textwrap
import types
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterable, Iterator, Optional

import yaml

from ..core import plan as planning
from ..core.errors import DataError, IpyrosError
from ..core.model import NodeModel
from ..core.userdata import load_json, load_yaml

if TYPE_CHECKING:
    from ..node.dsl import rosNode
    from ..node.session import Session

FORMAT_KEY = "ipyros_node_format"
FORMAT = 1
_MISSING: Any = object()
# A name the handlers call ``<name>.write(...)`` on: the node they were written for.
_WRITER = re.compile(r"(?<![\w.])([A-Za-z_]\w*)\s*\.\s*write\s*\(")


# -- handlers and their source --------------------------------------------------------------

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


def handler_source(fn: Any, label: str) -> str:
    """The source of handler ``fn``: a dedented ``def``, or the expression of a lambda."""
    name = getattr(fn, "__name__", type(fn).__name__)
    give_def = f"give the handler of {label} a def (def handler(msg): ...) and declare it again"
    if not isinstance(fn, types.FunctionType):
        raise IpyrosError(f"the handler of {label} is {type(fn).__name__} {name!r}, which has no source to keep; "
                          + give_def)
    try:
        source = textwrap.dedent(inspect.getsource(fn))
    except (OSError, TypeError):
        raise IpyrosError(f"cannot find the source of handler {name} for {label} (defined in "
                          f"{fn.__code__.co_filename}); {give_def}") from None
    return source if name != "<lambda>" else _lambda_expression(fn, source, label, give_def)


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


def _lookup(name: str, fn: types.FunctionType, namespace: Optional[dict]) -> Any:
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

    def bind(self, fn: types.FunctionType, source: str, namespace: Optional[dict],
             skip: Callable[[str, Any], bool] = lambda name, value: False) -> None:
        """Bind the globals of ``fn`` (whose source is ``source``); ``skip(name, value)`` leaves one out."""
        for name in global_names(source):
            if self.has(name):
                continue
            value = _lookup(name, fn, namespace)
            if skip(name, value):
                continue
            origin = None if value is _MISSING else import_of(value, fn.__module__)
            if origin is not None:
                self.imports[name] = origin
            elif isinstance(value, types.FunctionType) and value.__module__ == fn.__module__:
                helper = handler_source(value, f"helper {name} of {fn.__name__}")
                self.functions[name] = f"{name} = {helper}" if value.__name__ == "<lambda>" else \
                    helper if value.__name__ == name else f"{helper}{name} = {value.__name__}\n"
                self.bind(value, helper, namespace, skip)
            elif value is not _MISSING and _is_literal(value):
                self.values[name] = f"{name} = {value!r}"
            else:
                self.unbound[name] = (f"used by {fn.__name__}, not defined when saved" if value is _MISSING else
                                      f"used by {fn.__name__}, a {type(value).__name__}: not a literal, not importable")

    def import_lines(self, skip: Iterable[str] = ()) -> list[str]:
        """``import m`` lines, then ``from m import a, b`` lines (one per module), sorted."""
        lines, froms = [], {}
        for name, (module, attr) in self.imports.items():
            if name in skip:
                continue
            if attr == name:
                froms.setdefault(module, []).append(name)
            else:
                lines.append(import_statement(name, (module, attr)))
        lines += [f"from {module} import {', '.join(sorted(names))}" for module, names in froms.items()]
        return sorted(lines, key=lambda line: (line.startswith("from"), line))


# -- files ------------------------------------------------------------------------------------

def _write_atomic(path: "str | os.PathLike[str]", text: str, mode: int = 0o644) -> Path:
    """Write ``text`` to a temporary file beside ``path`` and rename it: readers never see half a file."""
    path = Path(path).expanduser().absolute()
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    except OSError as error:
        raise IpyrosError(f"cannot write {path}: {error.strerror}") from None
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as out:
            out.write(text)
            out.flush()
            os.fsync(out.fileno())
        os.chmod(tmp, mode)
        os.replace(tmp, path)
    except BaseException as error:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(error, OSError):  # a full disk, a quota: the file as it was stays
            raise IpyrosError(f"cannot write {path}: {error.strerror or error}; nothing was changed there") from None
        raise
    return path


class _Dumper(yaml.SafeDumper):
    """Multi-line strings (handler sources) as YAML literal blocks: readable, and diffs line by line."""


_Dumper.add_representer(str, lambda dumper, text: dumper.represent_scalar(
    "tag:yaml.org,2002:str", text, style="|" if "\n" in text else None))


# -- save -------------------------------------------------------------------------------------

MODEL_SUFFIXES = ("yaml", "yml", "json")


def handler_sources(nodes: Iterable["rosNode"]) -> dict[tuple[int, str], str]:
    """``(id(node), slot) → source`` of every handler of ``nodes``.

    A handler without source fails it, and the error names every such handler, so
    nothing is saved with a handler silently missing.
    """
    sources, missing = {}, []
    for node in nodes:
        for slot, label in handler_slots(node.model()):
            fn = node.handlers()[slot]
            try:
                sources[(id(node), slot)] = handler_source(fn, f"{node.name} {label}")
            except IpyrosError as error:
                missing.append(str(error).split("; ")[0])  # names the handler and why
    if missing:
        raise IpyrosError(f"nothing saved: {'; '.join(missing)}; define "
                          f"{'them' if len(missing) > 1 else 'it'} with def (at the prompt or in a file), "
                          "declare again, then save")
    return sources


def save(node: "rosNode", path: "str | os.PathLike[str]") -> Path:
    """Save ``node``'s model and its handlers' sources to ``path`` (YAML, or JSON for ``.json``)."""
    model = node.model()
    sources = handler_sources([node])
    entries = []
    for slot, _ in handler_slots(model):
        fn, source = node.handlers()[slot], sources[(id(node), slot)]
        origins = {n: import_of(_lookup(n, fn, None), fn.__module__) for n in global_names(source)}
        entry: dict[str, Any] = {"slot": slot, "name": fn.__name__}
        imports = [import_statement(n, o) for n, o in origins.items() if o is not None]
        if imports:
            entry["imports"] = imports
        entries.append({**entry, "source": source})
    data = {FORMAT_KEY: FORMAT, "ros": node.session.backend.name, "node": model.to_dict(), "handlers": entries}
    if str(path).lower().endswith(".json"):
        return _write_atomic(path, json.dumps(data, indent=2, ensure_ascii=False) + "\n")
    return _write_atomic(path, yaml.dump(data, Dumper=_Dumper, sort_keys=False, allow_unicode=True, width=100))


# -- load -------------------------------------------------------------------------------------

def load(path: "str | os.PathLike[str]", namespace: Optional[dict] = None, *,
         session: Optional["Session"] = None, trust: bool = False) -> "rosNode":
    """Rebuild the node saved in ``path``, declared but not created.

    A model file looks like data and travels like data, so the code in it (imports and
    handler sources) runs only when asked: ``trust=True``. Without it, a file that carries
    code is refused, in one line naming what would run; a model without code (its handlers
    taken by name from ``namespace``) loads as it is. A saved ``.py`` file is code, and runs
    as Python files do (:func:`ipyros.files.savefile.restore`).

    Handler sources run in ``namespace`` (default: a fresh dict); pass IPython's
    ``user_ns`` so the handlers read the user's globals. Names the handlers call
    ``.write`` on (``nd.write(...)``) are bound to the new node if ``namespace`` lacks them.
    """
    from ..node.dsl import rosNode

    path = Path(path).expanduser()
    namespace = {} if namespace is None else namespace
    data = _read(path)
    if not trust:
        _refuse_untrusted(path, data)
    try:
        model = NodeModel.from_dict(data["node"])
    except (TypeError, ValueError, AttributeError) as error:
        raise IpyrosError(f"{path}: the node is malformed: {error}") from None
    functions = {entry["slot"]: _define(path, entry, namespace) for entry in data["handlers"]}
    functions.update(_by_name(path, model, functions, namespace))
    node = rosNode(model.name, namespace=model.namespace, session=session)
    _across_ros(path, data.get("ros"), model, node)
    try:
        _declare(node, model, functions)
    except IpyrosError as error:
        raise type(error)(f"{path}: {error}") from None
    for entry in data["handlers"]:
        for name in _WRITER.findall(entry["source"]):
            namespace.setdefault(name, node)
    return node


def _refuse_untrusted(path: Path, data: dict) -> None:
    """Refuse, in one line saying what would run, a model file that would run anything: code, or a process.

    A model file looks like data and travels like data (an attachment, a repository), so
    loading it runs nothing unless asked: not the handlers' sources and imports, and not a
    basenode either, which is a program started with the user's rights (a launch file, a
    bag, ``/bin/sh -c ...``: whatever ``base`` names). A model of topics, timers, services and
    parameters whose handlers are found by name in the namespace loads without trust.
    """
    would = []
    if data["handlers"]:
        imports = sorted({line for entry in data["handlers"] for line in entry.get("imports") or []})
        would.append((f"imports {'; '.join(imports)} and " if imports else "") + "the handlers "
                     + ", ".join(entry["name"] for entry in data["handlers"]))
    base = data["node"].get("base")
    if base is not None:
        would.append(f"the basenode {_command_of(base)}")
    if would:
        raise IpyrosError(f"{path} would run {' and '.join(would)}; read it, and if you trust it load it with "
                          f"trust=True (rosNode.load({str(path)!r}, trust=True), %load_nodes --trust)")


def _command_of(base: Any) -> str:
    """What a model file's ``base`` would start, in words: a launch file's node, a package's executable, a file."""
    if not isinstance(base, dict):
        return repr(base)[:80]
    args = base.get("args") if isinstance(base.get("args"), list) else []
    line = " ".join(shlex.quote(str(word)) for word in [base.get("executable") or "?", *args])
    if len(line) > 200:
        line = line[:197] + "..."
    if base.get("launch"):
        return f"{base.get('launch_node') or '?'} of the launch file {base['launch']} (and the rest of that file)"
    if base.get("package"):
        return f"{line} of package {base['package']}"
    return line


def _across_ros(path: Path, made_on: Optional[str], model: NodeModel, node: "rosNode") -> None:
    """A model made on the other ROS: refuse what cannot run here, in one line; say what runs differently.

    The model itself is the same on both (names, types as ``pkg/Type``, QoS as data); what
    can differ is what it names: message packages and basenodes must be installed here
    (their lookups say so, in one line, if they are not), and a launch-file basenode needs
    roslaunch, which is ROS 1's.
    """
    here = node.session.backend.name
    if made_on in (None, here):
        return
    if model.base is not None and model.base.launch and not node.session.backend.has_master:
        raise IpyrosError(f"{path} was made on {made_on} and wraps a node of the launch file {model.base.launch}: "
                          f"{here} has no roslaunch; declare the basenode with baseNode(...) instead")
    notes = [f"{path} was made on {made_on}; loading it on {here}"]
    if node.session.backend.has_master and any(t.qos and set(t.qos) - {"durability"} for t in model.topics):
        notes.append("its QoS depth and reliability mean nothing on ROS 1 (TCP is reliable) and are kept")
    node.session.notify("ipyros: " + "; ".join(notes))


def _by_name(path: Path, model: NodeModel, functions: dict[str, Any], namespace: dict) -> dict[str, Any]:
    """Handlers a model file declares without their source: found by name in ``namespace``."""
    wanted = {slot: name for slot, name in _slot_handlers(model) if slot not in functions}
    found = {slot: namespace[name] for slot, name in wanted.items() if callable(namespace.get(name))}
    lacking = sorted({name for slot, name in wanted.items() if slot not in found})
    if lacking:
        raise IpyrosError(f"{path} has no source for handler(s) {', '.join(lacking)} and they are not defined here; "
                          "define them first (def name(msg): ...), then load")
    return found


def _slot_handlers(model: NodeModel) -> Iterator[tuple[str, str]]:
    """``(slot key, handler name)`` of every handler the model declares."""
    names = {planning.topic_slot(t.resolved): t.handler for t in model.topics}
    names.update({planning.service_slot(s.resolved): s.handler for s in model.services})
    names.update({planning.timer_slot(t.name): t.handler for t in model.timers})
    for slot, _ in handler_slots(model):
        yield slot, names[slot] or "?"


def _read(path: Path) -> dict:
    """The file's data, checked for shape; every problem is one line naming the file."""
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        raise IpyrosError(f"cannot read {path}: {getattr(error, 'strerror', None) or error}") from None
    try:
        data = (load_json if path.suffix.lower() == ".json" else load_yaml)(text, str(path))
    except DataError as error:
        raise IpyrosError(str(error)) from None
    if not isinstance(data, dict) or FORMAT_KEY not in data:
        raise IpyrosError(f"{path} is not a saved ipyros node (no {FORMAT_KEY}: key); save one with nd.save(path)")
    if data[FORMAT_KEY] != FORMAT:
        raise IpyrosError(f"{path} has format version {data[FORMAT_KEY]!r}, this ipyros reads version {FORMAT}")
    data.setdefault("handlers", [])  # a model without code: handlers are found by name when loaded
    for key, kind in (("node", dict), ("handlers", list)):
        if not isinstance(data.get(key), kind):
            raise IpyrosError(f"{path}: missing or malformed key {key!r} (a {kind.__name__} is expected)")
    for i, entry in enumerate(data["handlers"]):
        missing = [k for k in ("slot", "name", "source") if not isinstance(entry, dict) or
                   not isinstance(entry.get(k), str)]
        if missing:
            raise IpyrosError(f"{path}: handler #{i + 1} lacks {', '.join(missing)}")
    return data


def _define(path: Path, entry: dict, namespace: dict) -> Callable[..., Any]:
    """Run one handler's imports and source in ``namespace``; return the function it defines."""
    name, source = entry["name"], entry["source"]
    what = f"{path}: handler {name} ({entry['slot']})"
    for statement in entry.get("imports") or []:
        bound = statement.split()[-1].split(".")[0]
        if bound not in namespace:
            try:
                exec(statement, namespace)  # noqa: S102 - an import line the file names
            except Exception as error:  # noqa: BLE001 - any failure is the file's problem, told in one line
                raise IpyrosError(f"{what} needs `{statement}`, which fails: {error}") from None
    return define_function(name, source, namespace, what, f"<ipyros {path.name}: {name}>")


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
        fn = eval(code, namespace) if lambda_ else (exec(code, namespace), namespace.get(name))[1]  # noqa: S307
    except Exception as error:  # noqa: BLE001
        raise IpyrosError(f"{what}: running its definition failed: {error!r}") from None
    if not callable(fn):
        raise IpyrosError(f"{what}: its source does not define a function {name}")
    return fn


def _declare(node: "rosNode", model: NodeModel, functions: dict[str, Callable[..., Any]]) -> None:
    """Replay ``model`` through the public DSL: base first, then topics, services, timers, params."""
    base = model.base
    if base is not None and base.launch:  # the launch file says the rest, as it does now
        node.baseLaunch(base.launch, base.launch_node or base.node_name or "", args=base.launch_args)
        base = None
    if base is not None and base.executable:
        node.baseNode(base.executable, name=base.node_name, namespace=base.namespace, remaps=base.remaps,
                      params=base.params, args=base.args)
    if base is not None and base.package:
        node.basePackage(base.package)
    for t in model.topics:
        role = getattr(node, t.role)
        if t.direction == "publish":
            role.publish(t.name, type=t.type, latch=t.latch, qos=t.qos)
        else:
            role.subscribe(t.name, handler=functions.get(planning.topic_slot(t.resolved)), type=t.type, qos=t.qos)
    for s in model.services:  # a reuse relays and takes no handler: the slot is the intercepting new's
        handler = functions.get(planning.service_slot(s.resolved)) if s.role == "new" else None
        getattr(node, s.role).service(s.name, type=s.type, handler=handler)
    for timer in model.timers:
        node.timer(timer.period, functions.get(planning.timer_slot(timer.name)), name=timer.name,
                   oneshot=timer.oneshot)
    for key, value in model.params.items():
        node.params[key] = value
