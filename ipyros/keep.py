"""Keeping the work: save a DSL node to YAML, load it back, export it as a plain rospy script.

The model (:mod:`ipyros.model`) is plain data, but handlers are live functions. A saved
node is the model plus each handler's *source*, as ``inspect.getsource`` finds it (which
works for functions typed at an IPython prompt: IPython keeps every cell in ``linecache``):

    ipyros_node_format: 1
    node: {name: ..., topics: [...], timers: [...], services: [...], params: {...}}
    handlers:
    - slot: topic /turtle1/pose          # the handler's slot key (see ipyros.plan)
      name: showPose
      imports: [from turtlesim.msg import Pose]   # what its global names were bound to
      source: |
        def showPose(data): ...

:func:`load` runs each source in a namespace (IPython's ``user_ns``: the handlers see the
user's globals and stay editable with ``%handler``) and replays the declarations through
the public DSL, so every check applies as if typed. :func:`export` writes a standalone
rospy script doing what the node does, by walking the same plan the runtime opens
(:func:`ipyros.plan.plan`): so the script and the live node cannot disagree on wrapping.

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
import linecache
import os
import re
import sys
import tempfile
import textwrap
import types
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterator, Optional

import yaml

from . import plan as planning
from .errors import IpyrosError
from .model import BaseModel, NodeModel
from .slots import call_arity

if TYPE_CHECKING:
    from .dsl import rosNode
    from .session import Session

FORMAT_KEY = "ipyros_node_format"
FORMAT = 1
_MISSING: Any = object()
# A name the handlers call ``<name>.write(...)`` on: the node they were written for.
_WRITER = re.compile(r"(?<![\w.])([A-Za-z_]\w*)\s*\.\s*write\s*\(")


class ExportWarning(UserWarning):
    """The exported script has names to fill in by hand (``NAME = None  # set me``)."""


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
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return path


class _Dumper(yaml.SafeDumper):
    """Multi-line strings (handler sources) as YAML literal blocks: readable, and diffs line by line."""


_Dumper.add_representer(str, lambda dumper, text: dumper.represent_scalar(
    "tag:yaml.org,2002:str", text, style="|" if "\n" in text else None))


# -- save -------------------------------------------------------------------------------------

def save(node: "rosNode", path: "str | os.PathLike[str]") -> Path:
    """Save ``node``'s model and its handlers' sources to the YAML file ``path``; return its path."""
    model = node.model()
    entries = []
    for slot, label in handler_slots(model):
        fn = node._handlers[slot]
        source = handler_source(fn, f"{node.name} {label}")
        origins = {n: import_of(_lookup(n, fn, None), fn.__module__) for n in global_names(source)}
        entry: dict[str, Any] = {"slot": slot, "name": fn.__name__}
        imports = [import_statement(n, o) for n, o in origins.items() if o is not None]
        if imports:
            entry["imports"] = imports
        entries.append({**entry, "source": source})
    data = {FORMAT_KEY: FORMAT, "node": model.to_dict(), "handlers": entries}
    return _write_atomic(path, yaml.dump(data, Dumper=_Dumper, sort_keys=False, allow_unicode=True, width=100))


# -- load -------------------------------------------------------------------------------------

def load(path: "str | os.PathLike[str]", namespace: Optional[dict] = None, *,
         session: Optional["Session"] = None) -> "rosNode":
    """Rebuild the node saved in ``path``, declared but not created.

    Handler sources run in ``namespace`` (default: a fresh dict); pass IPython's
    ``user_ns`` so the handlers read the user's globals. Names the handlers call
    ``.write`` on (``nd.write(...)``) are bound to the new node if ``namespace`` lacks them.
    """
    from .dsl import rosNode

    path = Path(path).expanduser()
    namespace = {} if namespace is None else namespace
    data = _read(path)
    try:
        model = NodeModel.from_dict(data["node"])
    except (TypeError, ValueError, AttributeError) as error:
        raise IpyrosError(f"{path}: the node is malformed: {error}") from None
    functions = {entry["slot"]: _define(path, entry, namespace) for entry in data["handlers"]}
    node = rosNode(model.name, namespace=model.namespace, session=session)
    try:
        _declare(node, model, functions)
    except IpyrosError as error:
        raise type(error)(f"{path}: {error}") from None
    for entry in data["handlers"]:
        for name in _WRITER.findall(entry["source"]):
            namespace.setdefault(name, node)
    return node


def _read(path: Path) -> dict:
    """The file's data, checked for shape; every problem is one line naming the file."""
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except OSError as error:
        raise IpyrosError(f"cannot read {path}: {error.strerror}") from None
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark else ""
        raise IpyrosError(f"{path} is not valid YAML{where}: {getattr(error, 'problem', error)}") from None
    if not isinstance(data, dict) or FORMAT_KEY not in data:
        raise IpyrosError(f"{path} is not a saved ipyros node (no {FORMAT_KEY}: key); save one with nd.save(path)")
    if data[FORMAT_KEY] != FORMAT:
        raise IpyrosError(f"{path} has format version {data[FORMAT_KEY]!r}, this ipyros reads version {FORMAT}")
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
    filename = f"<ipyros {path.name}: {name}>"
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
    if base is not None and base.executable:
        node.baseNode(base.executable, name=base.node_name, namespace=base.namespace, remaps=base.remaps,
                      params=base.params, args=base.args)
    if base is not None and base.package:
        node.basePackage(base.package)
    for t in model.topics:
        role = getattr(node, t.role)
        if t.direction == "publish":
            role.publish(t.name, type=t.type, latch=t.latch)
        else:
            role.subscribe(t.name, handler=functions.get(planning.topic_slot(t.resolved)), type=t.type)
    for s in model.services:
        getattr(node, s.role).service(s.name, type=s.type, handler=functions.get(planning.service_slot(s.resolved)))
    for timer in model.timers:
        node.timer(timer.period, functions.get(planning.timer_slot(timer.name)), name=timer.name,
                   oneshot=timer.oneshot)
    for key, value in model.params.items():
        node.params[key] = value


# -- export -----------------------------------------------------------------------------------

# Names the generated script defines itself; a handler global with one of them would clash.
_SCRIPT_NAMES = {"rospy", "os", "signal", "subprocess", "NodeHandle", "relay", "main", "BASENODE",
                 "start_basenode", "stop_basenode"}

_HANDLE = '''
class NodeHandle:
    """Stands in for the ipyros node the handlers were written for: write(topic, msg) publishes."""

    def __init__(self):
        self.publishers = {}  # resolved topic name -> rospy.Publisher, filled in by main()

    def write(self, topic, msg):
        self.publishers[rospy.resolve_name(topic)].publish(msg)
'''

_RELAY = '''
def relay(source, target, msg_class):
    """Forward source to target unchanged: read as bytes (AnyMsg), written as bytes, never parsed."""
    pub = rospy.Publisher(target, msg_class, queue_size=10)  # advertised now: nothing lost at start

    def forward(raw):
        if raw._connection_header.get("latching") == "1" and not pub.impl.is_latch:
            pub.impl.enable_latch()  # latching follows the source
        pub.impl.acquire()
        try:
            pub.impl.publish(raw)  # Publisher.publish would type-check; the impl writes the bytes
        finally:
            pub.impl.release()

    return rospy.Subscriber(source, rospy.AnyMsg, forward)
'''

_BASE = '''
def start_basenode():
    """Run the wrapped node as a child, in its own process group (so it is stopped as a whole)."""
    proc = subprocess.Popen(BASENODE, start_new_session=True)
    print(f"started basenode {BASENODE[0]} (pid {proc.pid})", flush=True)
    return proc


def stop_basenode(proc):
    """Stop it as roslaunch does: SIGINT, then SIGTERM, then SIGKILL, to its process group."""
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGKILL):
        if proc.poll() is not None:
            return
        try:
            os.killpg(proc.pid, sig)
            proc.wait(5)
        except (ProcessLookupError, subprocess.TimeoutExpired):
            pass
'''


class _Script:
    """Collects what the script needs (imports, values, functions) while it is generated."""

    def __init__(self, node: "rosNode", path: "str | os.PathLike[str]", namespace: Optional[dict]) -> None:
        self.node, self.model, self.path, self.namespace = node, node.model(), path, namespace
        self.imports: dict[str, tuple[str, Optional[str]]] = {"rospy": ("rospy", None)}
        self.values: dict[str, str] = {}  # global name → its assignment line
        self.functions: dict[str, str] = {}  # name in the script → source
        self.names: dict[str, str] = {}  # slot → the handler's name in the script
        self.unset: list[str] = []
        sources = {slot: self._handler(slot, f"{node.name} {label}") for slot, label in handler_slots(self.model)}
        self.writers = sorted({w for src in sources.values() for w in _WRITER.findall(src)}) or ["this_node"]
        for slot, label in handler_slots(self.model):
            self._globals(node._handlers[slot], sources[slot])

    def _handler(self, slot: str, label: str) -> str:
        fn = self.node._handlers[slot]
        source = handler_source(fn, label)
        name = fn.__name__
        if name == "<lambda>":  # a name of its own: on_turtle1_pose, timer_tick, ...
            name = re.sub(r"\W+", "_", slot.replace("topic ", "on ", 1)).strip("_")
            source = f"{name} = {source}"
        if self.functions.get(name, source) != source:
            raise IpyrosError(f"two different handlers of {self.node.name} are named {name}; "
                              "rename one (def another_name(msg): ...) and declare it again")
        self.functions[name], self.names[slot] = source, name
        return source

    def _globals(self, fn: types.FunctionType, source: str) -> None:
        """Bind every global ``source`` reads: an import, a literal, a helper function, or a set-me."""
        for name in global_names(source):
            if self._taken(name) or name in self.imports:
                continue
            value = _lookup(name, fn, self.namespace)
            origin = None if value is _MISSING else import_of(value, fn.__module__)
            if name in _SCRIPT_NAMES and origin != (name, None):
                raise IpyrosError(f"handler {fn.__name__} uses the global {name}, a name the exported script "
                                  "needs for itself; rename it")
            if origin is not None:
                self.imports[name] = origin
            elif isinstance(value, types.FunctionType) and value.__module__ == fn.__module__:
                helper = handler_source(value, f"helper {name} of {fn.__name__}")
                self.functions[name] = f"{name} = {helper}" if value.__name__ == "<lambda>" else \
                    helper if value.__name__ == name else f"{helper}{name} = {value.__name__}\n"
                self._globals(value, helper)
            elif value is not _MISSING and _is_literal(value):
                self.values[name] = f"{name} = {value!r}"
            else:
                self.values[name] = f"{name} = None  # set me: used by handler {fn.__name__}"
                self.unset.append(name)

    def _taken(self, name: str) -> bool:
        return name in self.writers or name in self.functions or name in self.values

    def cls(self, type_name: str, kind: str = "msg") -> str:
        """The script's name for a message/service class, imported once (``pkg_Type`` if taken)."""
        package, short = type_name.split("/")
        origin = (f"{package}.{kind}", short)
        for name in (short, f"{package}_{short}"):
            if not self._taken(name) and self.imports.setdefault(name, origin) == origin:
                return name
        raise IpyrosError(f"the exported script cannot name {type_name}: {short} and {package}_{short} are taken")

    def main(self) -> list[str]:
        """The body of main(): the endpoints of the plan, the basenode, spin."""
        model, handle = self.model, self.writers[0]
        lines = [f"rospy.init_node({model.name!r})"]
        if model.params:
            lines += [f"for key, value in {model.params!r}.items():  # _key:=value on the command line wins",
                      '    if not rospy.has_param("~" + key):', '        rospy.set_param("~" + key, value)']
        writes_to = {planning.write_target(model, t.resolved): t.resolved for t in model.topics}
        # Publishers first: a handler may write as soon as its subscriber is up.
        for spec in sorted(planning.plan(model), key=lambda s: not isinstance(s, planning.PublishSpec)):
            if isinstance(spec, planning.PublishSpec):
                latch = ", latch=True" if spec.latch else ""
                lines.append(f"{handle}.publishers[{writes_to[spec.topic]!r}] = rospy.Publisher("
                             f"{spec.topic!r}, {self.cls(spec.type)}, queue_size=10{latch})")
            elif isinstance(spec, planning.SubscribeSpec):
                lines.append(f"rospy.Subscriber({spec.topic!r}, {self.cls(spec.type)}, {self.names[spec.slot]})")
            elif isinstance(spec, planning.RelaySpec):
                lines.append(f"relay({spec.source!r}, {spec.target!r}, {self.cls(spec.type)})")
            elif isinstance(spec, planning.TimerSpec):
                fn, name = self.node._handlers[spec.slot], self.names[spec.slot]
                call = name if call_arity(fn, "timer", name) else f"lambda event: {name}()"
                oneshot = ", oneshot=True" if spec.oneshot else ""
                lines.append(f"rospy.Timer(rospy.Duration({spec.period!r}), {call}{oneshot})")
            elif isinstance(spec, planning.ServiceSpec):
                lines.append(f"rospy.Service({spec.name!r}, {self.cls(spec.type, 'srv')}, {self.names[spec.slot]})")
            else:  # ServiceRelaySpec: answer with the basenode's own service
                srv = self.cls(spec.type, "srv")
                lines.append(f"rospy.Service({spec.target!r}, {srv}, rospy.ServiceProxy({spec.source!r}, {srv}))")
        if model.base is None:
            return lines + ["rospy.spin()"]
        return lines + ["basenode = start_basenode()", "try:", "    rospy.spin()", "finally:",
                        "    stop_basenode(basenode)"]

    def render(self) -> str:
        model = self.model
        main = self.main()  # first: it adds the message imports
        base = _base_argv(model) if model.base is not None else None
        head = [f"#!/usr/bin/python3\n\"\"\"{model.name}: a rospy node exported by ipyros from the DSL node "
                f"{planning.node_fullname(model)}.\n\nIt needs no ipyros: ./{Path(self.path).name} "
                "[from:=to ...] [_param:=value ...]"]
        if base is not None:
            wrapped = f"{model.base.package}/{model.base.executable}"  # type: ignore[union-attr]
            head.append(f"It runs its basenode {wrapped} itself, remapped as ipyros ran it, and stops it on exit.")
        head.append('"""')
        stdlib = ["os", "signal", "subprocess"] if base else ["os"] if model.namespace != "/" else []
        head += [f"import {m}" for m in stdlib]
        if model.namespace != "/":
            head += ["", "# Before rospy is imported: it reads its namespace then. The names below are resolved in it.",
                     f"os.environ[\"ROS_NAMESPACE\"] = {model.namespace!r}"]
        head += ["", *_import_lines({n: o for n, o in self.imports.items() if n not in stdlib})]
        if self.values:
            head += ["", "# Globals the handlers read, as they were at export.", *self.values.values()]
        parts = ["\n".join(head), _HANDLE.strip("\n"), f"{' = '.join(self.writers)} = NodeHandle()"]
        if base is not None:
            parts.append("# The basenode, remapped so that it talks only to this node on the topics it wraps.\n"
                         "BASENODE = [\n" + "".join(f"    {arg!r},\n" for arg in base) + "]")
            parts.append(_BASE.strip("\n"))
        if any(isinstance(s, planning.RelaySpec) for s in planning.plan(model)):
            parts.append(_RELAY.strip("\n"))
        parts += [src.rstrip("\n") for src in self.functions.values()]
        parts.append("def main():\n" + "".join(f"    {line}\n" for line in main).rstrip("\n"))
        parts.append('if __name__ == "__main__":\n    main()')
        return "\n\n\n".join(parts) + "\n"


def _import_lines(imports: dict[str, tuple[str, Optional[str]]]) -> list[str]:
    """``import m`` lines, then ``from m import a, b`` lines (one per module), sorted."""
    lines, froms = [], {}
    for name, (module, attr) in imports.items():
        if attr == name:
            froms.setdefault(module, []).append(name)
        else:
            lines.append(import_statement(name, (module, attr)))
    lines += [f"from {module} import {', '.join(sorted(names))}" for module, names in froms.items()]
    return sorted(lines, key=lambda line: (line.startswith("from"), line))


def _base_argv(model: NodeModel) -> list[str]:
    """The basenode's command line as ipyros launches it (found now; remaps as in plan.base_remaps)."""
    from .base import BaseProcess
    from .wrap import base_namespace, base_node_name

    assert model.base is not None
    base = BaseModel(**{**model.base.__dict__, "node_name": base_node_name(model.base),
                        "namespace": base_namespace(model)})
    return BaseProcess.from_model(base, remaps=planning.base_remaps(model), log_path=os.devnull).argv


def export(node: "rosNode", path: "str | os.PathLike[str]", namespace: Optional[dict] = None) -> Path:
    """Write a standalone rospy script (``#!/usr/bin/python3``) that runs ``node`` without ipyros.

    Handler globals are looked up in their closure, ``namespace`` (IPython's ``user_ns``)
    and their module: modules and importable names become imports, plain literals become
    assignments, the user's helper functions are copied; anything else becomes
    ``NAME = None  # set me`` and an :class:`ExportWarning` lists them.
    """
    script = _Script(node, path, namespace)
    text = script.render()
    compile(text, str(path), "exec")  # a generated script that does not compile is ipyros's bug: fail here
    written = _write_atomic(path, text, mode=0o755)
    if script.unset:
        warnings.warn(f"ipyros: {written} needs values for {', '.join(script.unset)} (marked '# set me'): "
                      "they are not plain literals or importable", ExportWarning, stacklevel=2)
    return written
