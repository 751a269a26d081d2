"""Export a DSL node to run without ipyros: one rospy script, or a ROS package with a launch file.

The script walks the same plan the runtime opens (:func:`ipyros.core.plan.plan`), so the
script and the live node cannot disagree on wrapping: publishers, subscribers with the
handlers' sources, AnyMsg relays that forward bytes, timers, services, private params.
Handler globals are copied in where they can be: imports, plain literals, helper sources.

A wrapping node's basenode runs remapped as ipyros runs it (:func:`ipyros.node.wrapping.basenode_remaps`):
started and stopped by the script itself in the one-file form (``nd.export("node.py")``),
or by roslaunch next to the node in the package form (``nd.export("my_node_pkg")``), whose
launch file a roboticist reads like any other: ``<node>``, ``<remap>``, ``<param>``.
"""

from __future__ import annotations

import ast
import dataclasses
import getpass
import json
import os
import re
import shlex
import sys
import types
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable, Optional

import yaml

from ..core import plan as planning
from ..core.errors import IpyrosError, warn_user
from ..core.model import BaseModel, NodeModel
from ..core.slots import call_arity
from .modelfile import _WRITER, Bindings, _write_atomic, handler_slots, handler_source, import_of

if TYPE_CHECKING:
    from ..node.dsl import rosNode


class ExportWarning(UserWarning):
    """The exported script has names to fill in by hand (``NAME = None  # set me``)."""


# -- the script -----------------------------------------------------------------------------------

# Names the generated script defines itself; a handler global with one of them would clash.
_SCRIPT_NAMES = {"rospy", "os", "signal", "subprocess", "NodeHandle", "relay", "main", "BASENODE",
                 "BASENODE_ENV", "start_basenode", "stop_basenode"}

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
    proc = subprocess.Popen(BASENODE, env={**os.environ, **BASENODE_ENV}, start_new_session=True)
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


def docstring(text: str) -> str:
    """``text`` as a triple-quoted string literal that reads back as exactly ``text``.

    Names in a docstring come from the user (an export path, a basenode's path): a ``\"\"\"``
    in one would end the docstring and make the rest of the name code. So backslashes and
    quotes are escaped, and the literal is checked to read back as the text it stands for.
    """
    body = text.replace("\\", "\\\\").replace('"', '\\"')
    literal = f'"""{body}"""'
    if ast.literal_eval(literal) != text:  # ipyros's bug, not the user's: never write it
        raise IpyrosError(f"cannot write {text[:60]!r} as a docstring")
    return literal


