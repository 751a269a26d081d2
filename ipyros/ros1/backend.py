"""ROS 1 as a :class:`~ipyros.node.backend.Backend`: the seam's calls, answered by :mod:`.runtime`."""

from __future__ import annotations

from typing import Any, Callable, Optional

from ..core.errors import MasterError
from ..core.qos import Qos
from ..core.slots import HandlerSlot
from . import introspect, runtime

__all__ = ["Ros1"]


class Ros1:
    """rospy behind the seam: one process node hosts every DSL node's endpoints.

    ``host`` (the DSL node's full name) does not matter here: rospy allows one node per
    process, and the names are resolved already.
    """

    name = "ROS 1"
    has_master = True

    def __init__(self) -> None:
        self.process = runtime.ProcessNode()

    # TCPROS is reliable and rospy queues are ipyros's own: of a QoS only durability
    # means something here (transient-local is latched); nothing can mismatch.
    def publication(self, host: str, topic: str, cls: type, qos: Qos,
                    complain: Callable[[str], None]) -> runtime.Publication:
        return runtime.Publication(topic, cls, qos.latched)

    def subscription(self, host: str, topic: str, cls: type, slot: HandlerSlot, qos: Qos,
                     complain: Callable[[str], None]) -> runtime.Subscription:
        return runtime.Subscription(topic, cls, slot, complain)

    def relay(self, host: str, source: str, target: str, cls: type,
              on_wrong_type: Optional[Callable[[str], None]], complain: Callable[[str], None]) -> runtime.Relay:
        return runtime.Relay(source, target, cls, on_wrong_type, complain)

    def timer(self, host: str, period: float, slot: HandlerSlot, oneshot: bool,
              complain: Optional[Callable[[str], None]] = None) -> runtime.Timer:
        return runtime.Timer(period, slot, oneshot)  # rospy gives each timer a thread of its own

    def service(self, host: str, name: str, cls: type, slot: HandlerSlot) -> runtime.ServiceServer:
        return runtime.ServiceServer(name, cls, slot)

    def service_relay(self, host: str, source: str, target: str, cls: type,
                      complain: Callable[[str], None]) -> runtime.ServiceRelay:
        return runtime.ServiceRelay(source, target, cls)  # a basenode's failure reaches the caller as an error

    def wait_for_node(self, master_uri: Optional[str], name: str, timeout: float = 10.0,
                      alive: Optional[Callable[[], bool]] = None) -> Any:
        """The interface of the running node ``name``, read from the master once it has settled."""
        from ..tools.discovery import wait_for_node

        return wait_for_node(master_uri or "", name, timeout=timeout, alive=alive)

    def open_host(self, host: str) -> None:
        """Nothing to do: the DSL node's endpoints live in the process node."""

    def close_host(self, host: str) -> None:
        """Nothing to do: the process node stays for the session's other nodes."""

    # The parameter server and the master, by global name.
    check_param = staticmethod(runtime.check_param)
    get_param = staticmethod(runtime.get_param)
    set_param = staticmethod(runtime.set_param)
    has_param = staticmethod(runtime.has_param)
    delete_param = staticmethod(runtime.delete_param)
    refuse_taken_name = staticmethod(runtime.refuse_taken_name)

    # -- the graph's services, parameters and nodes, for %services, %call, %params, %nodes ----
    def service_type(self, name: str) -> str:
        return introspect.service_type(self._master(), name)

    def call(self, name: str, cls: type, request: Any, timeout: float) -> Any:
        return introspect.call(self._master(), name, cls, request, timeout)

    def params_under(self, namespace: str) -> dict[str, Any]:
        """Every parameter under ``namespace``, by global name."""
        return introspect.params_under(self._master(), namespace)

    read_param = staticmethod(runtime.get_param)
    write_param = staticmethod(runtime.set_param)

    def topic_endpoints(self, topic: str) -> list[tuple[str, str, str, str]]:
        """Who publishes and subscribes to ``topic``, each with its type (``%topics -v``)."""
        from .master import configured_uri

        return introspect.topic_endpoints(self.process.master_uri or configured_uri(), topic)

    def node_pid(self, node: str) -> Optional[int]:
        return introspect.node_pid(self._master(), node)

    def _master(self) -> str:
        if self.process.master_uri is None:
            raise MasterError("no ROS node of this session runs yet; create a node first")
        return self.process.master_uri

    def __repr__(self) -> str:
        return f"<ipyros backend {self.name}: {self.process.name or 'no node yet'}>"
