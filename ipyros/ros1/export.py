"""How a node is exported on ROS 1: a rospy script, and a catkin package with a launch file.

The flavour that :func:`ipyros.files.export.export` writes with (``backend.export_flavour()``):
the rospy calls of the script's ``main()``, its helpers (a byte relay as ``rospy.AnyMsg``
in and a typed publisher out), and for the package form ``package.xml``, ``CMakeLists.txt``
and ``launch/<node>.launch``, every name in them written by an XML library. No ROS
package is imported here: this writes text.
"""

from __future__ import annotations

import json
import shlex
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any, Iterable, Optional

import yaml

from ..core import plan as planning
from ..core.errors import IpyrosError
from ..files.export import package_xml, placed_on, xml_comment, xml_text
from . import cpp_export
from .nodes import command, list_packages

__all__ = ["RospyScript"]

_HANDLE = '''
class NodeHandle:
    """Stands in for the ipyros node the handlers were written for: write(topic, msg) publishes."""

    def __init__(self):
        self.publishers = {}  # resolved topic name -> rospy.Publisher, filled in by main()

    def write(self, topic, msg):
        self.publishers[rospy.resolve_name(topic)].publish(msg)
'''

_RELAY = '''
def relay(source, target, msg_class, ready=None):
    """Forward source to target unchanged: read as bytes (AnyMsg), written as bytes, never parsed.
    ready(), if given, must say yes for a message to go on. Returns the publisher and the subscriber."""
    pub = rospy.Publisher(target, msg_class, queue_size=10)  # advertised now: nothing lost at start

    def forward(raw):
        if ready is not None and not ready():
            return
        if raw._connection_header.get("latching") == "1" and not pub.impl.is_latch:
            pub.impl.enable_latch()  # latching follows the source
        pub.impl.acquire()
        try:
            pub.impl.publish(raw)  # Publisher.publish would type-check; the impl writes the bytes
        finally:
            pub.impl.release()

    return pub, rospy.Subscriber(source, rospy.AnyMsg, forward)
'''

_ACTION_RELAY = '''
def relay_action(source, target, goal, cancel, status, feedback, result):
    """Relay action source as target: its five topics, given their message classes.

    A client sends its goal as soon as it hears the server's status, so the status goes on only once
    goals and cancels reach the basenode and its feedback and results come back; else a goal sent
    at once would be lost. The server repeats its status, so nothing is lost by holding it back.
    """
    inward = [relay(f"{target}/{part}", f"{source}/{part}", cls) for part, cls in (("goal", goal), ("cancel", cancel))]
    outward = [relay(f"{source}/{part}", f"{target}/{part}", cls)
               for part, cls in (("feedback", feedback), ("result", result))]

    def connected():
        return (all(pub.get_num_connections() for pub, _ in inward)
                and all(sub.get_num_connections() for _, sub in outward))

    relay(f"{source}/status", f"{target}/status", status, ready=connected)
'''


_ACTIONS = '''
class ActionCall:
    """What an action handler gets beside the goal, as ipyros gave it: feedback(msg), cancelled, forward(goal)."""

    def __init__(self, handle, cancelled, feedback_class, forward_to, spec):
        self._handle, self._cancelled, self._feedback_class = handle, cancelled, feedback_class
        self._forward_to, self._spec = forward_to, spec
        self.forwarded = None  # the final state of a forwarded goal

    def feedback(self, msg):
        self._handle.publish_feedback(self._feedback_class(**msg) if isinstance(msg, dict) else msg)

    @property
    def cancelled(self):
        return self._cancelled.is_set()

    def forward(self, goal):
        """Send goal to the basenode's own server; its feedback goes on to the client; its result comes back."""
        # actionlib.ActionClient, not SimpleActionClient: the simple one drops what comes back before
        # its send_goal returns, so a quick server's first feedback could be lost
        client = actionlib.ActionClient(self._forward_to, self._spec)
        try:
            client.wait_for_server()
            done = threading.Event()

            def transition(handle):
                if handle.get_comm_state() == actionlib.CommState.DONE:
                    done.set()

            handle = client.send_goal(goal, transition_cb=transition, feedback_cb=lambda _, fb: self.feedback(fb))
            cancel_sent = False
            while not done.wait(0.05):
                if self.cancelled and not cancel_sent:
                    handle.cancel()
                    cancel_sent = True
            self.forwarded = handle.get_goal_status()
            return handle.get_result()
        finally:
            client.stop()


def serve_action(name, spec, result_class, feedback_class, handler, takes_action, forward_to=None):
    """Serve action name: each goal runs handler on a thread of its own; a cancel sets action.cancelled."""
    cancels = {}

    def work(handle, cancelled):
        call = ActionCall(handle, cancelled, feedback_class, forward_to, spec)
        try:
            result = handler(handle.get_goal(), call) if takes_action else handler(handle.get_goal())
        except Exception as error:  # as ipyros does: the goal is aborted, the node goes on
            rospy.logerr(f"the handler of action {name} failed: {error!r}")
            handle.set_aborted(result_class())
            return
        result = result_class(**result) if isinstance(result, dict) else result or result_class()
        if cancelled.is_set():
            handle.set_canceled(result)
        elif call.forwarded in (GoalStatus.ABORTED, GoalStatus.REJECTED):
            handle.set_aborted(result)
        else:
            handle.set_succeeded(result)

    def on_goal(handle):
        cancelled = cancels.setdefault(handle.get_goal_id().id, threading.Event())
        handle.set_accepted()
        threading.Thread(target=work, args=(handle, cancelled), daemon=True).start()

    def on_cancel(handle):
        cancels.setdefault(handle.get_goal_id().id, threading.Event()).set()

    server = actionlib.ActionServer(name, spec, on_goal, on_cancel, auto_start=False)
    server.start()
    return server
'''


