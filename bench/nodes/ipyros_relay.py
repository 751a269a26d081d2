"""Paths (c) and (d) of the relay bench through ipyros's own runtime, in a node process of its own.

    ipyros_relay.py reuse|handler IN OUT KIND

``reuse``: an :class:`ipyros.runtime.Relay` from IN to OUT, what a wrapping node's
``reuse`` declaration runs. ``handler``: a typed :class:`ipyros.runtime.Subscription`
whose :class:`ipyros.slots.HandlerSlot` calls a handler that changes one field and
writes the message on through an :class:`ipyros.runtime.Publication`, what
``new.subscribe(topic, handler)`` plus a publish runs. So the bench measures the
runtime's code as it is, slot bookkeeping included.
"""

from __future__ import annotations

import os
import sys

import nodeio
import wire
from ipyros import runtime
from ipyros.slots import HandlerSlot


def report_failure(failure) -> None:
    nodeio.say("error", f"handler failed: {failure.error!r}")


def main() -> None:
    mode, source, target, kind = sys.argv[1:5]
    node = runtime.ProcessNode()
    node.start("/bench_ipyros_relay", os.environ["ROS_MASTER_URI"])
    cls = wire.message_class(kind)
    if mode == "reuse":
        runtime.Relay(source, target, cls)
    else:
        change = wire.KINDS[kind].handle
        out = runtime.Publication(target, cls)

        def handler(msg) -> None:
            change(msg)
            out.write(msg)

        runtime.Subscription(source, cls, HandlerSlot(f"bench {source}", handler, report_failure))
    nodeio.say("ready")
    nodeio.serve()
    node.shutdown()


if __name__ == "__main__":
    main()
