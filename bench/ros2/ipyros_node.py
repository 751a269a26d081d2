"""Paths (c) and (d) through ipyros itself, on ROS 2: a DSL node in a process of its own.

    ipyros_node.py reuse|guarded|handler IN OUT KIND

``reuse``: a wrapping node around ``idle.py`` (which publishes nothing: the bench's
publisher publishes on the wrapper's internal name in its place), ``reuse.publish(OUT)``:
the relay forwards bytes. ``guarded``: the same with a guard on OUT (limits on two fields, NaN and
infinities checked, no stop on silence): the relay reads, checks and writes every message. ``handler``: ``new.subscribe(IN, handler)`` that changes one
field and ``write``s the message on OUT. Says ``ready TOPIC``, TOPIC being where to publish.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

os.environ["IPYROS_ROS"] = "2"

import common  # noqa: E402
import wire2  # noqa: E402
from ipyros.dsl import rosNode  # noqa: E402
from ipyros.core.plan import internal_name  # noqa: E402

mode, source, target, kind = sys.argv[1:5]
cls = wire2.message_class(kind)
if mode in ("reuse", "guarded"):
    node = rosNode("bench_wrap")
    node.baseNode(str(Path(__file__).with_name("idle.py")))
    node.reuse.publish(target, type=cls)
    if mode == "guarded":
        node.guard(target, limits={"twist.linear.x": (-1.0, 1.0), "twist.angular.z": (-2.0, 2.0)}, grace=0.2)
    node.create()
    publish_on = internal_name(node.model(), node.resolve(target))
else:
    node = rosNode("bench_handler")
    change = wire2.KINDS[kind][2]

    def handler(msg) -> None:
        change(msg)
        node.write(target, msg)

    node.new.subscribe(source, handler=handler, type=cls).publish(target, type=cls)
    node.create()
    publish_on = node.resolve(source)
common.say("ready", publish_on)
common.serve()
node.shutdown()
