"""The node model: what a DSL node is declared to be, as plain data.

Every DSL call edits one of these; the runtime makes the running ROS world match it,
and save, export and display read it. Nothing here touches ROS. Handlers are kept as
names (``module.qualname``-free, just the function's ``__name__``): the live function
objects belong to the DSL node, not to the model, so the model can be saved as JSON/YAML.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields
from typing import Any, Literal, Optional

Direction = Literal["publish", "subscribe"]
Role = Literal["new", "reuse"]


@dataclass
class TopicModel:
    """One declared topic of a node.

    ``name`` is the name as the user typed it; ``resolved`` is the global name ROS
    gives it (relative names resolve in the node's namespace, ``~`` under the node).
    ``qos`` holds the QoS fields given (see :mod:`ipyros.core.qos`), None for the defaults.
    """

    name: str
    resolved: str
    direction: Direction
    type: str
    role: Role = "new"
    handler: Optional[str] = None
    latch: bool = False
    qos: Optional[dict[str, Any]] = None


@dataclass
class TimerModel:
    """A periodic callback of the node; ``name`` identifies it for replace and remove."""

    name: str
    period: float
    handler: str
    oneshot: bool = False


@dataclass
class ServiceModel:
    """A service the node provides (``new``) or relays from its basenode (``reuse``)."""

    name: str
    resolved: str
    type: str
    role: Role = "new"
    handler: Optional[str] = None


@dataclass
class ActionModel:
    """An action the node serves (``new``: its handler gets each goal) or relays from its basenode (``reuse``).

    ``type`` is ``"pkg/Type"`` on both ROS (``actionlib/TwoInts``, ``test_msgs/Fibonacci``).
    """

    name: str
    resolved: str
    type: str
    role: Role = "new"
    handler: Optional[str] = None


@dataclass
class GuardModel:
    """A safety guard on an output of the node (see :mod:`ipyros.core.guard`): every message that leaves the node
    on ``resolved`` passes it.

    ``limits`` bounds numeric fields by path (``{"linear.x": [-0.5, 0.5]}``), ``rate`` their change per second,
    ``on_limit`` says what a value outside does (``"clamp"`` or ``"drop"``); after ``timeout`` seconds of
    silence the ``stop`` message is sent (its fields; None: the type's zero message), again at ``repeat`` Hz,
    and held ``grace`` seconds after the session ends; ``estop_topic`` (a ``std_msgs/Bool``) trips it too.
    ``machine`` places it on another machine's keeper (see :mod:`ipyros.processes.keeper`), which holds the stop
    message when the session is not heard for ``lease`` seconds and ends the guard after ``machine_grace`` (None:
    never). ``rules`` are conditions over what the robot senses and what the guard does while one holds, and
    ``stale`` how old an input's last message may be (see :mod:`ipyros.core.rules`). Plain data: a guard in a
    model file runs without ``trust`` (a rule's condition is compiled from a whitelist, never run as code).
    """

    name: str
    resolved: str
    type: str
    limits: dict[str, list[float]] = field(default_factory=dict)
    rate: dict[str, float] = field(default_factory=dict)
    on_limit: str = "clamp"
    timeout: Optional[float] = None
    stop: Optional[dict[str, Any]] = None
    repeat: float = 10.0
    grace: float = 3.0
    estop_topic: Optional[str] = None
    machine: Optional[str] = None
    lease: float = 0.5
    machine_grace: Optional[float] = 30.0
    rules: list[dict[str, Any]] = field(default_factory=list)  # each as :meth:`ipyros.core.rules.Rule.as_data`
    stale: dict[str, float] = field(default_factory=dict)  # an input topic → the seconds its last message is good


@dataclass
class BaseModel:
    """The basenode a wrapping node wraps: found as ``rosrun package executable`` finds it.

    A basenode read from a launch file (``baseLaunch``) also keeps ``launch``, the file
    (absolute, or ``$(find pkg)/...`` as written), ``launch_node``, its full name in it,
    and ``launch_args``, the ``<arg>`` values it was read with (as ``roslaunch file a:=1``);
    its ``env`` comes from the file's ``<env>`` tags. A recorded bag as the basenode
    (``baseBag``) keeps ``bag``: its path and how it is played (``rate``, ``loop``,
    ``topics``, ``delay``), beside the player it runs as. ``own_name`` is the name its own code
    gives its node, read from its source when it is declared (``node_name`` is the one given).
    """

    executable: Optional[str] = None
    package: Optional[str] = None
    node_name: Optional[str] = None
    own_name: Optional[str] = None
    namespace: Optional[str] = None
    remaps: dict[str, str] = field(default_factory=dict)
    params: dict[str, Any] = field(default_factory=dict)
    args: list[str] = field(default_factory=list)
    env: dict[str, str] = field(default_factory=dict)
    launch: Optional[str] = None
    launch_node: Optional[str] = None
    launch_args: dict[str, str] = field(default_factory=dict)
    bag: Optional[dict[str, Any]] = None
    #: The machine whose keeper runs it (``.machine("robot1")``), and how long that keeper waits to hear the
    #: session before it stops it (s; None: it is left running).
    machine: Optional[str] = None
    machine_grace: Optional[float] = 30.0

    def describe(self) -> str:
        """The basenode in a few words, as a person names it: ``ipyros_demo/move_base``, ``bag /data/run1.bag``,
        ``/planner of nav.launch``, or the path of a script run by path."""
        if self.bag:
            return f"bag {self.bag.get('path')}"
        if self.launch:
            return f"{self.launch_node or self.node_name} of {self.launch}"
        if self.package:
            return f"{self.package}/{self.executable}"
        return str(self.executable or "?")


@dataclass
class NodeModel:
    """Everything declared about one DSL node."""

    name: str
    namespace: str = "/"
    base: Optional[BaseModel] = None
    topics: list[TopicModel] = field(default_factory=list)
    timers: list[TimerModel] = field(default_factory=list)
    services: list[ServiceModel] = field(default_factory=list)
    params: dict[str, Any] = field(default_factory=dict)
    actions: list[ActionModel] = field(default_factory=list)
    guards: list[GuardModel] = field(default_factory=list)

    # -- queries -------------------------------------------------------------
    def topic(self, resolved: str, direction: Direction, role: Optional[Role] = None) -> Optional[TopicModel]:
        """The declared topic with this resolved name and direction (and role), if any."""
        for t in self.topics:
            if t.resolved == resolved and t.direction == direction and (role is None or t.role == role):
                return t
        return None

    def publications(self) -> list[TopicModel]:
        return [t for t in self.topics if t.direction == "publish"]

    def subscriptions(self) -> list[TopicModel]:
        return [t for t in self.topics if t.direction == "subscribe"]

    def timer(self, name: str) -> Optional[TimerModel]:
        return next((t for t in self.timers if t.name == name), None)

    def service(self, resolved: str) -> Optional[ServiceModel]:
        return next((s for s in self.services if s.resolved == resolved), None)

    def action(self, resolved: str, role: Optional[Role] = None) -> Optional[ActionModel]:
        return next((a for a in self.actions if a.resolved == resolved and (role is None or a.role == role)), None)

    def guard(self, resolved: str) -> Optional[GuardModel]:
        return next((g for g in self.guards if g.resolved == resolved), None)

    def outputs(self) -> list[TopicModel]:
        """What the node sends to the world: its new publications and the basenode's outputs it relays or takes over
        (the topics a guard may stand on)."""
        return [t for t in self.topics if t.direction == "publish"]

    # -- plain data ----------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """A JSON/YAML-ready dict (only str, float, bool, list, dict, None)."""
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> "NodeModel":
        """Inverse of :meth:`to_dict`; unknown keys are an error, not silently dropped."""
        if not isinstance(data, dict):
            raise ValueError(f"a node must be a mapping of its fields, not {type(data).__name__}")
        data = dict(data)
        _check_keys(cls, data)
        base = data.pop("base", None)
        return cls(
            base=_build(BaseModel, base) if base is not None else None,
            topics=[_build(TopicModel, t) for t in data.pop("topics", [])],
            timers=[_build(TimerModel, t) for t in data.pop("timers", [])],
            services=[_build(ServiceModel, s) for s in data.pop("services", [])],
            actions=[_build(ActionModel, a) for a in data.pop("actions", [])],
            guards=[_build(GuardModel, g) for g in data.pop("guards", [])],
            **data,
        )


def _check_keys(cls: type, data: dict[str, Any]) -> None:
    unknown = set(data) - {f.name for f in fields(cls)}
    if unknown:
        raise ValueError(f"unknown {cls.__name__} field(s): {', '.join(sorted(unknown))}")


#: The values a field may take, where it has a fixed set (checked when a model is read from a file).
_CHOICES = {"direction": ("publish", "subscribe"), "role": ("new", "reuse"), "on_limit": ("clamp", "drop")}


def _build(cls: type, data: dict[str, Any]):
    if not isinstance(data, dict):
        raise ValueError(f"a {cls.__name__} must be a mapping of its fields, not {type(data).__name__}")
    _check_keys(cls, data)
    for key, allowed in _CHOICES.items():
        if key in data and data[key] not in allowed:
            raise ValueError(f"{cls.__name__} {key} {data[key]!r:.40} is not one of {', '.join(allowed)}")
    return cls(**data)
