"""The paper's internal DSL: ``rosNode``, ``new``/``reuse``, ``subscribe``, ``publish``, ``create``, ``write``.

Each call validates its input and edits the node's :class:`~ipyros.core.model.NodeModel`
through its :class:`~ipyros.node.engine.NodeEngine`, which makes the live node match at once
once the node runs (:mod:`ipyros.core.plan` says which endpoints must exist; the session's
backend, :mod:`ipyros.node.backend`, opens and closes them). A rejected declaration raises a
one-line error and changes nothing, neither model nor running node. A ``rosNode`` holds the
DSL and nothing else: ``nd.<TAB>`` shows the paper's methods and how to keep the work.

    nd = rosNode("turtle_control_node")
    (nd.new.subscribe(topic="/turtle1/pose", handler=showPose, msgType=Pose)
           .publish(topic="/turtle1/cmd_vel", msgType=Twist))
    nd.create()
    nd.write("/turtle1/cmd_vel", msg)
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Callable, Optional

from ..core import names
from ..core.actions import SentGoal
from ..core.errors import DeclarationError, NotDeclaredError, cut
from ..core.guard import DEFAULT_MACHINE_GRACE
from ..core.model import NodeModel
from ..core.records import History, NodeStatus, Versions
from ..node import declaring
from ..node.engine import NodeEngine
from ..node.session import Session, current
from ..node.baseinterface import discover
from ..node.wrapping import set_bag, set_base, set_launch_base, set_machine
from . import keeping
from .declarations import UNSET, NodeParams, TopicHandler

__all__ = ["engine_of", "node_of", "restore", "rosNode", "shutdown"]


class rosNode:  # noqa: N801 - the paper's name
    """A ROS node declared, created and reshaped from the prompt.

    ``namespace`` defaults to ``ROS_NAMESPACE`` (or ``/``). Several rosNodes can live in one
    session (on ROS 1 they share the process's one rospy node; see the README).
    """

    def __init__(self, name: str = UNSET, namespace: Optional[str] = None, *, session: Optional[Session] = None,
                 **unknown: Any) -> None:
        if name is UNSET or unknown:
            given = f"got unknown keyword argument(s) {', '.join(sorted(unknown))}; it" if unknown else "needs a name:"
            raise TypeError(f"rosNode() {given} takes name and namespace, e.g. rosNode('turtle_control_node') "
                            "or rosNode('planner', namespace='/robot1')")
        session = session or current()
        rules = session.backend.name_rules
        ns = names.default_namespace() if namespace is None else names.check_namespace(namespace, rules)
        model = NodeModel(name=names.check_node_name(name, rules), namespace=ns)
        # A wrapping node without a namespace of its own lives in its basenode's (see wrapping.set_base).
        self._engine = NodeEngine(self, model, session, explicit_namespace=namespace is not None)
        self.new = TopicHandler(self, "new")
        self.reuse = TopicHandler(self, "reuse")
        self.params = NodeParams(self._engine)

    # -- what it is ---------------------------------------------------------------------------
    @property
    def name(self) -> str:
        return self._engine.name

    @property
    def fullname(self) -> str:
        return self._engine.fullname

    @property
    def created(self) -> bool:
        """Whether the node runs (``create()`` was called and ``shutdown()`` not since)."""
        return self._engine.created

    @property
    def ros_name(self) -> Optional[str]:
        """The ROS node that hosts this node's endpoints while it runs: on ROS 1 the process's one, which
        the session's DSL nodes share (rospy allows one); on ROS 2 a node of its own, of its own name."""
        if not self.created:
            return None
        process = self._engine.session.process
        return process.name if process.shared else self.fullname

    @property
    def base(self) -> Any:
        """The running basenode (``tail()``, ``stop()``, ``restart()``), or None."""
        return self._engine.base

    @property
    def basenode_name(self) -> Optional[str]:
        """The basenode's full ROS name (``/move_base``), or None for a node that wraps nothing."""
        return self._engine.basenode_name

    def model(self) -> NodeModel:
        """A copy of the declared structure, as plain data."""
        return self._engine.model()

    def handler(self, topic: str) -> Optional[Callable[..., Any]]:
        """The function now serving subscription ``topic`` (or the service or timer of that name)."""
        return self._engine.handler(topic)

    def resolve(self, name: str) -> str:
        """The global name ``name`` has for this node."""
        return self._engine.resolve(name)

    # -- the basenode ----------------------------------------------------------------
    def baseNode(self, executable: str, **options: Any) -> "rosNode":  # noqa: N802 - the paper's name
        """Wrap the basenode run by ``executable`` (its package is given by :meth:`basePackage`).

        Options: ``name`` (node name, default the executable's), ``namespace``, ``remaps``
        (dict), ``params`` (private parameters), ``args`` (list of arguments), ``env`` (dict of
        environment variables it gets beside the session's). A Python script whose ``#!`` line
        names an interpreter of its own (a workspace's venv) runs with that one.
        """
        set_base(self._engine, executable=executable, **options)
        return self

    def basePackage(self, package: str) -> "rosNode":  # noqa: N802 - the paper's name
        """The package of the basenode, found as rosrun (ROS 2: ros2 run) finds it."""
        set_base(self._engine, package=package)
        return self

    def machine(self, name: Optional[str], grace: Optional[float] = DEFAULT_MACHINE_GRACE) -> "rosNode":
        """Run the basenode on the robot's machine ``name``, whose keeper starts it there (``python -m ipyros.machine
        --name NAME --allow PKG`` runs on the robot; its token is copied here, see the guide's "A robot on another
        machine"). It runs beside the robot's drivers, with the remaps, parameters and arguments declared here; the
        keeper stops it when this session is not heard for ``grace`` seconds (None: it is left running), and when
        the keeper itself ends. ``machine(None)`` brings it back to this machine.
        """
        set_machine(self._engine, name, grace)
        return self

    def baseLaunch(self, launch: str, node: str, args: Optional[dict[str, Any]] = None,
                   **arg_values: Any) -> "rosNode":  # noqa: N802 - named like baseNode
        """Wrap the node ``node`` that the launch file ``launch`` starts (``/robot1/planner``).

        The file's ``<arg>`` values are given as keywords (``rate=5``) or, for names that
        are not Python identifiers, as ``args={"use-sim": True}``, like
        ``roslaunch FILE rate:=5``. Its package, executable, name, namespace, remaps,
        params and args come from the launch file; ``create()`` runs the rest of the launch
        file untouched, and this node wrapped where it was. The file itself is not edited.
        """
        if args is not None and not isinstance(args, dict):
            raise DeclarationError(f"baseLaunch(args={cut(args)}): give a dict of the launch file's args, "
                                   "e.g. args={'rate': 5}")
        set_launch_base(self._engine, launch, node, {**(args or {}), **arg_values})
        return self

    def baseBag(self, path: Any, rate: float = 1.0, loop: bool = False, topics: Optional[list[str]] = None,
                delay: float = 5.0, clock: bool = False) -> "rosNode":  # noqa: N802 - named like baseNode
        """Wrap a recorded bag as the basenode: a bag player (like ``rosbag play``) publishes its
        topics, remapped like any basenode's, so that ``reuse`` and ``new.subscribe`` work on
        recorded data as on a live node, and ``nd.base.restart()`` plays it again (after a
        handler change: the same messages, new behaviour).

        ``rate`` scales the playing speed, ``loop`` plays it again and again, ``topics`` plays
        only these; the player waits until each topic has a subscriber, ``delay`` seconds at most.
        ``clock``: the player publishes the bag's time on ``/clock`` as it plays, and this node
        runs on it (``nd.now()``, and on ROS 2 its timers; see the guide's "Recorded data"). ``%bag
        pause NODE`` (resume, step, seek, rate, loop) drives it while it plays.
        """
        set_bag(self._engine, path, rate, loop, topics, delay, clock)
        return self

    def discover(self, timeout: float = 10.0) -> Any:
        """Run the basenode once, read its topics and services from the graph, reuse them all.

        Returns the discovered interface (it displays as a table).
        """
        return discover(self._engine, timeout)

    # -- its life ------------------------------------------------------------------
    def create(self) -> "rosNode":
        """Start the node: everything declared so far begins to run."""
        self._engine.create()
        return self

    def shutdown(self) -> None:
        """Stop the node's publishers, subscribers, timers, services and its basenode."""
        self._engine.shutdown()

    def now(self) -> float:
        """The node's ROS time, in seconds: the bag's time while a ``baseBag(..., clock=True)`` plays (0 until
        its first /clock), else the system's. On ROS 2 its timers run on the same clock."""
        return self._engine.now()

    # -- timers -----------------------------------------------------------------------
    def timer(self, period: float, handler: Callable[..., Any], *, name: Optional[str] = None,
              oneshot: bool = False) -> "rosNode":
        """Call ``handler`` every ``period`` seconds (once if ``oneshot``).

        Declaring a timer with the same ``name`` (default: the handler's name) replaces it.
        """
        declaring.timer(self._engine, period, handler, name, oneshot)
        return self

    # -- parameters set from outside ------------------------------------------------------
    def on_param(self, key: str, handler: Optional[Callable[[Any], Any]]) -> "rosNode":
        """Call ``handler(value)`` whenever someone else sets this node's parameter ``key`` (``~key``).

        A tuning tool, ``rosparam set`` / ``ros2 param set``, a launch of another node: a
        node usually reads its gains once; this one hears each new value while it runs
        (ROS 1: the master tells the nodes that subscribed to a parameter; ROS 2: the node's
        own parameter services). Setting it here, ``nd.params[key] = v``, is not news and calls
        nothing. ``key`` must have a value first (``nd.params[key] = default``); ``None`` stops
        the calls. A handler that raises is told at the prompt; the node runs on.
        """
        if handler is not None and not callable(handler):
            raise DeclarationError(f"on_param({key!r}, ...) takes a function of the new value, "
                                   f"e.g. lambda value: print(value); not {cut(handler)}")
        self._engine.params.on_param(self.params._key(key), handler)
        return self

    # -- removal ---------------------------------------------------------------------
    def remove(self, topic: Optional[str] = None, *, timer: Optional[str] = None,
               service: Optional[str] = None, action: Optional[str] = None, guard: Optional[str] = None) -> "rosNode":
        """Remove every declaration of ``topic``, or the named ``timer``, ``service``, ``action`` or ``guard``
        (a guarded output is removed only after its guard, by its own call)."""
        for kind, name in (("guard", guard), ("topic", topic), ("timer", timer), ("service", service),
                           ("action", action)):
            if name is not None:
                declaring.remove(self._engine, kind, name)
        return self

    # -- safety: guards on its outputs ---------------------------------------------------
    def guard(self, topic: str, *, limits: Optional[dict] = None, timeout: Optional[float] = None,
              stop: Any = None, on_limit: str = "clamp", rate: Optional[dict] = None,
              estop_topic: Optional[str] = None, grace: float = 3.0, repeat: float = 10.0,
              machine: Optional[str] = None, lease: Optional[float] = None,
              machine_grace: Optional[float] = 30.0, rules: Optional[list] = None,
              stale: Optional[dict] = None) -> "rosNode":
        """Guard the output ``topic``: every message that leaves the node there passes the guard first, whatever
        sent it (a handler, ``write``, ``%pub``, the relay of the basenode's output).

        ``limits={"linear.x": (-0.5, 0.5)}`` bounds numeric fields by path (``axes[2]``, ``poses[*].x``): a value
        outside is clamped, or with ``on_limit="drop"`` the message is not sent; ``rate={"linear.x": 1.0}`` bounds
        a field's change per second; NaN and infinities never pass (the stop message goes instead). After
        ``timeout`` seconds with nothing passing, a process of the session's own sends ``stop`` (fields, or a
        message; default: the type's zero message) at ``repeat`` Hz until a command passes, even when the
        session is frozen or killed; when the session ends it holds the stop for ``grace`` s (at most 10).
        ``estop_topic`` (``std_msgs/Bool``) trips the e-stop from anywhere. Declared again, the rules change
        live. ``machine="robot1"`` places the guard on the robot, in its keeper (``python -m ipyros.machine``):
        the node's messages go there to be checked, and the robot holds the stop message when it has not heard
        this session for ``lease`` s (0.5), a lost link too; it ends the guard after ``machine_grace`` s (30).
        ``rules=[rule("min(/scan.ranges) < 0.5", limit={"linear.x": (-0.2, 0.2)}), ...]`` act on what the robot
        senses (``limit``, ``scale``, ``only``, ``stop``; see :func:`ipyros.rule`), ``stale={"/scan": 0.3}`` says
        how old an input's last message may be: an input never heard or stale is a stop.
        Not certified functional safety: the robot's hardware e-stop stays the last line.
        """
        declaring.guard(self._engine, topic, limits, rate, on_limit, timeout, stop, repeat, grace, estop_topic,
                        machine, lease, machine_grace, rules, stale)
        return self

    def estop(self) -> list[str]:
        """Put every guarded output of this node to its stop message at once, and hold it there until
        :meth:`release`, whatever else arrives; the topics."""
        return self._engine.estop(True)

    def release(self) -> list[str]:
        """Let commands through the guards again after :meth:`estop`; the topics."""
        return self._engine.estop(False)

    # -- actions as a client ----------------------------------------------------------
    def send_goal(self, name: str, goal: Any = None, type: Any = None,  # noqa: A002 - as for topics
                  feedback: Optional[Callable[[Any], None]] = None, timeout: float = 10.0) -> SentGoal:
        """Send ``goal`` (a Goal message or a dict of its fields) to action server ``name``; returns at once.

        ``type`` is the action's type (``"test_msgs/Fibonacci"``), read from the graph when not
        given; ``feedback(msg)`` is called with each feedback. The returned goal has
        ``result(timeout)``, ``cancel()``, ``status`` and ``feedback`` (see :mod:`ipyros.core.actions`).
        ``timeout``: how long the server may take to show up.
        """
        return self._engine.writing.send_goal(name, goal, type, feedback, timeout)

    # -- writing ----------------------------------------------------------------------
    def write(self, topic: str, msg: Any) -> None:
        """Publish ``msg`` on ``topic``, which this node must publish."""
        self._engine.writing.write(topic, msg)

    # -- keeping the work (the formats are the files layer's; dsl/keeping.py brings them here) ------
    def save(self, path: Any, namespace: Optional[dict] = None) -> Path:
        """Save the node to ``path``: ``.py`` as runnable DSL code, ``.yaml``/``.json`` as its model.

        The Python file (:mod:`ipyros.files.savefile`) brings the node back running when run;
        the model file (:mod:`ipyros.files.modelfile`, docs/model.md) is the node model plus handler
        sources, for tools. Handlers' globals are looked up in ``namespace`` first.
        """
        if not isinstance(path, (str, os.PathLike)):
            raise DeclarationError(f"save({cut(path)}): give a path ending in .py, .yaml or .json")
        if Path(path).expanduser().is_dir():
            raise DeclarationError(f"save({str(path)!r}): that is a directory; give a file, e.g. "
                                   f"{os.path.join(str(path), self.name + '.py')!r}")
        return keeping.save(self._engine, path, namespace)

    @classmethod
    def load(cls, path: Any, namespace: Optional[dict] = None, create: bool = False, *,
             session: Optional[Session] = None, trust: bool = False) -> "rosNode":
        """Bring back a node saved by :meth:`save` (``.py`` runs the file; a model file is declared).

        Handlers are defined in ``namespace`` (in IPython: ``get_ipython().user_ns``); a
        ``.py`` file creates the node if it was running when saved; ``create=True`` also
        creates a node loaded from a model file. A model file that would run anything
        (handler sources, imports, a basenode) is refused unless ``trust=True``: it looks like
        data, so nothing in it runs without being asked; a ``.py`` file is code and runs as such.
        """
        return keeping.load(cls, path, namespace, create=create, session=session, trust=trust)

    @classmethod
    def running(cls, name: str, *, session: Optional[Session] = None) -> "rosNode":
        """The running node of this session called ``name`` (``/turtle_control_node``, or without the ``/``):
        how to reach a node whose variable now holds something else."""
        session = session or current()
        wanted = names.join("/", name) if not name.startswith("/") else name
        engine = session.nodes.get(wanted)
        if engine is None or not engine.created:
            known = ", ".join(sorted(n for n, e in session.nodes.items() if e.created)) or "none"
            raise NotDeclaredError(f"no node {wanted} is running in this session (running: {known})")
        return node_of(engine)

    def export(self, path: Any, namespace: Optional[dict] = None, language: str = "python") -> Path:
        """Export this node to run without ipyros: a ``.py`` path is one standalone script; any other
        path becomes a ROS package (ROS 1: catkin, with launch/<node>.launch starting its basenode; ROS 2:
        ament_python, built by colcon). ``language="cpp"`` (ROS 1): the package's node is roscpp C++ whose
        relays, declarations, parameters and guards are complete and whose handlers are to be ported by hand
        (PORTING.md lists them); see :mod:`ipyros.files.export`."""
        if not isinstance(path, (str, os.PathLike)):
            raise DeclarationError(f"export({cut(path)}): give a path: 'my_node.py' (one script) or 'my_node_pkg' "
                                   "(a ROS package)")
        if language not in ("python", "cpp"):
            raise DeclarationError(f"export(language={cut(language)}): give 'python' or 'cpp'")
        return keeping.export(self._engine, path, namespace, language)

    # -- what it did ---------------------------------------------------------------
    def status(self) -> NodeStatus:
        """Per topic, timer and service: rate, handler time and exception count."""
        return self._engine.status()

    def history(self) -> History:
        """Every change of this node so far, oldest first (a table in IPython)."""
        return self._engine.history()

    def versions(self, what: str) -> Versions:
        """Every function the handler of ``what`` (a topic, timer name or service) was given, oldest first.

        Displays as a table; ``nd.versions("cmd_vel")[0].source`` is the first one's source.
        """
        return self._engine.handlers_of.versions(what)

    def revert(self, what: str, version: int) -> "rosNode":
        """Serve ``what`` with handler ``version`` again (see :meth:`versions`), live, no message lost."""
        self._engine.handlers_of.revert(what, version)
        return self

    def restore_versions(self, what: str, versions: list[tuple[str, str]], current: Optional[int] = None) -> "rosNode":
        """Give the handler of ``what`` its past: every version as ``(time, source)``, oldest first.

        Version ``current`` (default: the last) is the function serving now; the others
        are kept as source and compiled by :meth:`revert` when chosen, in the namespace
        of the handler then serving. This is how a saved file brings versions back.
        """
        self._engine.handlers_of.restore(what, versions, current)
        return self

    def __repr__(self) -> str:
        model = self._engine.model()
        state = "running" if self.created else "declared"
        actions = f", {len(model.actions)} actions" if model.actions else ""
        return f"<rosNode {self.fullname} ({state}): {len(model.topics)} topics, " \
               f"{len(model.timers)} timers, {len(model.services)} services{actions}>"


def shutdown(*nodes: rosNode) -> None:
    """Shut ``nodes`` down together (every node of the session when none is given): their basenodes are all asked to
    stop at once and waited for side by side, so that leaving 50 wrapped basenodes takes seconds, not a minute."""
    if not all(isinstance(node, rosNode) for node in nodes):
        wrong = next(node for node in nodes if not isinstance(node, rosNode))
        raise DeclarationError(f"shutdown({cut(wrong)}): give rosNodes, e.g. shutdown(nd1, nd2), or none for all")
    sessions = {id(node._engine.session): node._engine.session for node in nodes} or {id(current()): current()}
    for session in sessions.values():
        mine = [node._engine for node in nodes if node._engine.session is session] if nodes else None
        session.shutdown_nodes(mine)


def engine_of(node: rosNode) -> NodeEngine:
    """The engine of ``node``: how ipyros's own modules use a node (the user sees the DSL only)."""
    return node._engine


def node_of(engine: NodeEngine) -> rosNode:
    """The rosNode the user holds for ``engine`` (its ``owner``: the node layer keeps it for identity only)."""
    owner = engine.owner
    assert isinstance(owner, rosNode), owner
    return owner


def restore(path: "str | os.PathLike[str]", namespace: Optional[dict] = None) -> list[rosNode]:
    """Run the file ``path`` that ``nd.save``/``%save_nodes`` wrote, in ``namespace`` (default: a fresh one);
    return the nodes it made (see :func:`ipyros.dsl.keeping.restore`)."""
    return keeping.restore(rosNode, path, namespace)