class _Script:
    """Collects what the script needs (imports, values, functions) while it is generated.

    ``package`` None: one file that does everything, the basenode included. A package name:
    the script of that package, whose launch file starts the basenode (the script does not).
    """

    #: The client library the script imports, and the names it defines itself.
    LIBRARY = "rospy"
    SCRIPT_NAMES = _SCRIPT_NAMES

    def __init__(self, node: "rosNode", path: "str | os.PathLike[str]", namespace: Optional[dict],
                 package: Optional[str] = None) -> None:
        self.node, self.model, self.path, self.package = node, node.model(), path, package
        # The handlers' sources go in with their globals: a global named like a handler is that handler.
        self.bindings = Bindings(imports={self.LIBRARY: (self.LIBRARY, None)})
        self.imports = self.bindings.imports  # message classes join the handlers' imports
        self.names: dict[str, str] = {}  # slot → the handler's name in the script
        self.unset: dict[str, str] = {}  # global name → its "set me" line
        sources = {slot: self._handler(slot, f"{node.name} {label}") for slot, label in handler_slots(self.model)}
        self.writers = sorted({w for src in sources.values() for w in _WRITER.findall(src)}) or ["this_node"]
        for slot, _label in handler_slots(self.model):
            fn = node.handlers()[slot]
            self.bindings.bind(fn, sources[slot], namespace,
                               skip=lambda name, value, fn=fn: self._skip(fn, name, value))
            for name in [n for n in self.bindings.unbound if n not in self.unset]:
                self.unset[name] = f"{name} = None  # set me: used by handler {fn.__name__}"

    def _handler(self, slot: str, label: str) -> str:
        fn = self.node.handlers()[slot]
        source = handler_source(fn, label)
        name = fn.__name__
        if name == "<lambda>":  # a name of its own: on_turtle1_pose, timer_tick, ...
            name = re.sub(r"\W+", "_", slot.replace("topic ", "on ", 1)).strip("_")
            source = f"{name} = {source}"
        functions = self.bindings.functions
        if functions.get(name, source) != source:
            raise IpyrosError(f"two different handlers of {self.node.name} are named {name}; "
                              "rename one (def another_name(msg): ...) and declare it again")
        functions[name], self.names[slot] = source, name
        return source

    def _skip(self, fn: types.FunctionType, name: str, value: Any) -> bool:
        """Globals the script binds itself: the node the handlers write with; refuse one it needs for itself."""
        if name in self.writers:
            return True
        if name in self.SCRIPT_NAMES and import_of(value, fn.__module__) != (name, None):
            raise IpyrosError(f"handler {fn.__name__} uses the global {name}, a name the exported script "
                              "needs for itself; rename it")
        return False

    def _taken(self, name: str) -> bool:
        """Whether ``name`` means something else than an import in the script."""
        return name in self.writers or (self.bindings.has(name) and name not in self.imports)

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
                fn, name = self.node.handlers()[spec.slot], self.names[spec.slot]
                call = name if call_arity(fn, "timer", name) else f"lambda event: {name}()"
                oneshot = ", oneshot=True" if spec.oneshot else ""
                lines.append(f"rospy.Timer(rospy.Duration({spec.period!r}), {call}{oneshot})")
            elif isinstance(spec, planning.ServiceSpec):
                lines.append(f"rospy.Service({spec.name!r}, {self.cls(spec.type, 'srv')}, {self.names[spec.slot]})")
            else:  # ServiceRelaySpec: answer with the basenode's own service
                srv = self.cls(spec.type, "srv")
                lines.append(f"rospy.Service({spec.target!r}, {srv}, rospy.ServiceProxy({spec.source!r}, {srv}))")
        if not self.starts_base:
            return lines + ["rospy.spin()"]
        return lines + ["basenode = start_basenode()", "try:", "    rospy.spin()", "finally:",
                        "    stop_basenode(basenode)"]

    @property
    def starts_base(self) -> bool:
        """Whether the script runs the basenode itself (the single-file export of a wrapping node)."""
        return self.model.base is not None and self.package is None

    def _docstring(self) -> list[str]:
        model = self.model
        run = f"rosrun {self.package} {model.name}" if self.package else f"./{Path(self.path).name}"
        lines = [f"{model.name}: a rospy node exported by ipyros from the DSL node {planning.node_fullname(model)}.",
                 "", f"It needs no ipyros: {run} [from:=to ...] [_param:=value ...]"]
        if model.base is not None:
            wrapped = f"{model.base.package}/{model.base.executable}"
            lines.append(f"It runs its basenode {wrapped} itself, remapped as ipyros ran it, and stops it on exit."
                         if self.starts_base else
                         f"Its basenode {wrapped} is started next to it, remapped as ipyros ran it, by\n"
                         f"roslaunch {self.package} {model.name}.launch (which starts this node too).")
        return ["#!/usr/bin/python3", docstring("\n".join(lines))]

    def render(self) -> str:
        main = self.main()  # first: it adds the message imports
        base = _base_argv(self.model, ros2=self.LIBRARY == "rclpy") if self.starts_base else None
        head = self._head(base is not None)
        values = [*self.bindings.values.values(), *self.unset.values()]
        if values:
            head += ["", "# Globals the handlers read, as they were at export.", *values]
        parts = ["\n".join(head), *self._handle(), f"{' = '.join(self.writers)} = NodeHandle()"]
        if base is not None:
            parts.append("# The basenode, remapped so that it talks only to this node on the topics it wraps.\n"
                         "BASENODE = [\n" + "".join(f"    {arg!r},\n" for arg in base) + "]\n"
                         f"BASENODE_ENV = {self.model.base.env!r}  # its launch file's <env> tags, if any")
            parts.append(_BASE.strip("\n"))
        parts += self._relays(planning.plan(self.model))
        parts += [src.rstrip("\n") for src in self.bindings.functions.values()]
        parts.append("def main():\n" + "".join(f"    {line}\n" for line in main).rstrip("\n"))
        parts.append('if __name__ == "__main__":\n    main()')
        return "\n\n\n".join(parts) + "\n"

    def _head(self, starts_base: bool) -> list[str]:
        """The docstring and the imports (and, on ROS 1, the namespace rospy reads at import)."""
        model = self.model
        stdlib = ["os", "signal", "subprocess"] if starts_base else ["os"] if model.namespace != "/" else []
        head = [*self._docstring(), *(f"import {m}" for m in stdlib)]
        if model.namespace != "/" and self.package is None:
            head += ["", "# Before rospy is imported: it reads its namespace then. The names below are resolved in it.",
                     f"os.environ[\"ROS_NAMESPACE\"] = {model.namespace!r}"]
        elif model.namespace != "/":  # roslaunch's ns= sets ROS_NAMESPACE; rosrun's __ns:= wins over it
            head += ["", "# Before rospy is imported: it reads its namespace then. The names below are global.",
                     f"os.environ.setdefault(\"ROS_NAMESPACE\", {model.namespace!r})"]
        return head + ["", *self.bindings.import_lines(skip=stdlib)]

    def _handle(self) -> list[str]:
        """What the handlers' ``nd.write`` stands on."""
        return [_HANDLE.strip("\n")]

    def _relays(self, plan: Any) -> list[str]:
        """The helpers the plan's relays need."""
        return [_RELAY.strip("\n")] if any(isinstance(s, planning.RelaySpec) for s in plan) else []


