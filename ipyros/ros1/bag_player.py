"""A ROS 1 bag played as a node: ``python bag_player.py BAG [--rate R] [--loop] [--delay S] [--clock]
[--topics T ...]``. BAG is a ``.bag`` file, or an ``.mcap`` file of ROS 1 messages.

ipyros runs it as the basenode of ``baseBag``. Unlike ``rosbag play``, whose node name is
always made anonymous, it runs under the name it is given (``__name:=``), so the wrapping
node finds it in the graph like any basenode; its topics are remapped the ROS 1 way
(``from:=to``). It advertises every topic first, waits until each has a subscriber (at
most ``--delay`` seconds), then publishes the messages with their recorded spacing
(divided by ``--rate``), and exits at the end unless ``--loop``. ``--clock`` publishes the
bag's time on ``/clock`` as it plays (100 Hz, also while paused). Lines on its stdin pause,
resume, step, seek, change the rate and the looping (:mod:`ipyros.processes.playback`,
which it loads by its path). It needs only rospy and Debian's python3-rosbag (MCAP: mcap-ros1-support),
not ipyros.
"""

import sys
import threading
import time
from pathlib import Path

import rosbag
import rospy

# ipyros's playback module by its folder, and the MCAP reader beside this file: it runs without ipyros importable
sys.path[:0] = [str(Path(__file__).resolve().parents[1] / "processes"), str(Path(__file__).resolve().parent)]
import mcapread  # noqa: E402
import playback  # noqa: E402


class RosBag:
    """A ROS 1 bag, read with rosbag."""

    def __init__(self, path: str) -> None:
        self._bag = rosbag.Bag(path)

    def __enter__(self) -> "RosBag":
        return self

    def __exit__(self, *exc) -> None:
        self._bag.close()

    def classes(self, topics) -> dict:
        """The message class of each topic (of ``topics``, or all), from its first message."""
        found: dict = {}
        for topic, msg, _ in self._bag.read_messages(topics=topics):
            found.setdefault(topic, type(msg))
        return found

    def span(self) -> tuple:
        """The first and last stamps (ns)."""
        if not self._bag.get_message_count():
            return 0, 0
        return tuple(int(round(t * 1e9)) for t in (self._bag.get_start_time(), self._bag.get_end_time()))

    def read(self, topics, since):
        found = self._bag.read_messages(topics=topics, start_time=None if since is None else rospy.Time(nsecs=since))
        return ((topic, stamp.to_nsec(), msg) for topic, msg, stamp in found)


class McapBag:
    """An MCAP file of ROS 1 messages (:mod:`mcapread`): classes from its own schemas."""

    def __init__(self, path: str) -> None:
        self._path = path
        self._summary = mcapread.summary(path)

    def __enter__(self) -> "McapBag":
        return self

    def __exit__(self, *exc) -> None:
        pass

    def classes(self, topics) -> dict:
        return mcapread.message_classes(self._summary, topics)

    def span(self) -> tuple:
        return mcapread.span(self._summary)

    def read(self, topics, since):
        return mcapread.messages(self._path, topics, since)


def main() -> None:
    args = playback.parse_player_args(rospy.myargv(sys.argv)[1:])
    controls = playback.read_controls()
    rospy.init_node("bag_player", disable_signals=True)
    with (McapBag(args.bag) if args.bag.endswith(".mcap") else RosBag(args.bag)) as bag:
        publishers = {topic: rospy.Publisher(topic, cls, queue_size=1000)
                      for topic, cls in bag.classes(args.topics).items()}
        print(f"bag_player: {len(publishers)} topics from {args.bag}", flush=True)
        start, end = bag.span()
        state = playback.Playback(start, end, args.rate, args.loop)
        if args.clock:
            from rosgraph_msgs.msg import Clock

            clock = rospy.Publisher("/clock", Clock, queue_size=10)

            def tick() -> None:
                while not rospy.is_shutdown():
                    clock.publish(Clock(clock=rospy.Time(nsecs=state.now())))
                    time.sleep(0.01)

            threading.Thread(target=tick, name="clock", daemon=True).start()
        # Up to --delay seconds for the wrapping node to connect, then go.
        deadline = time.monotonic() + args.delay
        while time.monotonic() < deadline and not all(p.get_num_connections() for p in publishers.values()):
            time.sleep(0.05)
        time.sleep(0.2)  # the connection's header exchange done on the subscriber's side too
        state.restarted()  # bag time starts now, after the wait, not when the player came up

        try:
            playback.play(state, lambda since: bag.read(args.topics, since),
                          lambda topic, msg: publishers[topic].publish(msg), controls,
                          lambda: not rospy.is_shutdown())
        except KeyboardInterrupt:
            pass
    time.sleep(0.5)  # the last messages on their way before the connections close


if __name__ == "__main__":
    main()
