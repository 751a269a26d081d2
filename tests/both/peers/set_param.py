"""Peer: set parameter KEY of node NODE to VALUE (a Python literal) from outside, as rosparam set / ros2 param set
do, AFTER seconds from now (0), then print ``set`` and end.

    python set_param.py NODE KEY VALUE [AFTER]
"""
import ast
import sys
import time

node_name, key, value = sys.argv[1], sys.argv[2], ast.literal_eval(sys.argv[3])
due = time.monotonic() + (float(sys.argv[4]) if len(sys.argv) > 4 else 0.0)
try:
    import rclpy
except ImportError:  # ROS 1: the parameter server, no node needed
    import rospy

    time.sleep(max(0.0, due - time.monotonic()))
    rospy.set_param(f"{node_name}/{key}", value)
    print("set", flush=True)
    sys.exit(0)

from rcl_interfaces.srv import SetParameters  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402

rclpy.init()
node = rclpy.create_node("set_param_peer")
client = node.create_client(SetParameters, f"{node_name}/set_parameters")
if not client.wait_for_service(timeout_sec=20):
    sys.exit(f"no {node_name}/set_parameters")
time.sleep(max(0.0, due - time.monotonic()))
future = client.call_async(SetParameters.Request(parameters=[Parameter(key, value=value).to_parameter_msg()]))
rclpy.spin_until_future_complete(node, future, timeout_sec=20)
result = future.result()
print("set" if result and result.results[0].successful else f"refused: {result}", flush=True)
node.destroy_node()
rclpy.try_shutdown()
