"""The demo robot: ipyros's small simulated robots, started from the session in one call.

Debian ships no turtlesim and no simulator, so ipyros brings its own (the ROS package
``ipyros_demo`` in ``ipyros/demo``: plain rospy nodes). A *demo robot* is one of its
launch files, started in one line::

    robot = demo_robot("turtle")    # %demo          the turtle of the paper's section III-B
    robot = demo_robot("kobuki")    # %demo kobuki   the base and speed monitor of section III-C
    robot.stop()                    # %demo --stop

The launch file says what runs (``ipyros/demo/launch/<robot>.launch``, also usable with
``roslaunch``); it is read with roslaunch's own loader, so ``<arg>``, ``if=``, ``<remap>``
and ``<param>`` mean what they mean to roslaunch. ipyros then sets the parameters on
the master and runs each node itself, as a child process of the session
(:class:`~ipyros.processes.basenode.BaseProcess`: a log of its own, stopped by :meth:`DemoRobot.stop`
and at exit, and killed by the kernel if the interpreter is killed), rather than through
``roslaunch``, which would start a master of its own when none answers, and hide which
node of the set failed. Python nodes run with the session's own interpreter, which can
import rospy wherever ipyros runs (Debian, a RoboStack environment), whatever their
``#!`` line says.

One demo robot runs at a time (they share topic names): starting another stops the
first. Launch arguments are keywords: ``demo_robot("kobuki", planner=True, max_speed=3)``.
"""

from __future__ import annotations

import atexit
import difflib
import re
import shlex
import threading
import xml.etree.ElementTree as ET
import xmlrpc.client
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional

import yaml
from rich.table import Table

from ..core.errors import BaseNodeError, IpyrosError
from ..ipython.display import Shown
from ..node.session import Session, current
from ..processes.basenode import DEMO_DIR, BaseProcess, exit_reason, package_executable, python_command
from ..ros1.launchfile import fullname, one_line
from ..ros1.master import master_proxy

LAUNCH_DIR = DEMO_DIR / "launch"

#: The turtle circle of the paper's section III-B, in five lines (the README's first lines too).
TURTLE_CIRCLE = (
    "from geometry_msgs.msg import Pose, Twist, Vector3",
    "poses = []",
    'nd = rosNode("turtle_control_node")',
    'nd.new.subscribe(topic="/turtle1/pose", handler=poses.append, msgType=Pose)'
    '.publish(topic="/turtle1/cmd_vel", msgType=Twist).create()',
    'nd.timer(1.0, lambda: nd.write("/turtle1/cmd_vel", Twist(linear=Vector3(x=2.0), angular=Vector3(z=1.8))))',
)


class DemoRobotError(IpyrosError, ValueError):
    """A demo robot that does not exist, or a launch argument it does not have."""


@dataclass(frozen=True)
class RobotKind:
    """One demo robot: its launch file, what it is, the arguments ``%demo`` gives it, what to try."""

    launch: str
    about: str
    defaults: dict[str, str] = field(default_factory=dict)
    hint: tuple[str, ...] = ()

    @property
    def path(self) -> Path:
        return LAUNCH_DIR / self.launch


ROBOTS: dict[str, RobotKind] = {
    "turtle": RobotKind(
        "turtle.launch",
        "a turtle in the plane: obeys /turtle1/cmd_vel, publishes /turtle1/pose (paper, section III-B)",
        hint=("Drive it in a circle as the paper does (section III-B), five lines:",
              *(f"    {line}" for line in TURTLE_CIRCLE),
              "then look at poses[-1].position again and again (or %echo /turtle1/pose -n 1): "
              "it goes round a circle of radius 2.0/1.8 = 1.11 m.")),
    "kobuki": RobotKind(
        "kobuki.launch",
        "a mobile base obeying /mobile_base/commands/velocity and a speed monitor publishing /speed_exceeded "
        "(paper, section III-C); the planner, move_base, is left out for you to wrap (planner:=true runs it)",
        defaults={"planner": "false"},
        hint=("Wrap the planner as the paper does (section III-C): the README's \"Wrapping an existing node\", "
              "or notebooks/kobuki.ipynb;",
              "give it a goal with: %pub /move_base_simple/goal geometry_msgs/PoseStamped "
              "{pose: {position: {x: 20.0}}}")),
}


# -- launch files ---------------------------------------------------------------------------

