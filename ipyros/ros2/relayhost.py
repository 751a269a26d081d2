"""The relay host on ROS 2 (see :mod:`ipyros.processes.relayhost`): an rclpy node whose relays a keeper opens.

    python -m ipyros.ros2.relayhost NODE_NAME
"""

from __future__ import annotations

import sys

from ..core import msgtypes
from ..processes.relayhost import opener, serve
from .machine import RclpyKeeper

__all__ = ["main"]


def main(argv: list[str]) -> int:
    ros = RclpyKeeper(None, relays_name=argv[0])
    try:
        serve(opener(ros), lambda type_name, data: ros.deserialize(msgtypes.resolve_message(type_name)[1], data))
    finally:
        ros.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
