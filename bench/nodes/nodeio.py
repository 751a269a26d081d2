"""What every bench node process shares: starting rospy, and talking to the bench over pipes.

The bench drives its nodes through their standard input and output, one line per
command or answer, so it never has to guess with sleeps. A node ends when its standard
input closes (the bench went away) or when it reads ``quit``; the bench also starts
nodes with a parent-death signal, so nothing outlives it.
"""

from __future__ import annotations

import sys
import warnings
from typing import Callable, Optional

import rospy

# rospy warns when a Publisher has no queue_size; None (synchronous) is the bench's choice.
warnings.filterwarnings("ignore", message="The publisher should be created with an explicit")


def start(name: str) -> None:
    """Start this process's rospy node; signals stay the bench's (it stops nodes by PID)."""
    rospy.init_node(name, disable_signals=True)


def say(*words: object) -> None:
    """One answer line to the bench."""
    sys.stdout.write(" ".join(str(w) for w in words) + "\n")
    sys.stdout.flush()


def serve(commands: Optional[dict[str, Callable[[], object]]] = None,
          cleanup: Optional[Callable[[], None]] = None) -> None:
    """Answer the bench's commands until ``quit`` or end of input; then ``cleanup()``, and
    shut rospy down."""
    commands = commands or {}
    for line in sys.stdin:
        word = line.strip()
        if word == "quit":
            break
        action = commands.get(word)
        if action is None:
            say("error", f"unknown command {word!r}")
        else:
            answer = action()
            if answer is not None:
                say(answer)
    try:
        if cleanup is not None:
            cleanup()
    finally:
        rospy.signal_shutdown("bench done")