@dataclass(frozen=True)
class LaunchArg:
    """A ``<arg>`` of a launch file that can be set (it has a default)."""

    name: str
    default: str
    doc: str = ""


@dataclass(frozen=True)
class LaunchNode:
    """A ``<node>`` of a launch file, as roslaunch would run it."""

    package: str
    executable: str
    name: str  # global: /mobile_base
    namespace: str
    args: tuple[str, ...]
    remaps: dict[str, str]


def launch_args(path: Path) -> list[LaunchArg]:
    """The top-level ``<arg>``\\ s of a launch file that have a default (the ones one may set)."""
    root = ET.parse(path).getroot()
    return [LaunchArg(a.get("name", ""), a.get("default", ""), " ".join(a.get("doc", "").split()))
            for a in root.findall("arg") if a.get("default") is not None]


def read_launch(path: Path, args: Optional[dict[str, Any]] = None) -> tuple[list[LaunchNode], dict[str, Any]]:
    """The nodes and the parameters (full name → value) of a launch file, with ``args`` set.

    Read by roslaunch's own XML loader: ``$(arg)``, ``if=``/``unless=``, ``<remap>`` and
    ``<param>`` work as in roslaunch. Unknown argument names are refused, naming the known ones.
    """
    known = {a.name for a in launch_args(path)}
    for name in args or {}:
        if name not in known:
            close = difflib.get_close_matches(name, sorted(known), n=1)
            hint = f"did you mean {close[0]}? " if close else ""
            raise DemoRobotError(f"{path.name} has no argument {name!r}; {hint}its arguments: {', '.join(sorted(known))}")
    if not current().backend.has_master:
        return _read_launch_alone(path, args or {})
    from roslaunch.config import ROSLaunchConfig
    from roslaunch.core import RLException
    from roslaunch.xmlloader import XmlLoader

    words = [f"{name}:={_launch_value(value)}" for name, value in (args or {}).items()]
    config = ROSLaunchConfig()
    try:
        XmlLoader().load(str(path), config, argv=words, verbose=False)
    except (RLException, ValueError) as error:  # a broken file; a value an if= or a <param> type refuses
        raise DemoRobotError(f"{path.name}: {one_line(error)}; see its arguments with %demo --list") \
            from None
    nodes = [LaunchNode(package=n.package, executable=n.type, name=fullname(n), namespace=n.namespace,
                        args=tuple(shlex.split(n.args or "")), remaps=dict(n.remap_args))
             for n in config.nodes]
    return nodes, {name: param.value for name, param in config.params.items()}


_ARG = re.compile(r"\$\(arg ([\w-]+)\)")


def _read_launch_alone(path: Path, args: dict[str, Any]) -> tuple[list[LaunchNode], dict[str, Any]]:
    """:func:`read_launch` where roslaunch is not installed (ROS 2): the demo's launch files use
    ``<arg>``, ``$(arg)``, ``if=``/``unless=``, ``<node>``, ``<remap>`` and ``<param>`` only,
    and those are read here as roslaunch reads them."""
    root = ET.parse(path).getroot()
    values = {a.get("name", ""): a.get("value", a.get("default", "")) for a in root.findall("arg")}
    values.update({k: _launch_value(v) for k, v in args.items()})

    def text(element: ET.Element, attribute: str) -> str:
        return _ARG.sub(lambda m: values[m[1]], element.get(attribute) or "")

    def wanted(element: ET.Element) -> bool:
        return ((element.get("if") is None or text(element, "if") in ("true", "1"))
                and (element.get("unless") is None or text(element, "unless") not in ("true", "1")))

    nodes, params = [], {}
    for element in filter(wanted, root.findall("node")):
        name = "/" + text(element, "name")
        nodes.append(LaunchNode(package=text(element, "pkg"), executable=text(element, "type"), name=name,
                                namespace="/", args=tuple(shlex.split(text(element, "args"))),
                                remaps={text(r, "from"): text(r, "to") for r in element.findall("remap") if wanted(r)}))
        # typed as roslaunch types them: 5.0 a float, true a bool, the rest a string
        params.update({f"{name}/{text(p, 'name')}": _typed(text(p, "value"))
                       for p in element.findall("param") if wanted(p)})
    return nodes, params


def _typed(text: str) -> Any:
    try:
        value = yaml.safe_load(text)
    except yaml.YAMLError:
        return text
    return value if isinstance(value, (bool, int, float)) else text


