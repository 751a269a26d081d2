#!/usr/bin/python3
"""Test peer: a publisher of sensor_msgs/Image on TOPIC that speaks TCPROS by hand, so that it can stop in
the middle of a message, as a publisher that crashes while it sends one (rospy cannot be made to).

usage: cut_publisher.py TOPIC
To its first subscriber it sends image 1 whole (as publish_images.py makes it, 1 MiB), then the length and
the first half of image 2, and prints "half sent"; on a line "cut" on stdin it closes the connection,
unregisters and prints "cut".
"""
import io
import os
import socket
import sys
import threading
import xmlrpc.client
from xmlrpc.server import SimpleXMLRPCServer

import rosgraph.network
import rospy
from sensor_msgs.msg import Image

topic, size, caller = sys.argv[1], 1 << 20, "/cut_publisher"


def image(ident: int) -> bytes:
    buffer = io.BytesIO()
    Image(height=1, width=size, encoding="mono8", step=size, data=bytes([ident % 251]) * size,
          header=rospy.Header(frame_id=str(ident))).serialize(buffer)
    return len(buffer.getvalue()).to_bytes(4, "little") + buffer.getvalue()


listener = socket.create_server(("127.0.0.1", 0))
api = SimpleXMLRPCServer(("127.0.0.1", 0), logRequests=False, allow_none=True)
api.register_function(lambda caller_id, name, protocols: [1, "", ["TCPROS", "127.0.0.1", listener.getsockname()[1]]],
                      "requestTopic")
api.register_function(lambda caller_id: [1, "", os.getpid()], "getPid")
threading.Thread(target=api.serve_forever, daemon=True).start()
uri = f"http://127.0.0.1:{api.server_address[1]}/"
master = xmlrpc.client.ServerProxy(os.environ["ROS_MASTER_URI"])
master.registerPublisher(caller, topic, Image._type, uri)
print("ready", flush=True)

conn, _ = listener.accept()
rosgraph.network.read_ros_handshake_header(conn, io.BytesIO(), 65536)
conn.sendall(rosgraph.network.encode_ros_handshake_header({
    "callerid": caller, "topic": topic, "type": Image._type, "md5sum": Image._md5sum,
    "message_definition": Image._full_text, "latching": "0"}))
conn.sendall(image(1))
second = image(2)
conn.sendall(second[:len(second) // 2])
print("half sent", flush=True)
for line in sys.stdin:
    if line.strip() == "cut":
        break
conn.close()
master.unregisterPublisher(caller, topic, uri)
print("cut", flush=True)
sys.stdin.read()
