"""Peer: publish std_msgs/UInt32 0..COUNT-1 on TOPIC at RATE Hz once a subscriber is connected; print
"started" when it begins, "done" when all are sent.

    python seq.py TOPIC COUNT RATE
"""
import sys
import time

from anyros import DemoNode, message_class

topic, count, rate = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
node = DemoNode("seq_peer")
UInt32 = message_class("std_msgs/UInt32")
publisher = node.publisher(topic, UInt32, depth=count)
connections = getattr(publisher, "get_num_connections", None) or publisher.get_subscription_count
deadline = time.monotonic() + 30
while connections() < 1 and time.monotonic() < deadline:
    time.sleep(0.01)
time.sleep(0.3)  # the subscriber's side of the handshake
print("started", flush=True)
start = time.monotonic()
for i in range(count):
    publisher.publish(UInt32(data=i))
    time.sleep(max(0.0, start + (i + 1) / rate - time.monotonic()))
time.sleep(0.5)
print("done", flush=True)
sys.stdin.read()  # until the test stops the peer
