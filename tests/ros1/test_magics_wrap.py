"""%wrap: a basenode wrapped in one line, bound in the user namespace, its interface printed."""

from __future__ import annotations

import pytest
from IPython.core.error import UsageError
from peer import Peer
from ros1_fixtures import master_state, wait_for
from shell import error_of, ok

from ipyros import rosNode
from ipyros.core.errors import BaseNodeError
from ipyros.ipython.magics.wrap import rosrun_words


def test_rosrun_words_split_into_remaps_params_and_arguments():
    assert rosrun_words(["in:=/w/in", "_rate:=10", "_name:=robot", "_gains:=[1, 2]", "--prefix", "x"]) == (
        {"in": "/w/in"}, {"rate": 10, "name": "robot", "gains": [1, 2]}, ["--prefix", "x"])
    with pytest.raises(UsageError, match="a remap is from:=to"):
        rosrun_words(["in:="])
    with pytest.raises(UsageError, match="cannot read the value"):
        rosrun_words(["_p:=[1,"])


def test_wrap_binds_the_wrapping_node_and_prints_its_interface(ip, capsys, ros_master):
    try:
        ok(ip, "%wrap ipyros_test_nodes echo_node --as ew --ns mw in:=words -- --prefix ew:")
        node = ip.user_ns["ew"]
        assert isinstance(node, rosNode) and node.created and node.name == "ew"
        out = capsys.readouterr().out
        assert "rosNode /mw/ew (running) wrapping ipyros_test_nodes/echo_node" in out
        assert "/mw/words" in out and "/mw/out" in out and "bound to ew" in out
        assert master_state(ros_master)["pub"]["/mw/out"] == ["/ipyros_test"]  # the wrapper relays B's output
        with Peer("echo_topic.py", "/mw/out", "std_msgs/String") as listener:
            listener.wait_line("ready")
            ok(ip, "%pub /mw/words std_msgs/String hi")
            listener.wait_line('data: "ew:hi"')
    finally:
        if "ew" in ip.user_ns:
            ok(ip, "ew.shutdown()")
    wait_for(lambda: "/mw/out" not in master_state(ros_master)["pub"], what="the wrapper to stop")


def test_wrap_default_variable_and_errors(ip, capsys):
    try:
        ok(ip, "%wrap ipyros_test_nodes echo_node --name mw_default")
        assert isinstance(ip.user_ns.get("echo_node_wrapper"), rosNode)
        assert "bound to echo_node_wrapper" in capsys.readouterr().out
    finally:
        if "echo_node_wrapper" in ip.user_ns:
            ok(ip, "echo_node_wrapper.shutdown()")
    error = error_of(ip, "%wrap no_such_package_here echo_node")
    assert isinstance(error, BaseNodeError) and "no_such_package_here" in str(error)
    assert "give a Python variable name" in str(error_of(ip, "%wrap ipyros_test_nodes echo_node --as 2x"))
    assert "the following arguments are required: executable" in str(error_of(ip, "%wrap ipyros_test_nodes"))


def test_wrap_does_not_rebind_a_variable_holding_a_running_node(ip, ros_master):
    try:
        ok(ip, "busy = rosNode('mw_busy').create()")
        error = error_of(ip, "%wrap ipyros_test_nodes echo_node --as busy --name mw_never")
        assert isinstance(error, UsageError)
        assert "--as busy holds the running node /mw_busy; give another name with --as, or stop that one " \
               "first: busy.shutdown()" in str(error)
        assert ip.user_ns["busy"].created and ip.user_ns["busy"].name == "mw_busy"
        assert "/mw_never" not in master_state(ros_master)["pub"].get("/rosout", [])  # nothing was started
        ok(ip, "echo_node_wrapper = rosNode('mw_default_holder').create()")
        assert "the default variable echo_node_wrapper holds the running node" in str(
            error_of(ip, "%wrap ipyros_test_nodes echo_node --name mw_never"))
    finally:
        for variable in ("busy", "echo_node_wrapper"):
            if variable in ip.user_ns:
                ok(ip, f"{variable}.shutdown()")