def _placed_base(model: NodeModel) -> BaseModel:
    """The basenode as ipyros runs it: its name and namespace filled in, its own remaps composed with
    the wrapping's (:func:`ipyros.node.wrapping.basenode_remaps`, one remap per name)."""
    from ..node.wrapping import base_namespace, base_node_name, basenode_remaps

    assert model.base is not None
    return dataclasses.replace(model.base, node_name=base_node_name(model.base), namespace=base_namespace(model),
                               remaps=basenode_remaps(model))


def _base_argv(model: NodeModel, ros2: bool = False) -> list[str]:
    """The basenode's command line as ipyros launches it (its executable found now)."""
    from ..processes.basenode import BaseProcess

    return BaseProcess.from_model(_placed_base(model), log_path=os.devnull, ros2=ros2).argv


# -- the script on ROS 2 ----------------------------------------------------------------------

_HANDLE_ROS2 = '''
class NodeHandle:
    """Stands in for the ipyros node the handlers were written for: write(topic, msg) publishes."""

    def __init__(self):
        self.node = None  # the rclpy node, made by main()
        self.publishers = {}  # resolved topic name -> rclpy publisher, filled in by main()

    def write(self, topic, msg):
        self.publishers[self.node.resolve_topic_name(topic)].publish(msg)

    @property
    def params(self):
        """The node's parameters by name, as nd.params gave them (read-only here)."""
        return {name: p.value for name, p in self.node.get_parameters_by_prefix("").items()}
'''

_RELAY_ROS2 = '''
def relay(node, source, target, msg_class):
    """Forward source to target unchanged: serialized bytes, never parsed (reliable, volatile)."""
    pub = node.create_publisher(msg_class, target, qos())  # made now: nothing lost at start
    return node.create_subscription(msg_class, source, pub.publish, qos(), raw=True)
'''

