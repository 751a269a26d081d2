"""What the demo robot's nodes need of ROS, on ROS 1 (rospy) or ROS 2 (rclpy): one source for both.

The demo nodes (turtle_sim, move_base, speed_monitor) are plain ROS nodes, run and wrapped
as any other; they are written once against this small surface and run with whichever
ROS this interpreter has (``IPYROS_ROS`` or ``ROS_VERSION`` 2: rclpy; else rospy if
importable). Private names (``~clear_goal``) and parameters are the node's own on both.

    node = DemoNode("turtle_sim")
    speed = float(node.param("max_speed", 5.0))
    pose_pub = node.publisher("turtle1/pose", Pose)
    node.subscribe("turtle1/cmd_vel", Twist, on_cmd_vel)
    node.run(20.0, step)          # step() at 20 Hz until the node is asked to stop

Callbacks run on a thread of their own while ``run`` steps on the main one, on both ROS.
"""

from __future__ import annotations

import atexit
import importlib.util
import os
import sys
import threading
import time
from typing import Any, Callable


def _ros2() -> bool:
    wanted = os.environ.get("IPYROS_ROS") or os.environ.get("ROS_VERSION") or ""
    return wanted == "2" or (wanted != "1" and importlib.util.find_spec("rospy") is None)


def rospy_node(name: str, **options: Any) -> None:
    """``rospy.init_node(name, **options)`` for a node that ends at once when asked to (or at exit).

    Asked to stop, rospy unregisters the node, then joins its XML-RPC server's thread, which notices
    its closed socket only at its next half-second poll: 0.6 s a node for nothing (the thread is a
    daemon: it ends with the process). Without the join a node is gone in a fifth of a second.
    """
    import rospy

    rospy.init_node(name, **options)
    joined = getattr(rospy.core, "_shutdown_threads", None)  # rospy's own: another rospy only stops slower
    if isinstance(joined, list):
        joined.clear()


class DemoNode:
    """A node of the demo robot: parameters, publishers, subscriptions, a service, a loop."""

    def __init__(self, name: str) -> None:
        self.ros2 = _ros2()
        if self.ros2:
            import rclpy
            from rclpy.executors import SingleThreadedExecutor

            rclpy.init(args=sys.argv)  # --ros-args: name, namespace, remaps, parameters
            self._node = rclpy.create_node(name)
            self._executor = SingleThreadedExecutor()
            self._executor.add_node(self._node)
            self._spinner = threading.Thread(target=self._spin, daemon=True)
            self._spinner.start()
            atexit.register(self.close)  # however the script ends: after run(), or a script of its own
        else:
            rospy_node(name)
            self._node = None

    def _spin(self) -> None:
        from rclpy.executors import ExternalShutdownException

        try:
            self._executor.spin()
        except ExternalShutdownException:  # Ctrl-C or SIGTERM: run() ends too
            pass

    def param(self, name: str, default: Any) -> Any:
        """The node's private parameter ``name``, or ``default``."""
        if not self.ros2:
            import rospy

            return rospy.get_param("~" + name, default)
        from rcl_interfaces.msg import ParameterDescriptor

        # any type: a launch file's "5" for a float parameter is a number all the same
        return self._node.declare_parameter(name, default, ParameterDescriptor(dynamic_typing=True)).value

    def publisher(self, topic: str, cls: type, latch: bool = False, depth: int = 10) -> Any:
        """A publisher (``publish(msg)``); ``latch``: a late subscriber still gets the last message;
        ``depth``: how many messages wait for a slow subscriber."""
        if not self.ros2:
            import rospy

            return rospy.Publisher(topic, cls, queue_size=1 if latch else depth, latch=latch)
        from rclpy.qos import DurabilityPolicy, QoSProfile

        qos = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL) if latch else QoSProfile(depth=depth)
        return self._node.create_publisher(cls, topic, qos)

    def subscribe(self, topic: str, cls: type, callback: Callable[[Any], None], depth: int = 10,
                  best_effort: bool = False, latched: bool = False) -> None:
        """Call ``callback(msg)`` for each message; ``best_effort``: as a sensor's subscriber (ROS 2; ROS 1 has TCP);
        ``latched``: also the last message of a latching publisher (ROS 2 asks for it: transient local; ROS 1
        gets it anyway)."""
        if not self.ros2:
            import rospy

            rospy.Subscriber(topic, cls, callback, queue_size=depth)
            return
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

        reliability = ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE
        durability = DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE
        self._node.create_subscription(cls, topic, callback, QoSProfile(depth=depth, reliability=reliability,
                                                                        durability=durability))

    def service(self, name: str, cls: type, callback: Callable[[Any], None]) -> None:
        """Serve ``name`` (``~name``: the node's own) by calling ``callback(request)``; the answer is empty."""
        if not self.ros2:
            import rospy

            def answer_ros1(request: Any) -> Any:
                callback(request)
                return cls._response_class()  # type: ignore[attr-defined]

            rospy.Service(name, cls, answer_ros1)
            return

        def answer(request: Any, response: Any) -> Any:
            callback(request)
            return response

        private = name.startswith("~") and not name.startswith("~/")
        self._node.create_service(cls, "~/" + name[1:] if private else name, answer)

    def now(self) -> float:
        """Seconds, for differences (the node's clock)."""
        if not self.ros2:
            import rospy

            return rospy.get_time()
        return self._node.get_clock().now().nanoseconds * 1e-9

    # One call site per severity: rclpy refuses a logging call site whose severity changes.
    def info(self, text: str, *args: Any) -> None:
        if not self.ros2:
            import rospy

            rospy.loginfo(text, *args)
            return
        self._node.get_logger().info(text % args)

    def warn(self, text: str, *args: Any) -> None:
        if not self.ros2:
            import rospy

            rospy.logwarn(text, *args)
            return
        self._node.get_logger().warning(text % args)

    def run(self, rate: float, step: Callable[[], None]) -> None:
        """Call ``step()`` at ``rate`` Hz until the node is asked to stop (Ctrl-C, SIGTERM, ROS shutdown)."""
        if not self.ros2:
            import rospy

            timer = rospy.Rate(rate)
            while not rospy.is_shutdown():
                step()
                try:
                    timer.sleep()
                except rospy.ROSInterruptException:
                    break
            return
        import rclpy

        period, next_time = 1.0 / rate, time.monotonic()
        try:
            while rclpy.ok():
                step()
                next_time += period
                time.sleep(max(0.0, next_time - time.monotonic()))
        except KeyboardInterrupt:
            pass
        finally:
            self.close()

    def close(self) -> None:
        """Stop spinning and destroy the node (ROS 2; once, and again at exit). The spinning thread must be
        gone before the interpreter is: rclpy aborts the process (SIGABRT) if it finds it still waiting,
        and Fast DDS's shared memory (a 64 MiB segment with ipyros's profile) is then never freed."""
        if not self.ros2 or self._node is None:
            return
        import rclpy

        rclpy.try_shutdown()
        self._executor.shutdown()
        self._spinner.join(timeout=5.0)
        self._node.destroy_node()
        self._node = None
