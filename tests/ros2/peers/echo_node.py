"""Basenode for the ROS 2 wrapping tests: "in" → prefix + data → "out" (std_msgs/String), names relative
("crash" on "in" ends it with code 3);
service "check" (std_srvs/SetBool) answers success=data, message="<prefix> checked"; "status" (transient-local,
latched) says "<prefix> up" once, at start.

Its parameter ``prefix`` (default "echo:") is what it puts in front; ``sensor`` (default False)
publishes "out" best-effort, as sensor drivers do (rclpy's sensor_data profile); ``check_delay``
(seconds, default 0) makes "check" a slow service, which prints "checking" when a call comes.
It spins until Ctrl-C.
"""
import os
import time

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.qos import DurabilityPolicy, QoSProfile, qos_profile_sensor_data
from std_msgs.msg import String
from std_srvs.srv import SetBool

rclpy.init()
node = rclpy.create_node("echo_node")
prefix = node.declare_parameter("prefix", "echo:").value
sensor = node.declare_parameter("sensor", False).value
check_delay = node.declare_parameter("check_delay", 0.0).value
out = node.create_publisher(String, "out", qos_profile_sensor_data if sensor else 10)


def echo(msg: String) -> None:
    if msg.data == "crash":
        print("asked to crash", flush=True)
        os._exit(3)  # a crash: no cleanup, as a segfaulting node would not
    out.publish(String(data=prefix + msg.data))


node.create_subscription(String, "in", echo, 10)


def check(request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
    if check_delay:
        print("checking", flush=True)
        time.sleep(check_delay)
    return SetBool.Response(success=request.data, message=f"{prefix} checked")


node.create_service(SetBool, "check", check)
latched = node.create_publisher(String, "status", QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
latched.publish(String(data=f"{prefix} up"))  # once, at start: only a latched topic keeps it for later subscribers
print("echo_node ready", flush=True)
try:
    rclpy.spin(node)
except (KeyboardInterrupt, ExternalShutdownException):
    pass
finally:
    node.destroy_node()
    rclpy.try_shutdown()
