"""What a parameter can hold on each ROS (:mod:`ipyros.core.paramvalues`): one line for what it cannot, before
anything is sent."""

from __future__ import annotations

import pytest

from ipyros.core.errors import DeclarationError
from ipyros.core.paramvalues import check_ros1, check_ros2


@pytest.mark.parametrize("value", [True, 3, -2**31, 1.5, "x", [1, "a", [2.0]], {"a": {"b": [1, 2]}}, []])
def test_ros1_takes_what_xml_rpc_carries(value):
    check_ros1("/p", value)


@pytest.mark.parametrize("value, says", [
    (None, "parameter /p = None: the ROS parameter server has no null; to remove the parameter use del nd.params"),
    (2**31, "parameter /p = 2147483648 does not fit the 32-bit integer"),
    ([1, [2, None]], "parameter /p[1][1] = None"),
    ({"a": {3: 1}}, "parameter /p/a has key 3: the parameter server takes string keys only; use '3'"),
    (object(), "is a object: the ROS parameter server holds bool, int, float, str, and lists or dicts of those"),
    (b"raw", "is a bytes"),
])
def test_ros1_refuses_in_one_line_naming_where(value, says):
    with pytest.raises(DeclarationError) as caught:
        check_ros1("/p", value)
    assert says in str(caught.value) and "\n" not in str(caught.value)


def test_ros1_refuses_a_value_nested_past_fifty_levels():
    deep: list = []
    for _ in range(60):
        deep = [deep]
    with pytest.raises(DeclarationError, match="nested more than 50 levels deep; flatten it"):
        check_ros1("/p", deep)


@pytest.mark.parametrize("value", [True, 2**62, 1.5, "x", b"raw", [1, 2], [True], ["a", "b"], [0.5], []])
def test_ros2_takes_its_parameter_types(value):
    check_ros2("p", value)


@pytest.mark.parametrize("value, says", [
    (None, "parameter p = None: a ROS 2 parameter cannot be unset that way; use del nd.params[...]"),
    (2**63, "does not fit the 64-bit integer a ROS 2 parameter holds; pass it as a float or a string"),
    ([1, "a"], "a ROS 2 parameter list holds one type (bool, int, float or str)"),
    ([1, 2**64], "its item 18446744073709551616 does not fit the 64-bit integers"),
    ({"a": 1}, "is a dict: a ROS 2 parameter holds bool, int, float, str, bytes or a list of one of those"),
    ([[1]], "a ROS 2 parameter list holds one type"),
])
def test_ros2_refuses_in_one_line(value, says):
    with pytest.raises(DeclarationError) as caught:
        check_ros2("p", value)
    assert says in str(caught.value) and "\n" not in str(caught.value)
