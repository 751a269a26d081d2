"""A guard's process on ROS 1 (see :mod:`ipyros.processes.sentinel`): a rospy node of its own that publishes the
stop message on the guarded topic when the session's messages stop, and hears the guard's e-stop topic.

    python -m ipyros.ros1.sentinel PIPE_FD SHARED_FD     (started by the session, never by hand)
"""

from __future__ import annotations

import sys
import threading
from typing import Any, Callable

from ..processes.sentinel import Shared, serve


def start(settings: dict[str, Any], shared: Shared,
          wake: threading.Event) -> tuple[Callable[[], None], Callable[[], int]]:
    import rospy
    from std_msgs.msg import Bool

    from ..core import msgtypes

    rospy.init_node(settings["node"], disable_signals=True)  # its process group gets no Ctrl-C; SIGTERM is served
    _, cls = msgtypes.resolve_message(settings["type"])
    stop = cls()
    stop.deserialize(bytes.fromhex(settings["stop"]))
    # queue_size: sent by rospy's own thread, so that a subscriber that stalls never holds the watch up
    publisher = rospy.Publisher(settings["topic"], cls, queue_size=10, latch=settings.get("latch", False))

    def estop(msg: Any) -> None:
        shared.estop_topic = msg.data
        wake.set()

    if settings.get("estop_topic"):
        rospy.Subscriber(settings["estop_topic"], Bool, estop, queue_size=10)

    def publish_stop() -> None:
        stop.deserialize(bytes.fromhex(settings["stop"]))  # the settings may have changed it
        publisher.publish(stop)

    return publish_stop, publisher.get_num_connections


def main(argv: list[str]) -> int:
    import rospy

    return serve(int(argv[1]), int(argv[2]), start, lambda: rospy.signal_shutdown("the guard ends"))


if __name__ == "__main__":
    sys.exit(main(sys.argv))
