"""The backend seam: what the DSL asks of a ROS, and nothing more.

The DSL, the node model, the plan and the magics are the same on ROS 1 and ROS 2; a
:class:`Backend` is what runs them on one ROS. A session holds exactly one, chosen when
it starts (:func:`choose`). Each endpoint it makes has ``close()``; publications and
relays also ``figures()`` (:class:`~ipyros.slots.SendFigures`), and publications
``write(msg)``.

=====================  ===================================================================
the DSL asks           what the backend gives
=====================  ===================================================================
a node process         ``process``: started once, named, registered again after a master
                       restart, shut down (``ProcessNode`` on ROS 1)
publish / write        ``publication(topic, cls, latch)``
subscribe(h)           ``subscription(topic, cls, slot)``: the slot calls the handler
reuse relay            ``relay(source, target, cls, on_wrong_type)``: bytes, not objects
timer                  ``timer(period, slot, oneshot)``
service / reuse        ``service(name, cls, slot)``, ``service_relay(source, target, cls)``
params                 ``check_param``, ``get_param``, ``set_param``, ``has_param``,
                       ``delete_param`` (by global name)
a free node name       ``refuse_taken_name(uri, name)``
=====================  ===================================================================
"""

from __future__ import annotations

from typing import Any, Callable, Optional, Protocol

from .slots import HandlerSlot

__all__ = ["Backend", "choose"]


class Backend(Protocol):
    """One ROS, as the DSL sees it (see the module's table)."""

    name: str  # "ROS 1", "ROS 2"
    process: Any

    def publication(self, topic: str, cls: type, latch: bool) -> Any: ...
    def subscription(self, topic: str, cls: type, slot: HandlerSlot) -> Any: ...
    def relay(self, source: str, target: str, cls: type,
              on_wrong_type: Optional[Callable[[str], None]]) -> Any: ...
    def timer(self, period: float, slot: HandlerSlot, oneshot: bool) -> Any: ...
    def service(self, name: str, cls: type, slot: HandlerSlot) -> Any: ...
    def service_relay(self, source: str, target: str, cls: type) -> Any: ...
    def check_param(self, name: str, value: Any) -> None: ...
    def get_param(self, name: str) -> Any: ...
    def set_param(self, name: str, value: Any) -> None: ...
    def has_param(self, name: str) -> bool: ...
    def delete_param(self, name: str) -> None: ...
    def refuse_taken_name(self, uri: str, name: str) -> None: ...


def choose() -> Backend:
    """The backend of a new session. Only ROS 1 exists yet; ROS 2 joins here (issue 10)."""
    from .ros1.backend import Ros1

    return Ros1()
