"""Errors that ipyros raises for bad input or a broken ROS graph.

Every error is one line that says what is wrong and what to do about it. Inside
IPython the extension shows only that line (no traceback); outside IPython they are
ordinary exceptions. Each subclass is also a ``ValueError``/``RuntimeError`` where
that is what it is, so generic code can still catch them the usual way.
"""

from __future__ import annotations


class IpyrosError(Exception):
    """Base class: a one-line, actionable message about something the user asked for."""


class DeclarationError(IpyrosError, ValueError):
    """A DSL declaration was rejected; nothing already running was changed."""


class MessageTypeError(DeclarationError):
    """A message or service type is unknown, malformed, or not the one expected."""


class TopicNameError(DeclarationError):
    """A topic, service or parameter name is not a valid ROS name."""


class HandlerError(DeclarationError):
    """A handler is not callable or does not take the arguments it will be given."""


class TopicTypeConflict(MessageTypeError):
    """The declared type differs from the type the live topic already has."""


class NotDeclaredError(IpyrosError, LookupError):
    """The node does not have the topic, timer or service that was named."""


class MasterError(IpyrosError, RuntimeError):
    """No ROS master could be reached or started."""


class BaseNodeError(IpyrosError, RuntimeError):
    """The basenode could not be found, started, or kept running."""


class NodeStateError(IpyrosError, RuntimeError):
    """The node is not in a state where this operation makes sense (e.g. shut down)."""