_SERVICE_RELAY_ROS2 = '''
def service_relay(node, caller, source, target, srv_class):
    """Serve target by calling source, from the caller node (spun on a thread of its own, so the
    answer is taken while this callback waits for it); a caller gets the empty response after 10 s."""
    client = caller.create_client(srv_class, source)

    def answer(request, response):
        done = threading.Event()
        future = client.call_async(request)
        future.add_done_callback(lambda _: done.set())
        return future.result() if done.wait(10.0) and future.result() is not None else response

    return node.create_service(srv_class, target, answer)
'''

_QOS_ROS2 = '''
def qos(depth=1000, best_effort=False, transient_local=False):
    """As ipyros declares endpoints: reliable, volatile, 1000 deep, unless the node said otherwise."""
    return QoSProfile(depth=depth,
                      reliability=ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL if transient_local else DurabilityPolicy.VOLATILE)
'''


class _Ros2Script(_Script):
    """The one-file export on ROS 2: an rclpy node (``#!`` this Python), the basenode started with ``--ros-args``."""

    LIBRARY = "rclpy"
    SCRIPT_NAMES = {"rclpy", "os", "signal", "subprocess", "sys", "threading", "NodeHandle", "relay", "qos",
                    "service_relay", "main", "BASENODE", "BASENODE_ENV", "start_basenode", "stop_basenode",
                    "QoSProfile", "ReliabilityPolicy", "DurabilityPolicy", "SingleThreadedExecutor"}

    def main(self) -> list[str]:
        model, handle = self.model, self.writers[0]
        specs = sorted(planning.plan(model), key=lambda s: not isinstance(s, planning.PublishSpec))
        relays_services = any(isinstance(s, planning.ServiceRelaySpec) for s in specs)
        lines = ["rclpy.init(args=sys.argv)  # --ros-args: remaps, -p key:=value",
                 f"node = {handle}.node = rclpy.create_node({model.name!r}, namespace={model.namespace.rstrip('/') or '/'!r})"]
        lines += [f"node.declare_parameter({key!r}, {value!r})  # -p {key}:=... on the command line wins"
                  for key, value in model.params.items()]
        writes_to = {planning.write_target(model, t.resolved): t.resolved for t in model.topics}
        if relays_services:
            lines += ["caller = rclpy.create_node(f'_{node.get_name()}_caller', namespace=node.get_namespace())",
                      "calls = SingleThreadedExecutor()", "calls.add_node(caller)",
                      "threading.Thread(target=calls.spin, daemon=True).start()"]
        for spec in specs:
            if isinstance(spec, planning.PublishSpec):
                lines.append(f"{handle}.publishers[node.resolve_topic_name({writes_to[spec.topic]!r})] = "
                             f"node.create_publisher({self.cls(spec.type)}, {spec.topic!r}, {_qos_call(spec.qos, spec.latch)})")
            elif isinstance(spec, planning.SubscribeSpec):
                lines.append(f"node.create_subscription({self.cls(spec.type)}, {spec.topic!r}, "
                             f"{self.names[spec.slot]}, {_qos_call(spec.qos)})")
            elif isinstance(spec, planning.RelaySpec):
                lines.append(f"relay(node, {spec.source!r}, {spec.target!r}, {self.cls(spec.type)})")
            elif isinstance(spec, planning.TimerSpec):
                fn, name = self.node.handlers()[spec.slot], self.names[spec.slot]
                call = f"lambda: {name}(None)" if call_arity(fn, "timer", name) else name
                if spec.oneshot:
                    lines += [f"once = node.create_timer({spec.period!r}, lambda: (once.cancel(), ({call})()))"]
                else:
                    lines.append(f"node.create_timer({spec.period!r}, {call})")
            elif isinstance(spec, planning.ServiceSpec):
                lines.append(f"node.create_service({self.cls(spec.type, 'srv')}, {spec.name!r}, "
                             f"lambda request, response: {self.names[spec.slot]}(request))")
            else:  # ServiceRelaySpec
                lines.append(f"service_relay(node, caller, {spec.source!r}, {spec.target!r}, "
                             f"{self.cls(spec.type, 'srv')})")
        lines += ["executor = SingleThreadedExecutor()", "executor.add_node(node)"]
        if self.starts_base:
            lines.append("basenode = start_basenode()")
        lines += ["try:", "    executor.spin()", "except (KeyboardInterrupt, ExternalShutdownException):",
                  "    pass", "finally:"]
        if self.starts_base:
            lines.append("    stop_basenode(basenode)")
        return lines + ["    rclpy.try_shutdown()"]

    def _docstring(self) -> list[str]:
        model = self.model
        lines = [f"{model.name}: an rclpy node exported by ipyros from the DSL node {planning.node_fullname(model)}.",
                 "", f"It needs no ipyros: ./{Path(self.path).name} [--ros-args -r from:=to -p param:=value ...]"]
        if model.base is not None:
            lines.append(f"It runs its basenode {model.base.package or model.base.executable} itself, remapped as "
                         "ipyros ran it, and stops it on exit.")
        return [f"#!{sys.executable}", docstring("\n".join(lines))]

    def _head(self, starts_base: bool) -> list[str]:
        stdlib = ["os", "signal", "subprocess", "sys", "threading"] if starts_base else ["sys", "threading"]
        return [*self._docstring(), *(f"import {m}" for m in stdlib), "", *self.bindings.import_lines(skip=stdlib),
                "from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor",
                "from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy"]

    def _handle(self) -> list[str]:
        return [_QOS_ROS2.strip("\n"), _HANDLE_ROS2.strip("\n")]

    def _relays(self, plan: Any) -> list[str]:
        helpers = [_RELAY_ROS2] if any(isinstance(s, planning.RelaySpec) for s in plan) else []
        if any(isinstance(s, planning.ServiceRelaySpec) for s in plan):
            helpers.append(_SERVICE_RELAY_ROS2)
        return [h.strip("\n") for h in helpers]


