"""Peer: subscribe to TOPIC (TYPE) and print ``heard <value>`` per message, the value at FIELD (a dotted path).

    python listen.py TOPIC TYPE [FIELD] [--best-effort]
"""
import sys

from anyros import DemoNode, field, message_class

topic, type_name = sys.argv[1], sys.argv[2]
path = sys.argv[3] if len(sys.argv) > 3 and not sys.argv[3].startswith("-") else ""
node = DemoNode("listen_peer")
node.subscribe(topic, message_class(type_name), lambda msg: print("heard", repr(field(msg, path)), flush=True),
               best_effort="--best-effort" in sys.argv)
print("ready", flush=True)
node.run(10.0, lambda: None)
