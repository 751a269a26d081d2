"""Paths (c) and (d) of the relay bench through ipyros itself: a DSL node in a process of its own.

    ipyros_node.py reuse|guarded|handler IN OUT KIND
    ipyros_node.py placed IN OUT KIND MACHINE

``reuse``: a wrapping node declared as issue 3's session declares one::

    w = rosNode("bench_wrap")
    w.baseNode("idle").basePackage("ipyros_bench")
    w.reuse.publish(topic=OUT, type=cls)
    w.create()

``create()`` launches the basenode remapped (OUT onto w's internal name) and relays
the internal name to OUT unchanged, without deserializing. The basenode
(``ipyros_bench/idle``, next to this file) publishes nothing: the bench's publisher
publishes on the internal name in its place, so that the bench drives the stream.
IN is not used.

``guarded``: the wrapping node of ``reuse`` with a guard on OUT (limits on two fields, NaN and
infinities checked, no stop on silence: the bench's pauses are not a robot's), as a session guards
a wrapped driver's output: the relay reads, checks and writes every message.

``handler``: a plain node whose handler changes one field and writes the message on::

    nd = rosNode("bench_handler")
    nd.new.subscribe(topic=IN, handler=handler, msgType=cls).publish(topic=OUT, msgType=cls)
    nd.create()

``placed``: the wrapping node of ``reuse`` with its basenode placed on MACHINE's keeper
(``.machine(MACHINE)``): the keeper there runs the basenode and the relay (bench/machine_relay.py).

Says ``ready TOPIC`` once running: TOPIC is where the bench's publisher must publish.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
#: Path (g)'s guard: the bench's messages are within them (the relay's cost is checking, not clamping).
GUARD_LIMITS = {"twist.linear.x": (-1.0, 1.0), "twist.angular.z": (-2.0, 2.0)}
# The stand-in basenode's package, found the way rosrun would find it.
os.environ["ROS_PACKAGE_PATH"] = os.pathsep.join(p for p in (str(HERE), os.environ.get("ROS_PACKAGE_PATH")) if p)

import nodeio  # noqa: E402  (after ROS_PACKAGE_PATH: nodeio imports rospy)
import wire  # noqa: E402
from ipyros.dsl import rosNode  # noqa: E402
from ipyros.core.plan import internal_name  # noqa: E402


def wrapping_node(target: str, cls: type, guarded: bool = False, machine: str | None = None) -> tuple[rosNode, str]:
    node = rosNode("bench_wrap")
    node.baseNode("idle").basePackage("ipyros_bench")
    if machine is not None:  # placed on that machine's keeper: the basenode and its relay run there
        node.machine(machine)
    node.reuse.publish(topic=target, type=cls)
    if guarded:
        node.guard(target, limits=GUARD_LIMITS, grace=0.2)
    node.create()
    return node, internal_name(node.model(), node.resolve(target))


def handler_node(source: str, target: str, cls: type, kind: str) -> tuple[rosNode, str]:
    node = rosNode("bench_handler")
    change = wire.KINDS[kind].handle

    def handler(msg) -> None:
        change(msg)
        node.write(target, msg)

    node.new.subscribe(topic=source, handler=handler, msgType=cls).publish(topic=target, msgType=cls)
    node.create()
    return node, node.resolve(source)


def main() -> None:
    mode, source, target, kind = sys.argv[1:5]
    cls = wire.message_class(kind)
    if mode in ("reuse", "guarded", "placed"):
        node, publish_on = wrapping_node(target, cls, guarded=mode == "guarded",
                                         machine=sys.argv[5] if mode == "placed" else None)
    else:
        node, publish_on = handler_node(source, target, cls, kind)
    nodeio.say("ready", publish_on)
    nodeio.serve(cleanup=node.shutdown)  # shutdown() stops the basenode too


if __name__ == "__main__":
    main()
