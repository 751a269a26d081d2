"""A bag played as a ROS 2 node: ``python bag_player.py BAG [--rate R] [--loop] [--delay S] [--clock]
[--topics T ...] [--ros-args ...]``. BAG is a rosbag2 folder, or a ROS 1 ``.bag`` file (its messages turned into
CDR as they are read, with the message definitions the bag carries).

ipyros runs it as the basenode of ``baseBag`` on ROS 2, named and remapped with
``--ros-args`` like any basenode. It advertises every topic (reliable, volatile, 1000
deep), waits until each has a subscriber (at most ``--delay`` seconds), then publishes the recorded
CDR bytes unchanged with their recorded spacing (divided by ``--rate``), and exits at the
end unless ``--loop``. ``--clock`` publishes the bag's time on ``/clock`` as it plays (100 Hz,
also while paused). Lines on its stdin pause, resume, step, seek, change the rate and the
looping (:mod:`ipyros.processes.playback`, which it loads by its path). It needs rclpy and
rosbags, not ipyros.
"""

import importlib
import sys
import threading
import time
from pathlib import Path

import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.utilities import remove_ros_args
from rosbags.rosbag2 import Reader

# ipyros's playback module, by its folder: this file runs without ipyros importable
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "processes"))
import playback  # noqa: E402


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

    @property
    def start_time(self) -> int:
        return self._reader.start_time

    @property
    def end_time(self) -> int:
        return self._reader.end_time

    def messages(self, connections, start=None):
        for connection, stamp, raw in self._reader.messages(connections=connections, start=start):
            yield connection, stamp, self._store.ros1_to_cdr(raw, connection.msgtype)

    def close(self) -> None:
        self._reader.close()


def message_class(msgtype: str) -> type:
    package, kind, name = msgtype.split("/")
    return getattr(importlib.import_module(f"{package}.{kind}"), name)


def main() -> None:
    args = playback.parse_player_args(remove_ros_args(sys.argv)[1:])
    controls = playback.read_controls()
    rclpy.init(args=sys.argv)
    node = rclpy.create_node("bag_player")
    reader = Ros1Bag(args.bag) if args.bag.endswith(".bag") else Reader(args.bag)
    reader.open()
    connections = [c for c in reader.connections if not args.topics or c.topic in args.topics]
    qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
    publishers = {c.topic: node.create_publisher(message_class(c.msgtype), c.topic, qos) for c in connections}
    print(f"bag_player: {len(publishers)} topics from {args.bag}", flush=True)
    state = playback.Playback(reader.start_time, max(reader.end_time, reader.start_time), args.rate, args.loop)
    if args.clock:
        from builtin_interfaces.msg import Time
        from rosgraph_msgs.msg import Clock

        clock = node.create_publisher(Clock, "/clock", 10)

        def tick() -> None:
            while rclpy.ok():
                now = state.now()
                try:
                    clock.publish(Clock(clock=Time(sec=now // 1_000_000_000, nanosec=now % 1_000_000_000)))
                except Exception:  # noqa: BLE001 - the context shut down meanwhile
                    return
                time.sleep(0.01)

        threading.Thread(target=tick, name="clock", daemon=True).start()
    try:
        # Up to --delay seconds for the wrapping node to subscribe (discovery takes a moment), then go.
        deadline = time.monotonic() + args.delay
        while time.monotonic() < deadline and not all(p.get_subscription_count() for p in publishers.values()):
            time.sleep(0.05)
        time.sleep(0.2)  # the matching settles on the subscriber's side too
        state.restarted()  # bag time starts now, after the wait, not when the player came up

        def read(since):
            found = reader.messages(connections=connections, start=since)
            return ((connection.topic, stamp, bytes(raw)) for connection, stamp, raw in found)

        playback.play(state, read, lambda topic, raw: publishers[topic].publish(raw), controls, rclpy.ok)
        time.sleep(0.5)  # the last messages on their way
    except KeyboardInterrupt:
        pass
    finally:
        reader.close()
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
