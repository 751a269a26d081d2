"""The demo robot: ipyros's small simulated robots, started from the session in one call.

Debian ships no turtlesim and no simulator, so ipyros brings its own (the ROS package
``ipyros_demo`` in ``ipyros/demo``: plain rospy nodes). A *demo robot* is one of its
launch files, started in one line::

    robot = demo_robot("turtle")    # %demo          the turtle of the paper's section III-B
    robot = demo_robot("kobuki")    # %demo kobuki   the base and speed monitor of section III-C
    robot.stop()                    # %demo --stop

The launch file says what runs (``ipyros/demo/launch/<robot>.launch``, also usable with
``roslaunch``); it uses ``<arg>``, ``$(arg)``, ``if=``/``unless=``, ``<node>``, ``<remap>``
and ``<param>``, read here as roslaunch reads them, the same on both ROS. ipyros then runs
each node itself, as a basenode of the session's ROS (the backend's ``basenode``: found
as rosrun or ros2 run finds it, its params on its command line, a log of its own, stopped
by :meth:`DemoRobot.stop` and at exit, and killed by the kernel if the interpreter is
killed), rather than through ``roslaunch``, which would start a master of its own when
none answers, and hide which node of the set failed. Python nodes run with the session's
own interpreter, which imports the session's ROS, whatever their ``#!`` line says.

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
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional

import yaml

from ..core.errors import BaseNodeError, IpyrosError, NodeStateError
from ..core.model import BaseModel
from ..demo import LAUNCH_DIR
from ..node.session import Session, current
from ..processes.basenode import BaseProcess, exit_reason

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
    """The nodes and the parameters (full name → value) of a demo launch file, with ``args`` set.

    The demo's launch files use ``<arg>``, ``$(arg)``, ``if=``/``unless=``, ``<node>``,
    ``<remap>`` and ``<param>`` only, read here as roslaunch reads them (no roslaunch needed:
    the same on both ROS). Unknown argument names are refused, naming the known ones.
    """
    known = {a.name for a in launch_args(path)}
    for name in args or {}:
        if name not in known:
            close = difflib.get_close_matches(name, sorted(known), n=1)
            hint = f"did you mean {close[0]}? " if close else ""
            raise DemoRobotError(f"{path.name} has no argument {name!r}; {hint}its arguments: {', '.join(sorted(known))}")
    root = ET.parse(path).getroot()
    values = {a.get("name", ""): a.get("value", a.get("default", "")) for a in root.findall("arg")}
    values.update({k: _launch_value(v) for k, v in (args or {}).items()})

    def text(element: ET.Element, attribute: str) -> str:
        return _ARG.sub(lambda m: values[m[1]], element.get(attribute) or "")

    def truth(element: ET.Element, attribute: str) -> bool:
        value = text(element, attribute)
        if value.lower() not in ("true", "1", "false", "0"):  # as roslaunch refuses it
            raise DemoRobotError(f"{path.name}: {value} is not a 'bool' type; give true or false")
        return value.lower() in ("true", "1")

    def wanted(element: ET.Element) -> bool:
        return ((element.get("if") is None or truth(element, "if"))
                and (element.get("unless") is None or not truth(element, "unless")))

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


_ARG = re.compile(r"\$\(arg ([\w-]+)\)")


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

class DemoRobot:
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
        self._lock = threading.RLock()

    @property
    def running(self) -> bool:
        """Whether every node of the robot is running."""
        return bool(self.processes) and all(p.running for p in self.processes.values())

    def start(self, timeout: float = 20.0) -> "DemoRobot":
        """Start every node (its params on its command line) and return once each is in the graph.

        Raises :class:`~ipyros.core.errors.BaseNodeError` if a node of the same name already
        runs elsewhere or a node does not come up; what did start is stopped again.
        """
        with self._lock:
            if self.processes:
                return self
            backend = self.session.backend
            backend.connect(self.session)  # ROS 1: the master, found or started
            for node in self.nodes:
                try:
                    backend.refuse_taken_name(node.name)
                except NodeStateError:
                    raise BaseNodeError(f"node {node.name} already runs at {backend.where()} (another session's "
                                        f"demo robot?); stop it there, or use it as it is instead of starting the "
                                        f"{self.kind} demo robot here") from None
            try:
                for node in self.nodes:
                    own = {k[len(node.name) + 1:]: v for k, v in self.params.items() if k.startswith(node.name + "/")}
                    base = BaseModel(executable=node.executable, package=node.package,
                                     node_name=node.name.rsplit("/", 1)[1],
                                     namespace=node.namespace if node.namespace != "/" else None,
                                     remaps=dict(node.remaps), params=own, args=list(node.args))
                    self.processes[node.name] = backend.basenode(base, on_exit=self._died).start()
                for node in self.nodes:
                    backend.wait_for_node(node.name, timeout=timeout, settle=0.1)
            except BaseException:
                self.stop()
                raise
            return self

    def stop(self) -> None:
        """Stop every node of the robot. Stopping twice does nothing."""
        with self._lock:
            processes, self.processes = self.processes, {}
            # All at once: each takes a moment to shut down on SIGINT, and none depends on another.
            stoppers = [threading.Thread(target=p.stop, name=f"ipyros-stop-{p.node_name}") for p in processes.values()]
            for thread in stoppers:
                thread.start()
            for thread in stoppers:
                thread.join()
            if processes:  # ROS 1: the launch file's params stay on the master unless deleted; the next start reads them
                self.session.backend.forget_params(list(self.params))

    def _died(self, process: BaseProcess, returncode: int, last_lines: list[str]) -> None:
        """A node of the robot ended without being asked: say so, with its last log lines."""
        tail = "\n    ".join(last_lines[-6:])
        self.session.notify(f"ipyros: demo robot {self.kind}: node {process.node_name} {exit_reason(returncode)}; "
                            f"start the robot again with %demo {self.kind}\n    {tail}")

    def hint(self) -> str:
        """What to try with this robot, as lines to print."""
        return "\n".join(self.spec.hint)

    def node_states(self) -> list[tuple[str, str, str, str]]:
        """Per node: its name, what runs (``pkg/executable``), its remaps, and its state now."""
        rows = []
        for node in self.nodes:
            process = self.processes.get(node.name)
            if process is None:
                how = "not started"
            elif process.running:
                how = f"pid {process.pid}"
            else:
                how = exit_reason(process.returncode or 0)
            remaps = ", ".join(f"{a} → {b}" for a, b in node.remaps.items())
            rows.append((node.name, f"{node.package}/{node.executable}", remaps, how))
        return rows

    def __repr__(self) -> str:
        state = "running" if self.running else ("stopped" if not self.processes else "partly running")
        return f"<DemoRobot {self.kind} ({state}): {', '.join(n.name for n in self.nodes)}>"


def robot_kind(kind: str) -> RobotKind:
    """The demo robot called ``kind``; a one-line error naming the known ones otherwise."""
    spec = ROBOTS.get(kind)
    if spec is None:
        close = difflib.get_close_matches(kind, sorted(ROBOTS), n=1)
        hint = f"did you mean {close[0]}? " if close else ""
        raise DemoRobotError(f"there is no demo robot {kind!r}; {hint}the demo robots: {', '.join(ROBOTS)}")
    return spec


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
    session.backend.connect(session)  # ROS 1: the master first (the extension may be starting it right now)
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
