"""What a parameter can hold on each ROS, said in one line before anything is sent (pure: no ROS).

ROS 1's parameter server speaks XML-RPC: booleans, 32-bit integers, floats, strings, and lists and dicts of those
(string keys). A ROS 2 parameter is typed: bool, 64-bit int, float, str, bytes, or a list of one of bool, int,
float or str. Without these checks a bad value fails deep in xmlrpc or rclpy, with a traceback or half-way
through a nested dict.
"""

from __future__ import annotations

from typing import Any

from .errors import DeclarationError, cut

__all__ = ["check_ros1", "check_ros2"]

_INT32 = range(-2**31, 2**31)


def check_ros1(name: str, value: Any, _depth: int = 0) -> None:
    """Refuse, in one line, a value the ROS 1 parameter server cannot hold.

    It speaks XML-RPC: booleans, 32-bit integers, floats, strings, lists and dicts with
    string keys, nothing else. Without this check a bad value fails deep in xmlrpc with
    a traceback (``None``, ``object()``) or half-way through a nested dict.
    """
    if value is None:
        raise DeclarationError(f"parameter {name} = None: the ROS parameter server has no null; "
                               f"to remove the parameter use del nd.params[...]")
    if isinstance(value, bool) or isinstance(value, (float, str)):
        return
    if isinstance(value, int):
        if value not in _INT32:
            raise DeclarationError(f"parameter {name} = {value} does not fit the 32-bit integer the ROS "
                                   f"parameter server holds; pass it as a float ({float(value)!r}) or a string")
        return
    if _depth > 50:
        raise DeclarationError(f"parameter {name} is nested more than 50 levels deep; flatten it")
    if isinstance(value, (list, tuple)):
        for i, item in enumerate(value):
            check_ros1(f"{name}[{i}]", item, _depth + 1)
        return
    if isinstance(value, dict):
        for key, item in value.items():
            if not isinstance(key, str):
                raise DeclarationError(f"parameter {name} has key {key!r}: the parameter server takes "
                                       f"string keys only; use {str(key)!r}")
            check_ros1(f"{name}/{key}", item, _depth + 1)
        return
    raise DeclarationError(f"parameter {name} = {value!r} is a {type(value).__name__}: the ROS parameter "
                           "server holds bool, int, float, str, and lists or dicts of those")


_INT64 = range(-2**63, 2**63)


def check_ros2(name: str, value: Any) -> None:
    """Refuse, in one line, a value a ROS 2 parameter cannot hold.

    bool, 64-bit int, float, str, bytes, and lists of one of bool, int, float or str.
    """
    if value is None:
        raise DeclarationError(f"parameter {name} = None: a ROS 2 parameter cannot be unset that way; "
                               "use del nd.params[...]")
    if isinstance(value, (bool, float, str, bytes)):
        return
    if isinstance(value, int):
        if value not in _INT64:
            raise DeclarationError(f"parameter {name} = {cut(value)} does not fit the 64-bit integer a ROS 2 parameter "
                                   "holds; pass it as a float or a string")
        return
    if isinstance(value, (list, tuple)):
        kinds = {bool if isinstance(v, bool) else type(v) for v in value}
        if not (len(kinds) <= 1 and kinds <= {bool, int, float, str}):
            raise DeclarationError(f"parameter {name} = {cut(value)}: a ROS 2 parameter list holds one type "
                                   "(bool, int, float or str)")
        wide = next((v for v in value if kinds == {int} and v not in _INT64), None)
        if wide is not None:
            raise DeclarationError(f"parameter {name} = {cut(value)}: its item {cut(wide)} does not fit the 64-bit "
                                   "integers a ROS 2 parameter list holds; pass floats or strings")
        return
    raise DeclarationError(f"parameter {name} = {cut(value)} is a {type(value).__name__}: a ROS 2 parameter "
                           "holds bool, int, float, str, bytes or a list of one of those")