def _actions_in(script: Any) -> bool:
    return any(isinstance(s, planning.ActionServerSpec) for s in script.plan())


def _action_relay(script: Any, spec: Any) -> str:
    """Relay a basenode's action: its five topics, goals and cancels in, status, feedback and results out."""
    package, stem = spec.type.split("/")
    classes = ", ".join(script.cls(type_name) for type_name in (
        f"{package}/{stem}ActionGoal", "actionlib_msgs/GoalID", "actionlib_msgs/GoalStatusArray",
        f"{package}/{stem}ActionFeedback", f"{package}/{stem}ActionResult"))
    return f"relay_action({spec.source!r}, {spec.target!r}, {classes})"


def _action_server(script: Any, spec: Any) -> str:
    package, stem = spec.type.split("/")
    return (f"serve_action({spec.name!r}, {script.cls(f'{package}/{stem}Action')}, "
            f"{script.cls(f'{package}/{stem}Result')}, {script.cls(f'{package}/{stem}Feedback')}, "
            f"{script.names[spec.slot]}, {script.takes_action(spec.slot)!r}, {spec.forward!r})")


class RospyScript:
    """The rospy flavour of an exported script (see :class:`ipyros.files.export.Script`, which asks it)."""

    LIBRARY = "rospy"
    #: How a guard's rules subscribe their inputs: an expression taking (topic, class, callback).
    LISTEN = "lambda topic, cls, hear: rospy.Subscriber(topic, cls, hear, queue_size=1)"
    #: Names the generated script defines itself; a handler global with one of them would clash.
    SCRIPT_NAMES = {"rospy", "os", "signal", "subprocess", "NodeHandle", "relay", "main", "BASENODE",
                    "BASENODE_ENV", "start_basenode", "stop_basenode", "threading", "actionlib", "GoalStatus",
                    "ActionCall", "serve_action", "relay_action"}
    #: What a wrapped action is remapped by: each of its topics (ROS 1 remaps names, not namespaces).
    action_parts = ("/goal", "/cancel", "/status", "/feedback", "/result")

    #: The basenode's command line, as the backend runs it (rosrun's lookup, or ros2 run's).
    base_command = staticmethod(command)

    @staticmethod
    def shebang() -> str:
        return "#!/usr/bin/python3"

    @staticmethod
    def about(script: Any) -> str:
        model = script.model
        run = f"rosrun {script.package} {model.name}" if script.package else f"./{Path(script.path).name}"
        lines = [f"{model.name}: a rospy node exported by ipyros from the DSL node {planning.node_fullname(model)}.",
                 "", f"It needs no ipyros: {run} [from:=to ...] [_param:=value ...]"]
        if model.base is not None:
            wrapped = f"{model.base.package}/{model.base.executable}"
            lines.append(f"It runs its basenode {wrapped} itself, remapped as ipyros ran it, and stops it on exit."
                         if script.starts_base else
                         f"Its basenode {wrapped} is started next to it, remapped as ipyros ran it, by\n"
                         f"roslaunch {script.package} {model.name}.launch (which starts this node too).")
        return "\n".join(lines)

    @staticmethod
    def stdlib(script: Any, starts_base: bool) -> list[str]:
        found = ["os", "signal", "subprocess"] if starts_base else ["os"] if script.model.namespace != "/" else []
        return found + (["threading"] if _actions_in(script) else [])

    @staticmethod
    def before_imports(script: Any) -> list[str]:
        """The namespace rospy reads at import time, set before it is imported."""
        namespace = script.model.namespace
        if namespace == "/":
            return []
        if script.package is None:
            return ["", "# Before rospy is imported: it reads its namespace then. The names below are resolved in it.",
                    f"os.environ[\"ROS_NAMESPACE\"] = {namespace!r}"]
        # roslaunch's ns= sets ROS_NAMESPACE; rosrun's __ns:= wins over it
        return ["", "# Before rospy is imported: it reads its namespace then. The names below are global.",
                f"os.environ.setdefault(\"ROS_NAMESPACE\", {namespace!r})"]

    @staticmethod
    def imports(script: Any) -> list[str]:
        return ["import actionlib", "from actionlib_msgs.msg import GoalStatus"] if _actions_in(script) else []

    @staticmethod
    def handle(script: Any) -> list[str]:
        """What the handlers' ``nd.write`` stands on."""
        return [_HANDLE.strip("\n")]

    @staticmethod
    def helpers(script: Any) -> list[str]:
        """The helpers the plan's relays need."""
        plan = script.plan()
        found = [_RELAY] if any(isinstance(s, (planning.RelaySpec, planning.ActionRelaySpec)) for s in plan) else []
        found += [_ACTION_RELAY] if any(isinstance(s, planning.ActionRelaySpec) for s in plan) else []
        return [h.strip("\n") for h in found + ([_ACTIONS] if _actions_in(script) else [])]

    @staticmethod
    def main(script: Any) -> list[str]:
        """The body of main(): the endpoints of the plan, the basenode, spin."""
        model, handle = script.model, script.writers[0]
        lines = [f"rospy.init_node({model.name!r})"]
        if model.params:
            lines += [f"for key, value in {model.params!r}.items():  # _key:=value on the command line wins",
                      '    if not rospy.has_param("~" + key):', '        rospy.set_param("~" + key, value)']
        writes_to = script.writes_to()
        for spec in script.plan():
            if isinstance(spec, planning.PublishSpec):
                latch = ", latch=True" if spec.latch else ""
                publisher = f"rospy.Publisher({spec.topic!r}, {script.cls(spec.type)}, queue_size=10{latch})"
                guarded = script.guard(spec.topic, f"{publisher}.publish")
                lines.append(f"{handle}.publishers[{writes_to[spec.topic]!r}] = {guarded or publisher}")
            elif isinstance(spec, planning.RelaySpec) and script.model.guard(spec.target) is not None:
                cls = script.cls(spec.type)  # a guarded relay reads the values it must check
                guarded = script.guard(spec.target, f"rospy.Publisher({spec.target!r}, {cls}, queue_size=10).publish")
                lines.append(f"rospy.Subscriber({spec.source!r}, {cls}, {guarded}.publish)")
            elif isinstance(spec, planning.SubscribeSpec):
                lines.append(f"rospy.Subscriber({spec.topic!r}, {script.cls(spec.type)}, {script.names[spec.slot]})")
            elif isinstance(spec, planning.RelaySpec):
                lines.append(f"relay({spec.source!r}, {spec.target!r}, {script.cls(spec.type)})")
            elif isinstance(spec, planning.TimerSpec):
                name = script.names[spec.slot]
                call = name if script.takes_event(spec.slot) else f"lambda event: {name}()"
                oneshot = ", oneshot=True" if spec.oneshot else ""
                lines.append(f"rospy.Timer(rospy.Duration({spec.period!r}), {call}{oneshot})")
            elif isinstance(spec, planning.ServiceSpec):
                lines.append(f"rospy.Service({spec.name!r}, {script.cls(spec.type, 'srv')}, {script.names[spec.slot]})")
            elif isinstance(spec, planning.ActionServerSpec):
                lines.append(_action_server(script, spec))
            elif isinstance(spec, planning.ActionRelaySpec):
                lines.append(_action_relay(script, spec))
            else:  # ServiceRelaySpec: answer with the basenode's own service
                srv = script.cls(spec.type, "srv")
                lines.append(f"rospy.Service({spec.target!r}, {srv}, rospy.ServiceProxy({spec.source!r}, {srv}))")
        if not script.starts_base:
            return lines + ["rospy.spin()"]
        return lines + ["basenode = start_basenode()", "try:", "    rospy.spin()", "finally:",
                        "    stop_basenode(basenode)"]

    # -- the package form -----------------------------------------------------------------------
    @staticmethod
    def script_file(package: str, node: str) -> tuple[str, int]:
        """Where the package holds the node, and its mode: an executable script (catkin installs it)."""
        return f"scripts/{node}", 0o755

    @staticmethod
    def package_files(script: Any, package: str) -> dict[str, tuple[str, int]]:
        """The package's files besides the script and package.xml: its launch file and CMakeLists.txt."""
        model = script.model
        return {f"launch/{model.name}.launch": (_launch_xml(script, package), 0o644),
                "CMakeLists.txt": (_CMAKE.format(package=package, node=model.name), 0o644)}

    @staticmethod
    def manifest(script: Any, package: str, files: Iterable[str], mark: str) -> str:
        return _package_xml(script, package, files, mark)

    # -- the C++ package (:mod:`.cpp_export`) ------------------------------------------------------
    @staticmethod
    def cpp_package(script: Any, package: str) -> tuple[dict[str, tuple[str, int]], cpp_export.Manifest]:
        return cpp_export.cpp_package(script, package, _launch_xml(script, package))

    @staticmethod
    def cpp_said(script: Any, package: str) -> Optional[str]:
        return cpp_export.ported_line(script, package)


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


