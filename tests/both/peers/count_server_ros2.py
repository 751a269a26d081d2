"""Basenode for the action tests on ROS 2: serves ``count`` (test_msgs/action/Fibonacci), name relative.

The same counting as count_server_ros1.py, in Fibonacci's fields: a goal of order N sends
N feedbacks, the i-th with a sequence of i numbers, one every 0.05 s, then succeeds with a
sequence of N. It prints "goal N" when a goal comes and "cancelled N" when a cancel reaches
it (the goal then ends cancelled). Spins until Ctrl-C.
"""
import time

import rclpy
from rclpy.action import ActionServer, CancelResponse
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor
from test_msgs.action import Fibonacci

rclpy.init()
node = rclpy.create_node("count_server")


def execute(handle):
    order = handle.request.order
    print(f"goal {order}", flush=True)
    for i in range(1, order + 1):
        if handle.is_cancel_requested:
            print(f"cancelled {order}", flush=True)
            handle.canceled()
            return Fibonacci.Result(sequence=list(range(i - 1)))
        handle.publish_feedback(Fibonacci.Feedback(sequence=list(range(i))))
        time.sleep(0.05)
    handle.succeed()
    return Fibonacci.Result(sequence=list(range(order)))


ActionServer(node, Fibonacci, "count", execute, cancel_callback=lambda handle: CancelResponse.ACCEPT)
print("count_server ready", flush=True)
executor = MultiThreadedExecutor()  # a goal that sleeps does not hold up its cancel
executor.add_node(node)
try:
    executor.spin()
except (KeyboardInterrupt, ExternalShutdownException):
    pass
finally:
    node.destroy_node()
    rclpy.try_shutdown()
