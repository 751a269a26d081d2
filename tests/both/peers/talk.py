"""Peer: publish a TYPE message on TOPIC at RATE Hz (fields set by FIELD=VALUE, values as Python literals).

    python talk.py TOPIC TYPE RATE [FIELD=VALUE ...]
"""
import ast
import sys

from anyros import DemoNode, field, message_class

topic, type_name, rate = sys.argv[1], sys.argv[2], float(sys.argv[3])
node = DemoNode("talk_peer")
msg = message_class(type_name)()
for assignment in (a for a in sys.argv[4:] if "=" in a and ":=" not in a and not a.startswith("-")):
    path, _, value = assignment.partition("=")
    owner, _, name = path.rpartition(".")
    setattr(field(msg, owner), name, ast.literal_eval(value))
publisher = node.publisher(topic, message_class(type_name))
print("ready", flush=True)
node.run(rate, lambda: publisher.publish(msg))
