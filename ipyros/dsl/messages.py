"""A workspace's own message types, made importable at the prompt: :func:`build_messages`."""

from __future__ import annotations

import os

from ..node.session import current

__all__ = ["build_messages"]


def build_messages(package_dir: "str | os.PathLike[str]", into: "str | os.PathLike[str] | None" = None) -> list[str]:
    """Make the ``.msg`` and ``.srv`` files of the message package at ``package_dir`` importable, now.

    ``build_messages("~/catkin_ws/src/my_robot_msgs")`` then ``from my_robot_msgs.msg import Status``: no
    catkin, no sourcing. The classes are written under ``into`` (``$IPYROS_MESSAGES_DIR``, else
    ``~/.ipyros/messages``), which this session and the basenodes it starts import from; the types
    complete at TAB and ``%pub``/``%echo`` take them. Returns the types built. ROS 1: genpy's Python, at once;
    ROS 2: rosidl's generators and the C compiler, a few seconds, shown as progress at the prompt.
    """
    session = current()
    return session.backend.build_messages(package_dir, into, session.progress)
