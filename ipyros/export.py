"""Export a DSL node as a standalone rospy script: the node without ipyros.

The script walks the same plan the runtime opens (:func:`ipyros.plan.plan`), so the
script and the live node cannot disagree on wrapping: publishers, subscribers with the
handlers' sources, AnyMsg relays that forward bytes, timers, services, private params,
and for a wrapping node the basenode, launched with the same remaps and stopped on exit.
Handler globals are copied in where they can be: imports, plain literals, helper sources.
"""

from __future__ import annotations

import os
import re
import types
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Optional

from . import plan as planning
from .errors import IpyrosError
from .keep import (_MISSING, _WRITER, _is_literal, _lookup, _write_atomic, global_names, handler_slots,
                   handler_source, import_of, import_statement)
from .model import BaseModel, NodeModel
from .slots import call_arity

if TYPE_CHECKING:
    from .dsl import rosNode


class ExportWarning(UserWarning):
    """The exported script has names to fill in by hand (``NAME = None  # set me``)."""


# -- the script -----------------------------------------------------------------------------------

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