def _launch_value(value: Any) -> str:
    """A Python value as a launch argument: booleans as roslaunch spells them."""
    return str(value).lower() if isinstance(value, bool) else str(value)


# -- the robot ------------------------------------------------------------------------------

class DemoRobot(Shown):
    """A demo robot's nodes, running as child processes of the session.

    ``processes`` maps each node's global name (``/turtle_sim``) to its
    :class:`~ipyros.processes.basenode.BaseProcess`: ``robot.processes["/turtle_sim"].tail(20)`` shows
    the end of its log (``.log_path`` is the file). It displays as a table of its nodes.
    """

    def __init__(self, kind: str, args: Optional[dict[str, Any]] = None, *, session: Optional[Session] = None) -> None:
        self.kind = kind
        self.spec = robot_kind(kind)
        self.args = {**self.spec.defaults, **{k: _launch_value(v) for k, v in (args or {}).items()}}
        self.nodes, self.params = read_launch(self.spec.path, self.args)
        self.session = session or current()
        self.processes: dict[str, BaseProcess] = {}
        self.master_uri: Optional[str] = None
        self._lock = threading.RLock()

    @property
    def running(self) -> bool:
        """Whether every node of the robot is running."""
        return bool(self.processes) and all(p.running for p in self.processes.values())

    def start(self, timeout: float = 20.0) -> "DemoRobot":
        """Set the parameters, start every node, and return once each is registered with the master.

        Raises :class:`~ipyros.core.errors.BaseNodeError` if a node of the same name already
        runs elsewhere or a node does not come up; what did start is stopped again.
        """
        from .discovery import wait_for_node

        with self._lock:
            if self.processes:
                return self
            backend = self.session.backend
            ros2 = not backend.has_master  # no master: parameters go to each node, as --ros-args -p
            uri = None if ros2 else self.session.attach_master().uri
            self.master_uri = uri
            commands = {node.name: python_command(package_executable(node.package, node.executable, ros2))
                        for node in self.nodes}
            for node in self.nodes:
                if ros2:
                    backend.refuse_taken_name(None, node.name)
                else:
                    _refuse_live_node(uri, node.name, self.kind)
            if uri is not None:
                master = master_proxy(uri)
                for name, value in self.params.items():
                    master.setParam("/ipyros", name, value)
            try:
                for node in self.nodes:
                    executable, first = commands[node.name]
                    own = {k[len(node.name) + 1:]: v for k, v in self.params.items()
                           if k.startswith(node.name + "/")} if ros2 else {}
                    process = BaseProcess(executable, [*first, *node.args], node_name=node.name.rsplit("/", 1)[1],
                                          namespace=node.namespace if node.namespace != "/" else None,
                                          remaps=node.remaps, params=own, master_uri=uri, on_exit=self._died,
                                          ros2=ros2)
                    self.processes[node.name] = process.start()
                for node in self.nodes:
                    if ros2:
                        backend.wait_for_node(None, node.name, timeout=timeout)
                    else:
                        wait_for_node(uri or "", node.name, timeout=timeout, settle=0.1)
            except BaseException:
                self.stop()
                raise
            return self

    def stop(self) -> None:
        """Stop every node of the robot and remove the parameters it set. Stopping twice does nothing."""
        with self._lock:
            processes, self.processes = self.processes, {}
            # All at once: each takes a moment to shut down on SIGINT, and none depends on another.
            stoppers = [threading.Thread(target=p.stop, name=f"ipyros-stop-{p.node_name}") for p in processes.values()]
            for thread in stoppers:
                thread.start()
            for thread in stoppers:
                thread.join()
            if processes and self.master_uri:
                master = master_proxy(self.master_uri)
                for name in self.params:
                    try:
                        master.deleteParam("/ipyros", name)
                    except (OSError, xmlrpc.client.Error):  # the master is gone: nothing left to clean
                        break

    def _died(self, process: BaseProcess, returncode: int, last_lines: list[str]) -> None:
        """A node of the robot ended without being asked: say so, with its last log lines."""
        tail = "\n    ".join(last_lines[-6:])
        self.session.notify(f"ipyros: demo robot {self.kind}: node {process.node_name} {exit_reason(returncode)}; "
                            f"start the robot again with %demo {self.kind}\n    {tail}")

    def hint(self) -> str:
        """What to try with this robot, as lines to print."""
        return "\n".join(self.spec.hint)

    def __repr__(self) -> str:
        state = "running" if self.running else ("stopped" if not self.processes else "partly running")
        return f"<DemoRobot {self.kind} ({state}): {', '.join(n.name for n in self.nodes)}>"

    def __rich__(self) -> Table:
        state = "[green]running[/]" if self.running else "[yellow]stopped[/]"
        table = Table(title=f"demo robot [bold]{self.kind}[/] ({state}) from {self.spec.launch}", title_justify="left")
        for column in ("node", "runs", "remaps", "state"):
            table.add_column(column)
        for node in self.nodes:
            process = self.processes.get(node.name)
            if process is None:
                how = "not started"
            elif process.running:
                how = f"pid {process.pid}"
            else:
                how = exit_reason(process.returncode or 0)
            remaps = ", ".join(f"{a} → {b}" for a, b in node.remaps.items())
            table.add_row(node.name, f"{node.package}/{node.executable}", remaps, how)
        return table


