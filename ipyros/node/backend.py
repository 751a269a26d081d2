"""The backend seam: what the DSL asks of a ROS, and nothing more.

The DSL, the node model, the plan and the magics are the same on ROS 1 and ROS 2; a
:class:`Backend` is what runs them on one ROS. A session holds exactly one, chosen when
it starts (:func:`choose`). Each endpoint it makes has ``close()``; publications and
relays also ``figures()`` (:class:`~ipyros.core.slots.SendFigures`), and publications
``write(msg)``. ``host`` is the full name of the DSL node an endpoint belongs to: on ROS 2
each DSL node is a ROS node of its own, on ROS 1 they share the process's.

=====================  ===================================================================
the DSL asks           what the backend gives
=====================  ===================================================================
a node process         ``process``: started once, named, registered again after a master
                       restart, shut down (``ProcessNode`` on ROS 1); ``has_master``
publish / write        ``publication(host, topic, cls, qos, complain)``
subscribe(h)           ``subscription(host, topic, cls, slot, qos, complain)``: the slot calls
                       the handler; ``complain(text)`` tells the session of a QoS mismatch
reuse relay            ``relay(host, source, target, cls, on_wrong_type, complain)``: bytes, not
                       objects, with the QoS of the source's publishers
timer                  ``timer(host, period, slot, oneshot, complain)``
service / reuse        ``service(host, name, cls, slot)``,
                       ``service_relay(host, source, target, cls, complain)``
a DSL node's life      ``open_host(host)`` at create(), ``close_host(host)`` at shutdown()
params                 ``check_param``, ``get_param``, ``set_param``, ``has_param``,
                       ``delete_param`` (by global name)
a free node name       ``refuse_taken_name(uri, name)``
a basenode's interface ``wait_for_node(master_uri, name, timeout, alive)``: an Interface once settled
the graph (no master)  ``graph_snapshot()``, ``graph_where()``: ROS 2 only; ROS 1's graph is read
                       from the master by :mod:`ipyros.tools.graph` itself
%services, %call       ``service_type(name)``, ``call(name, cls, request, timeout)``
%params, %param        ``params_under(namespace)``, ``read_param(name)``, ``write_param(name, value)``:
                       any node's (ROS 2: ``/node/key``, through its parameter services)
%node                  ``node_pid(name)``: None where the ROS does not say (ROS 2)
=====================  ===================================================================
"""

from __future__ import annotations

import importlib.util
import os
from typing import Any, Callable, Optional, Protocol

from ..core.errors import IpyrosError
from ..core.qos import Qos
from ..core.slots import HandlerSlot

#: Told, in one line, what went wrong with an endpoint after it opened (a QoS mismatch, ...).
Complain = Callable[[str], None]

__all__ = ["Backend", "choose"]


class Backend(Protocol):
    """One ROS, as the DSL sees it (see the module's table)."""

    name: str  # "ROS 1", "ROS 2"
    has_master: bool  # a ROS 1 master to find, start and watch; ROS 2 discovers peers itself
    process: Any

    def publication(self, host: str, topic: str, cls: type, qos: Qos, complain: Complain) -> Any: ...
    def subscription(self, host: str, topic: str, cls: type, slot: HandlerSlot, qos: Qos,
                     complain: Complain) -> Any: ...
    def relay(self, host: str, source: str, target: str, cls: type,
              on_wrong_type: Optional[Callable[[str], None]], complain: Complain) -> Any: ...
    def timer(self, host: str, period: float, slot: HandlerSlot, oneshot: bool,
              complain: Optional[Complain] = None) -> Any: ...
    def service(self, host: str, name: str, cls: type, slot: HandlerSlot) -> Any: ...
    def service_relay(self, host: str, source: str, target: str, cls: type, complain: Complain) -> Any: ...
    def wait_for_node(self, master_uri: Optional[str], name: str, timeout: float = 10.0,
                      alive: Optional[Callable[[], bool]] = None) -> Any: ...
    def open_host(self, host: str) -> None: ...
    def close_host(self, host: str) -> None: ...
    def check_param(self, name: str, value: Any) -> None: ...
    def get_param(self, name: str) -> Any: ...
    def set_param(self, name: str, value: Any) -> None: ...
    def has_param(self, name: str) -> bool: ...
    def delete_param(self, name: str) -> None: ...
    def refuse_taken_name(self, uri: str, name: str) -> None: ...
    def service_type(self, name: str) -> str: ...
    def call(self, name: str, cls: type, request: Any, timeout: float) -> Any: ...
    def params_under(self, namespace: str) -> dict[str, Any]: ...
    def read_param(self, name: str) -> Any: ...
    def write_param(self, name: str, value: Any) -> None: ...
    def node_pid(self, node: str) -> Optional[int]: ...


def choose() -> Backend:
    """The backend of a new session: ``IPYROS_ROS`` (``1`` or ``2``) if set, else ``ROS_VERSION``
    (what a sourced ROS install sets), else ROS 1 if rospy is importable, else ROS 2."""
    wanted = os.environ.get("IPYROS_ROS") or os.environ.get("ROS_VERSION") or ""
    if wanted not in ("", "1", "2"):
        raise IpyrosError(f"IPYROS_ROS={wanted!r}: give 1 (ROS 1, rospy) or 2 (ROS 2, rclpy)")
    if not wanted:
        wanted = "1" if importlib.util.find_spec("rospy") is not None else "2"
    try:
        if wanted == "2":
            from ..ros2.backend import Ros2

            return Ros2()
        from ..ros1.backend import Ros1

        return Ros1()
    except ImportError as error:
        which = "ROS 2 (rclpy: pip install 'ros-rclpy[fastrtps]')" if wanted == "2" else "ROS 1 (rospy)"
        raise IpyrosError(f"ipyros was asked for {which}, which this Python cannot import ({error}); "
                          "install it, or set IPYROS_ROS to the ROS you have") from None
