"""Peer: print every std_msgs/String arriving on TOPIC as "heard: <data>"; list the graph's nodes on "nodes"."""
import sys
import threading

import rclpy
import rclpy.executors
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

topic = sys.argv[1]
printing = threading.Lock()


def say(line: str) -> None:
    """One whole line at a time: the spin thread and the main thread both print."""
    with printing:
        sys.stdout.write(line + "\n")
        sys.stdout.flush()


rclpy.init()
node = rclpy.create_node("echo_peer")
node.create_subscription(String, topic, lambda m: say(f"heard: {m.data}"),
                         QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE))
executor = rclpy.executors.SingleThreadedExecutor()
executor.add_node(node)
spinner = threading.Thread(target=executor.spin, daemon=True)
spinner.start()
say("ready")
for line in sys.stdin:
    if line.strip() == "nodes":
        names = sorted(ns.rstrip("/") + "/" + name for name, ns in node.get_node_names_and_namespaces())
        say("nodes: " + " ".join(names))
# A clean goodbye: the graph forgets this node at once (a killed one lingers for DDS's lease time).
executor.shutdown()
spinner.join(5)
node.destroy_node()
rclpy.try_shutdown()
