"""Where a ROS 1 handler's time goes, per message: what the handler path does that the relay does not.

    python -m bench.handler_cost            # about 20 seconds, no master needed

The relay bench measures the whole paths: flat out, a DSL handler costs its node some 26 µs of CPU
a message more than a ``reuse`` relay of the same topic (37.5 against 11.1 µs in the README's run),
because the relay forwards the bytes it read and the handler path does more. This bench times, in
this process and one at a time, each step of that more, as :class:`ipyros.ros1.endpoints.Subscription`
and :class:`~ipyros.ros1.endpoints.Publication` take them, with the relay bench's message (a
``TwistStamped``) and handler (one field changed, then written on):

1. the message made from the bytes (genpy's deserialise);
2. what ``%try`` needs to make it again later (a :class:`~ipyros.core.slots.Pristine`, lazy: only a
   closure over the bytes, which rospy made anyway);
3. what :func:`~ipyros.core.slots.arrival` tells the handler (an :class:`~ipyros.core.slots.Arrival`);
4. the slot's bookkeeping: :meth:`HandlerSlot.run <ipyros.core.slots.HandlerSlot.run>` around a
   handler that does nothing (its figures, the recent messages, the output scope);
5. the user's handler itself (one field changed);
6. the message made bytes again (genpy's serialise, into a fresh buffer as ``write`` does);
7. all of ``nd.write`` on a running DSL node (a rosmaster of the bench's own): its checks, the
   serialise of 6, and rospy's send to a topic with no subscriber (the lock, no socket).

What rospy then does with the bytes (the connection's queue, the socket) the relay does too.
Prints a table and saves it to bench/results/handler_cost.md.
"""

from __future__ import annotations

import functools
import io
import os
import statistics
import subprocess
import sys
import tempfile
import timeit
from pathlib import Path
from typing import Callable

RESULTS = Path(__file__).resolve().parent / "results"


def per_call_us(call: Callable[[], object], number: int = 20_000, repeat: int = 7) -> float:
    """The median over ``repeat`` runs of ``number`` calls, in µs a call."""
    return statistics.median(timeit.repeat(call, number=number, repeat=repeat)) / number * 1e6


def measure() -> list[tuple[str, float]]:
    from geometry_msgs.msg import TwistStamped
    from rospy.msg import serialize_message

    from ipyros.core.slots import Arrival, HandlerSlot, Pristine
    from ipyros.ros1.endpoints import _message

    msg = TwistStamped()
    msg.header.frame_id = "base_link"
    msg.twist.linear.x, msg.twist.angular.z = 0.5, 0.1
    buffer = io.BytesIO()
    serialize_message(buffer, 1, msg)
    raw = buffer.getvalue()[4:]  # what rospy hands a subscriber: the message without its length prefix
    header = {"callerid": "/talker", "latching": "0"}

    def handler(m: TwistStamped) -> None:
        m.twist.linear.x += 1.0

    slot = HandlerSlot("bench handler", lambda m: None, report=lambda *_: None)
    given = _message(TwistStamped, raw, header)

    def serialise() -> None:
        serialize_message(io.BytesIO(), 2, given)

    steps = [
        ("1. deserialise (the message from its bytes)", lambda: _message(TwistStamped, raw, header)),
        ("2. what %try keeps (Pristine, lazy)",
         lambda: Pristine(functools.partial(_message, TwistStamped, raw, header))),
        ("3. what arrival() tells (Arrival)", lambda: Arrival(header.get("callerid", "?"), len(raw), False)),
        ("4. the slot's bookkeeping (run around a no-op)", lambda: slot.run(given)),
        ("5. the handler (one field changed)", lambda: handler(given)),
        ("6. serialise (write's bytes)", serialise),
    ]
    rows = [(what, per_call_us(call)) for what, call in steps]
    rows.append(("7. nd.write (its checks, 6, rospy's send to no subscriber)", dsl_write_us()))
    return rows


def dsl_write_us() -> float:
    """``nd.write`` on a running DSL node, in µs a call: timed in a child process (:func:`write_here`), because
    a session ends rospy for good in its process, and the benches after this one start sessions of their own."""
    done = subprocess.run([sys.executable, "-m", "bench.handler_cost", "--write"], capture_output=True, text=True,
                          timeout=300, cwd=Path(__file__).resolve().parent.parent)
    if done.returncode != 0:
        raise RuntimeError(f"the nd.write timing failed: {done.stderr.strip().splitlines()[-1:]}")
    return float(done.stdout.split()[-1])


def write_here() -> float:
    """``nd.write`` on a DSL node of this process's session, with a rosmaster of its own (``--write``)."""
    from geometry_msgs.msg import TwistStamped

    from bench.relay import Master
    from ipyros.dsl import rosNode
    from ipyros.node.session import current

    msg = TwistStamped()
    msg.header.frame_id = "base_link"
    msg.twist.linear.x, msg.twist.angular.z = 0.5, 0.1
    with tempfile.TemporaryDirectory(prefix="ipyros-bench-handler-") as tmp:
        master = Master(Path(tmp))
        os.environ.update({k: master.env[k] for k in ("ROS_MASTER_URI", "ROS_IP", "ROS_HOME", "ROS_LOG_DIR")})
        try:
            node = rosNode("handler_cost")
            node.new.publish("/handler_cost/out", msgType=TwistStamped)
            node.create()
            return per_call_us(lambda: node.write("/handler_cost/out", msg))
        finally:
            current().close()
            master.stop()


def main(argv: list[str] | None = None) -> int:
    if "--write" in (sys.argv[1:] if argv is None else argv):
        print(f"{write_here():.3f}")
        return 0
    rows = measure()
    total = sum(us for _, us in rows)
    text = ("Where a ROS 1 handler's time goes, per TwistStamped, in this process (median of 7 runs of "
            "20,000 calls)\n\n| step | µs |\n|---|---:|\n"
            + "".join(f"| {what} | {us:.2f} |\n" for what, us in rows)
            + f"| 1 to 5, and 7 (6 is in 7) | {total - rows[5][1]:.2f} |\n")
    print(text)
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "handler_cost.md").write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
