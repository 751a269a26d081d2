"""Peer: a lifecycle (managed) rclpy node, ``managed_talker``: publishes "tick N" on ``ticks`` while active.

It prints "configured", "activated", "deactivated" as its transitions run. Spins until Ctrl-C.
"""
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.lifecycle import LifecycleNode, TransitionCallbackReturn
from std_msgs.msg import String


class Talker(LifecycleNode):
    def __init__(self):
        super().__init__("managed_talker")
        self.count = 0

    def on_configure(self, state):
        self.pub = self.create_lifecycle_publisher(String, "ticks", 10)
        self.timer = self.create_timer(0.1, self.tick)
        print("configured", flush=True)
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state):
        print("activated", flush=True)
        return super().on_activate(state)

    def on_deactivate(self, state):
        print("deactivated", flush=True)
        return super().on_deactivate(state)

    def tick(self):
        self.count += 1
        self.pub.publish(String(data=f"tick {self.count}"))


rclpy.init()
node = Talker()
print("managed_node ready", flush=True)
try:
    rclpy.spin(node)
except (KeyboardInterrupt, ExternalShutdownException):
    pass
finally:
    node.destroy_node()
    rclpy.try_shutdown()
