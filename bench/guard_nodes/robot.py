"""The robot of the guard bench: a plain subscriber of the guarded topic (rospy or rclpy, no ipyros).

    python robot.py TOPIC [NAME]

Records every ``geometry_msgs/TwistStamped`` it gets: when it came (wall clock), its stamp, whether it is
the stop message (all zeros), and whether it breaks the guard's rules (a number not finite, ``linear.x``
outside +-0.5, ``angular.z`` outside +-1). Says ``ready``, then answers a line at a time:

``publishers``  how many publishers it hears (the session's and its guard's process)
``trip``        ``STAMP ARRIVAL``: the last command's stamp before the first stop message that came after a
                command, and when that stop message came, both since the last trip; ``none`` if not yet
``tally``       ``RECEIVED OUTSIDE``: messages so far, and how many broke the rules
"""

from __future__ import annotations

import importlib.util
import math
import sys
import threading
import time

RULES = (("linear", "x", 0.5), ("angular", "z", 1.0))


class Robot:
    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.events: list[tuple[float, float, bool]] = []  # (arrival, stamp, is the stop message)
        self.mark = 0  # where the next trip is looked for
        self.received = self.outside = 0

    def heard(self, msg) -> None:
        arrival = time.time()
        twist = msg.twist
        values = [getattr(getattr(twist, part), axis) for part in ("linear", "angular") for axis in "xyz"]
        bad = not all(math.isfinite(v) for v in values) or any(
            abs(getattr(getattr(twist, part), axis)) > most for part, axis, most in RULES)
        s = msg.header.stamp
        when = (s.secs + s.nsecs * 1e-9) if hasattr(s, "secs") else (s.sec + s.nanosec * 1e-9)
        with self.lock:
            self.received += 1
            self.outside += bad
            self.events.append((arrival, when, when == 0.0 and not any(values)))

    def trip(self) -> str:
        with self.lock:
            events, last = self.events, None
            for i in range(self.mark, len(events)):
                arrival, when, stop = events[i]
                if not stop:
                    last = when
                elif last is not None:
                    self.mark = i + 1
                    return f"{last!r} {arrival!r}"
            return "none"


def ros1(topic: str, robot: Robot, name: str):
    import rospy
    from geometry_msgs.msg import TwistStamped

    rospy.init_node(name, disable_signals=True)
    sub = rospy.Subscriber(topic, TwistStamped, robot.heard, queue_size=None, tcp_nodelay=True)
    return lambda: sub.get_num_connections(), lambda: rospy.signal_shutdown("done")


def ros2(topic: str, robot: Robot, name: str):
    import rclpy
    from geometry_msgs.msg import TwistStamped
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    rclpy.init()
    node = rclpy.create_node(name)
    qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
    node.create_subscription(TwistStamped, topic, robot.heard, qos)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    threading.Thread(target=executor.spin, daemon=True).start()

    def stop() -> None:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()

    return lambda: node.count_publishers(topic), stop


def main() -> None:
    robot = Robot()
    name = sys.argv[2] if len(sys.argv) > 2 else "bench_robot"  # a second robot needs a name of its own (ROS 1)
    publishers, stop = (ros1 if importlib.util.find_spec("rospy") else ros2)(sys.argv[1], robot, name)
    print("ready", flush=True)
    try:
        for line in sys.stdin:
            word = line.strip()
            if word == "quit":
                break
            if word == "publishers":
                answer = str(publishers())
            elif word == "trip":
                answer = robot.trip()
            elif word == "tally":
                with robot.lock:
                    answer = f"{robot.received} {robot.outside}"
            else:
                answer = f"error unknown command {word!r}"
            print(answer, flush=True)
    finally:
        stop()


if __name__ == "__main__":
    main()
