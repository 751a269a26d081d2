"""A ROS 1 bag played as a node: ``python bag_player.py BAG [--rate R] [--loop] [--delay S] [--topics T ...]``.

ipyros runs it as the basenode of ``baseBag``. Unlike ``rosbag play``, whose node name is
always made anonymous, it runs under the name it is given (``__name:=``), so the wrapping
node finds it in the graph like any basenode; its topics are remapped the ROS 1 way
(``from:=to``). It advertises every topic first, waits until each has a subscriber (at
most ``--delay`` seconds), then publishes the messages with their recorded spacing
(divided by ``--rate``), and exits at the end unless ``--loop``. It needs only rospy and
Debian's python3-rosbag, not ipyros.
"""

import argparse
import sys
import time

import rosbag
import rospy


def main() -> None:
    parser = argparse.ArgumentParser(prog="bag_player")
    parser.add_argument("bag")
    parser.add_argument("--rate", type=float, default=1.0)
    parser.add_argument("--loop", action="store_true")
    parser.add_argument("--delay", type=float, default=1.0)
    parser.add_argument("--topics", nargs="*")
    args = parser.parse_args(rospy.myargv(sys.argv)[1:])
    rospy.init_node("bag_player", disable_signals=True)
    with rosbag.Bag(args.bag) as bag:
        first: dict = {}
        for topic, msg, _ in bag.read_messages(topics=args.topics):
            first.setdefault(topic, type(msg))
        publishers = {topic: rospy.Publisher(topic, cls, queue_size=1000) for topic, cls in first.items()}
        print(f"bag_player: {len(publishers)} topics from {args.bag}", flush=True)
        # Up to --delay seconds for the wrapping node to connect, then go.
        deadline = time.monotonic() + args.delay
        while time.monotonic() < deadline and not all(p.get_num_connections() for p in publishers.values()):
            time.sleep(0.05)
        time.sleep(0.2)  # the connection's header exchange done on the subscriber's side too
        try:
            while not rospy.is_shutdown():
                start, recorded_start = time.monotonic(), None
                for topic, msg, stamp in bag.read_messages(topics=args.topics):
                    recorded_start = recorded_start if recorded_start is not None else stamp.to_sec()
                    wait = start + (stamp.to_sec() - recorded_start) / args.rate - time.monotonic()
                    if wait > 0:
                        time.sleep(wait)
                    publishers[topic].publish(msg)
                print("bag_player: played to the end", flush=True)
                if not args.loop:
                    break
        except KeyboardInterrupt:
            pass
    time.sleep(0.5)  # the last messages on their way before the connections close


if __name__ == "__main__":
    main()
