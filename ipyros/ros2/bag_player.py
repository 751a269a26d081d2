"""A bag played as a ROS 2 node: ``python bag_player.py BAG [--rate R] [--loop] [--delay S] [--topics T ...]
[--ros-args ...]``. BAG is a rosbag2 folder, or a ROS 1 ``.bag`` file (its messages turned into
CDR as they are read, with the message definitions the bag carries).

ipyros runs it as the basenode of ``baseBag`` on ROS 2, named and remapped with
``--ros-args`` like any basenode. It advertises every topic (reliable, volatile, 1000
deep), waits until each has a subscriber (at most ``--delay`` seconds), then publishes the recorded
CDR bytes unchanged with their recorded spacing (divided by ``--rate``), and exits at the
end unless ``--loop``. It needs rclpy and rosbags, not ipyros.
"""

import argparse
import importlib
import sys
import time

import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.utilities import remove_ros_args
from rosbags.rosbag2 import Reader


class Ros1Bag:
    """A ROS 1 bag read as rosbag2's Reader reads a folder: connections, then (connection, stamp, CDR bytes)."""

    def __init__(self, path: str) -> None:
        from rosbags.rosbag1 import Reader as Ros1Reader
        from rosbags.typesys import Stores, get_types_from_msg, get_typestore

        self._reader = Ros1Reader(path)
        self._store = get_typestore(Stores.ROS2_JAZZY)
        self._get_types = get_types_from_msg

    def open(self) -> None:
        self._reader.open()
        for connection in self._reader.connections:  # types the store lacks: from the bag's own definitions
            if connection.msgtype not in self._store.types:
                self._store.register(self._get_types(connection.msgdef.data, connection.msgtype))

    @property
    def connections(self) -> list:
        return list(self._reader.connections)

    def messages(self, connections):
        for connection, stamp, raw in self._reader.messages(connections=connections):
            yield connection, stamp, self._store.ros1_to_cdr(raw, connection.msgtype)

    def close(self) -> None:
        self._reader.close()


def message_class(msgtype: str) -> type:
    package, kind, name = msgtype.split("/")
    return getattr(importlib.import_module(f"{package}.{kind}"), name)


def main() -> None:
    parser = argparse.ArgumentParser(prog="bag_player")
    parser.add_argument("bag")
    parser.add_argument("--rate", type=float, default=1.0)
    parser.add_argument("--loop", action="store_true")
    parser.add_argument("--delay", type=float, default=1.0)
    parser.add_argument("--topics", nargs="*")
    args = parser.parse_args(remove_ros_args(sys.argv)[1:])
    rclpy.init(args=sys.argv)
    node = rclpy.create_node("bag_player")
    reader = Ros1Bag(args.bag) if args.bag.endswith(".bag") else Reader(args.bag)
    reader.open()
    connections = [c for c in reader.connections if not args.topics or c.topic in args.topics]
    qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
    publishers = {c.topic: node.create_publisher(message_class(c.msgtype), c.topic, qos) for c in connections}
    print(f"bag_player: {len(publishers)} topics from {args.bag}", flush=True)
    try:
        # Up to --delay seconds for the wrapping node to subscribe (discovery takes a moment), then go.
        deadline = time.monotonic() + args.delay
        while time.monotonic() < deadline and not all(p.get_subscription_count() for p in publishers.values()):
            time.sleep(0.05)
        time.sleep(0.2)  # the matching settles on the subscriber's side too
        while rclpy.ok():
            start, recorded_start = time.monotonic(), None
            for connection, stamp, raw in reader.messages(connections=connections):
                recorded_start = recorded_start if recorded_start is not None else stamp
                wait = start + (stamp - recorded_start) * 1e-9 / args.rate - time.monotonic()
                if wait > 0:
                    time.sleep(wait)
                if not rclpy.ok():
                    break
                publishers[connection.topic].publish(bytes(raw))
            print("bag_player: played to the end", flush=True)
            if not args.loop:
                break
        time.sleep(0.5)  # the last messages on their way
    except KeyboardInterrupt:
        pass
    finally:
        reader.close()
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