def _qos_call(qos: Any, latch: bool = False) -> str:
    """The script's ``qos(...)`` call for a declaration's QoS (see :mod:`ipyros.core.qos`)."""
    words = []
    if qos.depth is not None or latch or qos.latched:
        words.append(f"depth={qos.depth or (1 if latch or qos.latched else 1000)}")
    if qos.reliability == "best_effort":
        words.append("best_effort=True")
    if latch or qos.latched:
        words.append("transient_local=True")
    return f"qos({', '.join(words)})"


# -- the package ----------------------------------------------------------------------------------

# The first line of the comment that marks a package.xml as ipyros's: a later export may replace the
# package, and only the files that comment lists.
_MARK = "Exported by ipyros"
_LISTED = re.compile(r"<!-- " + _MARK + r"\b.*?^\s*files: ([^\n]*)$", re.S | re.M)
# REP 144: lower case letters, digits and single underscores, starting with a letter.
_PACKAGE_NAME = re.compile(r"[a-z][a-z0-9]*(?:_[a-z0-9]+)*")

_CMAKE = """\
cmake_minimum_required(VERSION 3.0.2)
project({package})

find_package(catkin REQUIRED)
catkin_package()

# The node is a Python script: installed with its #! line pointing at the workspace's Python.
catkin_install_python(PROGRAMS scripts/{node}
  DESTINATION ${{CATKIN_PACKAGE_BIN_DESTINATION}})
install(DIRECTORY launch
  DESTINATION ${{CATKIN_PACKAGE_SHARE_DESTINATION}})
"""


def check_package_name(name: str) -> str:
    """``name`` if it is a valid ROS package name (REP 144), else a one-line :class:`IpyrosError`."""
    if len(name) < 2 or not _PACKAGE_NAME.fullmatch(name):
        raise IpyrosError(f"{name!r} is not a valid ROS package name (lower case letters, digits and single "
                          "underscores, starting with a letter): export to a directory named like my_robot_node")
    return name