def robot_kind(kind: str) -> RobotKind:
    """The demo robot called ``kind``; a one-line error naming the known ones otherwise."""
    spec = ROBOTS.get(kind)
    if spec is None:
        close = difflib.get_close_matches(kind, sorted(ROBOTS), n=1)
        hint = f"did you mean {close[0]}? " if close else ""
        raise DemoRobotError(f"there is no demo robot {kind!r}; {hint}the demo robots: {', '.join(ROBOTS)}")
    return spec


def _refuse_live_node(uri: str, name: str, kind: str) -> None:
    """Refuse to start a node whose name a live node has: the master would shut that one down."""
    try:
        code, _, node_uri = master_proxy(uri).lookupNode("/ipyros", name)
        if code != 1:
            return
        xmlrpc.client.ServerProxy(node_uri).getPid("/ipyros")  # a stale registration does not answer
    except (OSError, xmlrpc.client.Error):
        return
    raise BaseNodeError(f"node {name} already runs on the master at {uri} (another session's demo robot?); "
                        f"stop it there, or use it as it is instead of starting the {kind} demo robot here")


# -- the one running robot -----------------------------------------------------------------

_running: Optional[DemoRobot] = None
_running_lock = threading.Lock()


def demo_robot(kind: str = "turtle", *, session: Optional[Session] = None, **args: Any) -> DemoRobot:
    """Start the demo robot ``kind`` (``"turtle"`` or ``"kobuki"``) and return it, running.

    Keywords set its launch file's arguments (``max_speed=3.0``, ``noise=0.01``,
    ``planner=True``). If the same robot with the same arguments already runs, it is
    returned as it is; another one is stopped first (one runs at a time).
    """
    global _running
    robot_kind(kind)  # a wrong name is an error at once, even without a master
    session = session or current()
    # The master first: extension loading may be starting it on a thread of its own right now.
    # Reading the launch file imports roslaunch, and a first import while that thread forks can
    # deadlock (the fork's at-fork hooks against the import lock), so the import waits until it is done.
    if session.backend.has_master:
        session.attach_master()
    robot = DemoRobot(kind, args, session=session)
    with _running_lock:
        previous = _running
        if previous is not None and previous.running and (previous.kind, previous.args) == (robot.kind, robot.args):
            return previous
        if previous is not None:
            previous.stop()
        _running = robot
    session.on_close(stop_demo_robot)  # an explicit session.close() stops it too, before the master
    return robot.start()


def running_robot() -> Optional[DemoRobot]:
    """The demo robot started by :func:`demo_robot`, if it still runs."""
    robot = _running
    return robot if robot is not None and robot.processes else None


def stop_demo_robot() -> Optional[DemoRobot]:
    """Stop the demo robot started by :func:`demo_robot`; returns it, or None if none ran."""
    global _running
    with _running_lock:
        robot, _running = _running, None
    if robot is None or not robot.processes:
        return None
    robot.stop()
    return robot


# Registered after the session's own exit hook (this module imports it), so it runs first:
# the robot stops while the master it talks to is still there.
atexit.register(stop_demo_robot)

__all__ = ["ROBOTS", "TURTLE_CIRCLE", "DemoRobot", "DemoRobotError", "LaunchArg", "LaunchNode", "demo_robot",
           "launch_args", "read_launch", "robot_kind", "running_robot", "stop_demo_robot"]
