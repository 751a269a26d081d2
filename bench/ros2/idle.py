"""The stand-in basenode of path (c): it publishes nothing (the bench publishes in its place) and spins."""

import rclpy
from rclpy.executors import ExternalShutdownException

rclpy.init()
node = rclpy.create_node("idle")
try:
    rclpy.spin(node)
except (KeyboardInterrupt, ExternalShutdownException):
    pass
finally:
    node.destroy_node()
    rclpy.try_shutdown()
