"""Run every benchmark of the ROS this venv has, in one go: ``python -m bench [--quick]``.

ROS 1 (a venv that sees rospy): the relay bench against topic_tools, where a handler's time goes,
the guard (stop on silence, hostile commands), a robot on another machine (link cuts, a lossy link, a relay
placed on it beside the session's),
%try over a bag, completion, an agent's tool calls (MCP) and %graph, scale; ROS 2 (rclpy): the relay bench,
the guard, %try over a bag, a robot on another machine, completion, the agent and %graph, and scale on rclpy.
Each bench starts what it needs (a rosmaster on a free port, or a DDS domain of its own), prints a table,
saves it under bench/results/, keeps its figures for
``python -m bench.figures`` and stops everything it started. The exit code is non-zero if a
target was missed.
"""

from __future__ import annotations

import importlib.util
import sys
import time


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    from bench import agent, completion, guard, scale, try_bag

    if importlib.util.find_spec("rospy") is None:
        from bench import machine_link, relay_ros2 as relay
        benches = (relay, guard, machine_link, try_bag, completion, agent, scale)
    else:
        from bench import handler_cost, machine_link, machine_relay, relay
        benches = (relay, handler_cost, guard, machine_link, machine_relay, try_bag, completion, agent, scale)

    status = 0
    started = time.monotonic()
    for number, bench in enumerate(benches, 1):  # each bench prints as it goes; here which one, and how far along
        gone = time.monotonic() - started
        print(f"\n=== {bench.__name__} ({number} of {len(benches)}; {gone // 60:.0f} min {gone % 60:.0f} s so far) "
              "===", flush=True)
        status |= bench.main(argv) or 0
    gone = time.monotonic() - started
    print(f"\n=== {len(benches)} benches in {gone // 60:.0f} min {gone % 60:.0f} s ===", flush=True)
    return status


if __name__ == "__main__":
    sys.exit(main())
