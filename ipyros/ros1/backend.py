"""ROS 1 as a :class:`~ipyros.backend.Backend`: the seam's calls, answered by :mod:`.runtime`."""

from __future__ import annotations

from typing import Callable, Optional

from ..slots import HandlerSlot
from . import runtime

__all__ = ["Ros1"]


class Ros1:
    """rospy behind the seam: one process node hosts every DSL node's endpoints."""

    name = "ROS 1"

    def __init__(self) -> None:
        self.process = runtime.ProcessNode()

    def publication(self, topic: str, cls: type, latch: bool) -> runtime.Publication:
        return runtime.Publication(topic, cls, latch)

    def subscription(self, topic: str, cls: type, slot: HandlerSlot) -> runtime.Subscription:
        return runtime.Subscription(topic, cls, slot)

    def relay(self, source: str, target: str, cls: type,
              on_wrong_type: Optional[Callable[[str], None]]) -> runtime.Relay:
        return runtime.Relay(source, target, cls, on_wrong_type)

    def timer(self, period: float, slot: HandlerSlot, oneshot: bool) -> runtime.Timer:
        return runtime.Timer(period, slot, oneshot)

    def service(self, name: str, cls: type, slot: HandlerSlot) -> runtime.ServiceServer:
        return runtime.ServiceServer(name, cls, slot)

    def service_relay(self, source: str, target: str, cls: type) -> runtime.ServiceRelay:
        return runtime.ServiceRelay(source, target, cls)

    # The parameter server and the master, by global name.
    check_param = staticmethod(runtime.check_param)
    get_param = staticmethod(runtime.get_param)
    set_param = staticmethod(runtime.set_param)
    has_param = staticmethod(runtime.has_param)
    delete_param = staticmethod(runtime.delete_param)
    refuse_taken_name = staticmethod(runtime.refuse_taken_name)

    def __repr__(self) -> str:
        return f"<ipyros backend {self.name}: {self.process.name or 'no node yet'}>"
