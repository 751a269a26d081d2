"""The keeper on ROS 1 (see :mod:`ipyros.processes.keeper`): a rospy node of its own on the robot's machine.

    python -m ipyros.machine --name robot1 [--allow PACKAGE ...] [--token-file FILE]
"""

from __future__ import annotations

import io
import sys
from typing import Any, Callable

from ..core import msgtypes
from ..processes.keeper import Keeper, Lookup, Token, log_line, serve, token_path, unknown_packages
from ..processes.relayhost import wrong_type_line
from . import nodes

__all__ = ["RospyKeeper", "main"]


class _Outlet:
    def __init__(self, publisher: Any) -> None:
        self._pub = publisher

    def write(self, msg: Any) -> None:
        self._pub.publish(msg)

    def count(self) -> int:
        return self._pub.get_num_connections()

    def close(self) -> None:
        self._pub.unregister()


class _Subscription:
    def __init__(self, subscriber: Any) -> None:
        self._sub = subscriber

    def close(self) -> None:
        self._sub.unregister()


class RospyKeeper(Lookup):
    """What the keeper asks of ROS 1, with rospy."""

    nodes = nodes  # basenodes found as rosrun finds them
    sentinel = "ipyros.ros1.sentinel"
    relay_host = "ipyros.ros1.relayhost"

    name = "ROS 1"

    def address(self) -> str:
        import rosgraph

        return f"master {rosgraph.get_master_uri()}"

    def publisher(self, topic: str, type_name: str, latch: bool) -> _Outlet:
        import rospy

        # queue_size: sent by rospy's own thread, so that a subscriber that stalls never holds the keeper up
        return _Outlet(rospy.Publisher(topic, msgtypes.resolve_message(type_name)[1], queue_size=10, latch=latch,
                                       tcp_nodelay=True))

    def subscribe(self, topic: str, type_name: str, callback: Callable[[Any], None],
                  lossy: bool = False) -> _Subscription:  # TCPROS only: lossy or not
        import rospy

        return _Subscription(rospy.Subscriber(topic, msgtypes.resolve_message(type_name)[1], callback,
                                              queue_size=10, tcp_nodelay=True))

    def relay(self, source: str, target: str, type_name: str, gate: Any, complain: Callable[[str], None]) -> Any:
        from ..core.errors import MessageTypeError
        from . import endpoints

        def wrong_type(got: str) -> None:
            complain(wrong_type_line(source, type_name, got))

        try:
            cls = msgtypes.resolve_message(type_name)[1]
        except MessageTypeError:
            if gate is not None:  # a guard reads the values it checks: the guard's own refusal said so already
                raise
            return endpoints.RawRelay(source, target, type_name, wrong_type, complain)  # TCPROS carries any type
        return endpoints.Relay(source, target, cls, wrong_type, complain, gate)

    def service_relay(self, source: str, target: str, type_name: str, complain: Callable[[str], None]) -> Any:
        from . import services

        return services.ServiceRelay(source, target, msgtypes.resolve_service(type_name)[1])

    def action_relay(self, source: str, target: str, type_name: str, complain: Callable[[str], None]) -> Any:
        from .actions import ActionRelay

        return ActionRelay(source, target, msgtypes.resolve_action(type_name)[1],
                           lambda got: complain(wrong_type_line(f"a part of {source}", type_name, got)), complain)

    def text(self, data: str) -> Any:
        from std_msgs.msg import String

        return String(data=data)

    def deserialize(self, cls: type, data: bytes) -> Any:
        msg = cls()
        msg.deserialize(data)
        return msg

    @staticmethod
    def serialize(msg: Any) -> bytes:
        buffer = io.BytesIO()
        msg.serialize(buffer)
        return buffer.getvalue()


def main(name: str, token_file: Any, allowed: frozenset[str] = frozenset()) -> int:
    import rospy

    ros = RospyKeeper()
    unknown = unknown_packages(ros, allowed, "this machine's ROS_PACKAGE_PATH")
    if unknown:
        print(unknown, file=sys.stderr)
        return 2
    token = Token.made_or_read(token_file or token_path(name))
    rospy.init_node(f"ipyros_machine_{name}", disable_signals=True)
    try:
        serve(Keeper(name, token, ros, log_line, allowed=allowed))
    finally:
        rospy.signal_shutdown("the keeper ends")
    return 0
