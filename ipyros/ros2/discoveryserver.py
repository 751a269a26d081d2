"""A Fast DDS discovery server on the robot, for a network where multicast does not carry discovery.

    python -m ipyros.ros2.discoveryserver PORT        (the keeper starts it: --discovery-server PORT)

ROS 2 finds its peers by multicast; many Wi-Fi networks drop or throttle it, and then a laptop never
sees the robot. Fast DDS's discovery server replaces it: every participant (a *client*) tells one
server of itself, over unicast, and the server tells each what it needs. Nothing beyond rclpy is
needed: this process is an rclpy participant made a ``SERVER`` by the profile its environment names
(:func:`profile_xml`, written by :func:`write_profile`), listening on every interface at ``PORT``.
The keeper and what it starts are its clients (``ROS_DISCOVERY_SERVER=127.0.0.1:PORT``); a laptop's
session is one with ``ROS_DISCOVERY_SERVER=ROBOT_ADDRESS:PORT``, and ipyros makes it a *super client*
(``ROS_SUPER_CLIENT``), which sees the whole graph as ``%topics`` and TAB need. Other nodes of the robot
must be its clients too (the same variable in their environment) to be seen.

It prints ``ready`` once its participant runs, and ends on SIGTERM, or with the keeper.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from pathlib import Path

__all__ = ["main", "profile_xml", "write_profile"]


def profile_xml(port: int) -> str:
    """A Fast DDS profile that makes the participants of a process discovery servers on ``port``, every interface."""
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns="http://www.eprosima.com">
  <profiles>
    <participant profile_name="ipyros_discovery_server" is_default_profile="true">
      <rtps>
        <builtin>
          <discovery_config><discoveryProtocol>SERVER</discoveryProtocol></discovery_config>
          <metatrafficUnicastLocatorList>
            <locator><udpv4><address>0.0.0.0</address><port>{port}</port></udpv4></locator>
          </metatrafficUnicastLocatorList>
        </builtin>
      </rtps>
    </participant>
  </profiles>
</dds>
"""


def write_profile(port: int, folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"ipyros-discovery-server-{port}.xml"
    path.write_text(profile_xml(port), encoding="utf-8")
    return path


def main(argv: list[str]) -> int:
    import rclpy

    rclpy.init(signal_handler_options=rclpy.signals.SignalHandlerOptions.NO)
    node = rclpy.create_node("ipyros_discovery_server", start_parameter_services=False)
    ended = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: ended.set())
    signal.signal(signal.SIGINT, lambda *_: ended.set())
    print(f"ready: discovery server on port {argv[0]} (pid {os.getpid()})", flush=True)
    ended.wait()
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
