"""Peer: subscribe to TOPIC (TYPE) and print ``heard <value>`` per message, the value at FIELD (a dotted path).

    python listen.py TOPIC TYPE [FIELD] [--best-effort] [--latched] [--name=NODE]
"""
import sys

from anyros import DemoNode, field, message_class, say

topic, type_name = sys.argv[1], sys.argv[2]
path = sys.argv[3] if len(sys.argv) > 3 and not sys.argv[3].startswith("-") else ""
name = next((a.split("=", 1)[1] for a in sys.argv if a.startswith("--name=")), "listen_peer")
node = DemoNode(name)
node.subscribe(topic, message_class(type_name), lambda msg: say("heard", repr(field(msg, path))),
               best_effort="--best-effort" in sys.argv, latched="--latched" in sys.argv)
print("ready", flush=True)
node.run(10.0, lambda: None)