def _dependencies(script: _Script, package: str) -> list[str]:
    """The ROS packages the exported node needs at run time: rospy, the message and service packages
    it imports (``pkg.msg``/``pkg.srv``), other imports that are ROS packages, and the basenode's."""
    from ..processes.basenode import list_packages

    known = set(list_packages())
    needs = {"rospy"}
    for module, _attr in script.imports.values():
        top, _, sub = module.partition(".")
        if sub in ("msg", "srv") or top in known:
            needs.add(top)
    if script.model.base is not None and script.model.base.package:
        needs.add(script.model.base.package)
    return sorted(needs - {package})


def _maintainer() -> tuple[str, str]:
    """Who maintains the package: the user, with catkin_create_pkg's placeholder address (``user@todo.todo``)."""
    try:
        user = getpass.getuser()
    except (KeyError, OSError):  # no name for this uid (e.g. in a container)
        user = "ipyros"
    return user, re.sub(r"[^-a-zA-Z0-9_%+]", "_", user) + "@todo.todo"


def _package_xml(script: _Script, package: str, files: Iterable[str]) -> str:
    """package.xml, written by an XML library (every name escaped), with the comment that marks it as ipyros's."""
    model = script.model
    user, email = _maintainer()
    what = f"{model.name}: a rospy node exported by ipyros from the DSL node {planning.node_fullname(model)}"
    if model.base is not None:
        what += f", and a launch file that starts it next to its basenode {model.base.package}/{model.base.executable}"
    root = ET.Element("package", format="2")
    for tag, text in (("name", package), ("version", "0.0.0"), ("description", what + ".")):
        ET.SubElement(root, tag).text = text
    ET.SubElement(root, "maintainer", email=email).text = user
    ET.SubElement(root, "license").text = "TODO"
    ET.SubElement(root, "buildtool_depend").text = "catkin"
    for dependency in _dependencies(script, package):
        ET.SubElement(root, "exec_depend").text = dependency
    ET.indent(root, space="  ")
    mark = ET.Comment(f" {_MARK} from the DSL node {planning.node_fullname(model)}.\n"
                      "     Exporting again replaces the package: this file and the files listed here (and only these).\n"
                      f"     files: {' '.join(sorted(files))}\n")
    return ('<?xml version="1.0"?>\n' + ET.tostring(mark, encoding="unicode") + "\n"
            + ET.tostring(root, encoding="unicode") + "\n")


def _add_params(node: ET.Element, params: dict[str, Any]) -> None:
    """Private parameters as ``<param>`` (plain scalars) or ``<rosparam>`` (YAML: lists, dicts, and strings
    that ``<param>`` would change: it strips them and expands ``$(...)`` in them)."""
    for key, value in params.items():
        name = key[1:] if key[:1] in ("~", "_") else key  # basenode params may be spelled ~rate or _rate
        kind = {bool: "bool", int: "int", float: "double", str: "str"}.get(type(value))
        if kind == "str" and (value != value.strip() or "$(" in value or "\n" in value):
            kind = None
        if kind is None:  # a string as JSON: YAML too, and on one line ("a\\nb")
            text = json.dumps(value) if isinstance(value, str) else \
                yaml.safe_dump(value, default_flow_style=True, width=1 << 20).strip()
            ET.SubElement(node, "rosparam", param=name).text = text
        else:
            text = ("true" if value else "false") if kind == "bool" else str(value) if kind == "str" else repr(value)
            ET.SubElement(node, "param", name=name, type=kind, value=text)


def _node_element(parent: ET.Element, package: str, executable: str, name: str, namespace: Optional[str],
                  **attributes: str) -> ET.Element:
    placed = {"ns": namespace} if namespace and namespace != "/" else {}
    return ET.SubElement(parent, "node", pkg=package, type=executable, name=name, **placed, output="screen",
                         **attributes)