def _dependencies(script: Any, package: str) -> list[str]:
    """The ROS packages the exported node needs at run time: rospy, the message and service packages
    it imports (``pkg.msg``/``pkg.srv``), other imports that are ROS packages, and the basenode's."""
    known = set(list_packages())
    needs = {"rospy"}
    for module, _attr in script.imports.values():
        top, _, sub = module.partition(".")
        if sub in ("msg", "srv") or top in known:
            needs.add(top)
    if script.model.base is not None and script.model.base.package:
        needs.add(script.model.base.package)
    return sorted(needs - {package})


def _package_xml(script: Any, package: str, files: Iterable[str], mark_text: str) -> str:
    model = script.model
    what = f"{model.name}: a rospy node exported by ipyros from the DSL node {planning.node_fullname(model)}"
    if model.base is not None:
        what += f", and a launch file that starts it next to its basenode {model.base.package}/{model.base.executable}"
    return package_xml(model, package, what, _dependencies(script, package), files, mark_text, format="2",
                       buildtool="catkin")


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


def _launch_xml(script: Any, package: str) -> str:
    """The launch file: the exported node with its params, and for a wrapping node its basenode placed and
    remapped as ipyros runs it (so it talks only to the exported node on the topics it wraps)."""
    model = script.model
    root = ET.Element("launch")
    wrapping = model.base is not None
    root.append(xml_comment(f"{model.name}, exported by ipyros from the DSL node {planning.node_fullname(model)}.",
                         f"roslaunch {package} {model.name}.launch starts it" +
                         (" and its basenode, which stops with it (required), as under ipyros." if wrapping else ".")))
    node = _node_element(root, package, model.name, model.name, model.namespace,
                         **({"required": "true"} if wrapping else {}))
    _add_params(node, model.params)
    if model.base is None:
        return xml_text(root)
    base = script.placed_base()
    if not base.package or not base.executable:
        raise IpyrosError(f"{model.name}'s basenode has no package, and roslaunch starts nodes by package: "
                          f"declare it with .basePackage('package') and export again")
    about = [f"The basenode {base.package}/{base.executable}, remapped onto {model.name}'s internal names:",
             f"it talks to the rest of the graph only through {model.name}, on the names it wraps.", *placed_on(base)]
    if base.launch:
        given = " ".join(f"{name}:={value}" for name, value in base.launch_args.items())
        about += [f"It is {base.launch_node} of {base.launch}" + (f" (with {given})" if given else "") +
                  ", as ipyros wrapped it there.",
                  "Start the rest of that launch file separately, without this node: roslaunch",
                  "cannot leave one node of an included file out."]
    root.append(xml_comment(*about))
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
    return xml_text(root)
