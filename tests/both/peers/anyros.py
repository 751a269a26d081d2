"""What the peers of tests/both/ stand on: ipyros's demo node shim, which runs on rospy or rclpy.

A peer is a plain ROS node in a process of its own, written once for both ROS (the ROS
is the interpreter's: the ROS 1 venv has rospy, the ROS 2 venv rclpy). Message types
are given as ``pkg/Type`` and imported from ``pkg.msg``, the same module on both.
"""

from __future__ import annotations

import importlib
import sys
import threading
from pathlib import Path
from typing import Any

import ipyros

sys.path.insert(0, str(Path(ipyros.__file__).resolve().parent / "demo"))
from demonode import DemoNode  # noqa: E402,F401 - what the peers import from here


def message_class(type_name: str) -> Any:
    package, _, name = type_name.partition("/")
    return getattr(importlib.import_module(f"{package}.msg"), name.split("/")[-1])


def field(msg: Any, path: str) -> Any:
    """The value at a dotted field path (``linear.x``) of a message; the message itself for ``""``."""
    for part in filter(None, path.split(".")):
        msg = getattr(msg, part)
    return msg


_printing = threading.Lock()


def say(*parts: Any) -> None:
    """Print one line whole, from any thread: ROS 1 calls a subscriber back on a thread per publisher (the
    session's and a guard's process's, say), and ``print()`` of several parts from two threads interleaves."""
    line = " ".join(str(p) for p in parts) + "\n"
    with _printing:
        sys.stdout.write(line)
        sys.stdout.flush()