def _launch_xml(model: NodeModel, package: str) -> str:
    """The launch file: the exported node with its params, and for a wrapping node its basenode placed and
    remapped as ipyros runs it (so it talks only to the exported node on the topics it wraps)."""
    root = ET.Element("launch")
    wrapping = model.base is not None
    root.append(_comment(f"{model.name}, exported by ipyros from the DSL node {planning.node_fullname(model)}.",
                         f"roslaunch {package} {model.name}.launch starts it" +
                         (" and its basenode, which stops with it (required), as under ipyros." if wrapping else ".")))
    node = _node_element(root, package, model.name, model.name, model.namespace,
                         **({"required": "true"} if wrapping else {}))
    _add_params(node, model.params)
    if model.base is None:
        return _xml(root)
    base = _placed_base(model)
    if not base.package or not base.executable:
        raise IpyrosError(f"{model.name}'s basenode has no package, and roslaunch starts nodes by package: "
                          f"declare it with .basePackage('package') and export again")
    about = [f"The basenode {base.package}/{base.executable}, remapped onto {model.name}'s internal names:",
             f"it talks to the rest of the graph only through {model.name}, on the names it wraps."]
    if base.launch:
        given = " ".join(f"{name}:={value}" for name, value in base.launch_args.items())
        about += [f"It is {base.launch_node} of {base.launch}" + (f" (with {given})" if given else "") +
                  ", as ipyros wrapped it there.",
                  "Start the rest of that launch file separately, without this node: roslaunch",
                  "cannot leave one node of an included file out."]
    root.append(_comment(*about))
    bad = next((arg for arg in base.args if "$(" in arg), None)
    if bad is not None:
        raise IpyrosError(f"basenode argument {bad!r} holds '$(', which roslaunch would expand: "
                          "export to a .py script instead, or change the argument")
    extra = {"args": shlex.join(base.args)} if base.args else {}
    base_node = _node_element(root, base.package, base.executable, base.node_name, base.namespace, **extra)
    for name, value in base.env.items():
        ET.SubElement(base_node, "env", name=name, value=value)
    for source, target in base.remaps.items():
        ET.SubElement(base_node, "remap", {"from": source, "to": target})
    _add_params(base_node, base.params)
    return _xml(root)


def _comment(*lines: str) -> ET.Element:
    """A comment of the launch file's top level, one line each (``--`` may not stand in a comment)."""
    return ET.Comment(" " + "\n       ".join(lines).replace("--", "- -") + " ")


def _xml(root: ET.Element) -> str:
    ET.indent(root, space="  ")
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def _previous_export(directory: Path) -> set[str]:
    """The files an earlier ipyros export listed in ``directory``; refuse a directory holding anything else."""
    if not directory.exists():
        return set()
    if not directory.is_dir():
        raise IpyrosError(f"{directory} is a file: export to a directory (a ROS package) or to a .py script")
    present = {p.relative_to(directory).as_posix() for p in directory.rglob("*") if not p.is_dir()}
    if not present:
        return set()
    try:
        found = _LISTED.search((directory / "package.xml").read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError):
        found = None
    if found is None:
        shown = ", ".join(sorted(present)[:3]) + (", ..." if len(present) > 3 else "")
        raise IpyrosError(f"{directory} holds files that ipyros did not export ({shown}): export to a new or empty "
                          "directory")
    # Only names of files inside the folder count: a package.xml may have been edited to list ../anything.
    listed = {name for name in found.group(1).split() if _inside(directory, name)}
    foreign = sorted(present - listed - {"package.xml"})
    if foreign:
        raise IpyrosError(f"{directory} is an earlier ipyros export, but holds files it did not write "
                          f"({', '.join(foreign[:3])}{', ...' if len(foreign) > 3 else ''}): move them away, or export "
                          "to another directory")
    return listed


