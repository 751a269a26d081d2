"""The relay host on ROS 1 (see :mod:`ipyros.processes.relayhost`): a rospy node whose relays a keeper opens.

    python -m ipyros.ros1.relayhost NODE_NAME
"""

from __future__ import annotations

import sys

from ..core import msgtypes
from ..processes.relayhost import opener, serve
from .machine import RospyKeeper

__all__ = ["main"]


def main(argv: list[str]) -> int:
    import rospy

    rospy.init_node(argv[0], disable_signals=True)
    ros = RospyKeeper()
    try:
        serve(opener(ros), lambda type_name, data: ros.deserialize(msgtypes.resolve_message(type_name)[1], data))
    finally:
        rospy.signal_shutdown("the keeper ends its relays")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