def _inside(directory: Path, name: str) -> bool:
    """Whether ``directory / name`` is a file of ``directory`` itself (no ``..``, no link leading out)."""
    target = directory / name
    return not Path(name).is_absolute() and ".." not in Path(name).parts and \
        os.path.realpath(target).startswith(os.path.realpath(directory) + os.sep)


def export_package(node: "rosNode", directory: "str | os.PathLike[str]", namespace: Optional[dict] = None) -> Path:
    """Write the ROS package ``directory`` (named after it) that runs ``node`` without ipyros; see :func:`export`."""
    directory = Path(os.path.abspath(Path(directory).expanduser()))
    package = check_package_name(directory.name)
    model = node.model()
    script_path = directory / "scripts" / model.name
    script = _Script(node, script_path, namespace, package=package)
    text = script.render()
    compile(text, str(script_path), "exec")  # a generated script that does not compile is ipyros's bug
    files = {f"scripts/{model.name}": (text, 0o755),
             f"launch/{model.name}.launch": (_launch_xml(model, package), 0o644),
             "CMakeLists.txt": (_CMAKE.format(package=package, node=model.name), 0o644)}
    stale = _previous_export(directory) - set(files)
    try:
        for folder in ("scripts", "launch"):
            (directory / folder).mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise IpyrosError(f"cannot create {directory}: {error.strerror}") from None
    # package.xml first, listing every file that may be there: an export cut short is still replaceable.
    _write_atomic(directory / "package.xml", _package_xml(script, package, [*files, *stale]))
    for name, (content, mode) in files.items():
        _write_atomic(directory / name, content, mode=mode)
    if stale:
        for name in stale:
            if _inside(directory, name):  # listed by an earlier export, and checked so: never a file elsewhere
                (directory / name).unlink(missing_ok=True)
        _write_atomic(directory / "package.xml", _package_xml(script, package, files))
    _warn_unset(script, script_path)
    return directory


def export(node: "rosNode", path: "str | os.PathLike[str]", namespace: Optional[dict] = None) -> Path:
    """Export ``node`` to run without ipyros; return what was written.

    ``path`` ending in ``.py``: one standalone rospy script (``#!/usr/bin/python3``) that
    does everything, for a wrapping node starting and stopping its basenode itself.

    Any other ``path``: a directory, made a ROS package named after it (drop it into a
    catkin workspace's ``src/`` or put its parent on ``ROS_PACKAGE_PATH``)::

        package.xml              exec_depend on rospy, the message packages, the basenode's
        CMakeLists.txt           catkin_make installs the script and the launch file
        scripts/<node>           the node: rosrun <package> <node>
        launch/<node>.launch     the node with its params, and its basenode with its remaps

    An existing directory is replaced only if it is an earlier export (its package.xml
    says so, and it holds nothing else): nobody's own package is overwritten.

    Handler globals are looked up in their closure, ``namespace`` (IPython's ``user_ns``)
    and their module: modules and importable names become imports, plain literals become
    assignments, the user's helper functions are copied; anything else becomes
    ``NAME = None  # set me`` and an :class:`ExportWarning` lists them.
    """
    ros2 = not node.session.backend.has_master
    if Path(path).suffix != ".py":
        if ros2:
            raise IpyrosError(f"on ROS 2 a node exports to one script: give a path ending in .py, not {path!r} "
                              "(a ROS 2 package is not made yet)")
        return export_package(node, path, namespace)
    script = (_Ros2Script if ros2 else _Script)(node, path, namespace)
    text = script.render()
    compile(text, str(path), "exec")  # a generated script that does not compile is ipyros's bug: fail here
    written = _write_atomic(path, text, mode=0o755)
    _warn_unset(script, written)
    return written


def _warn_unset(script: _Script, written: Path) -> None:
    if script.unset:
        warn_user(f"ipyros: {written} needs values for {', '.join(script.unset)} (marked '# set me'): "
                  "they are not plain literals or importable", ExportWarning)
