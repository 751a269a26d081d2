"""Bad input gets one line that says what is wrong and what to do, never a traceback or a wall of text."""

from __future__ import annotations

import sys

import pytest
from std_msgs.msg import String

from ipyros import rosNode
from ipyros.core import errors
from ipyros.dsl import engine_of


def one_line(error: BaseException) -> str:
    text = str(error)
    assert "\n" not in text, text
    assert len(text) < 1000, f"{len(text)} characters"
    return text


def test_a_missing_message_package_names_what_to_install(make_node, session):
    with pytest.raises(errors.MessageTypeError) as caught:
        make_node("install_hint").new.subscribe("/hint", handler=print, msgType="nav_msgs/Odometry")
    text = one_line(caught.value)
    wanted = "pip install ros-nav-msgs" if session.backend.name == "ROS 2" else "apt install python3-nav-msgs"
    assert wanted in text, text


@pytest.mark.parametrize("call, says, kind", [
    (lambda: rosNode(), "rosNode() needs a name: takes name and namespace", TypeError),
    (lambda: rosNode("x", ns="/robot1"), "got unknown keyword argument(s) ns; it takes name and namespace", TypeError),
    (lambda: rosNode("x", colour="red", size=3), "unknown keyword argument(s) colour, size", TypeError),
])
def test_a_node_made_wrong_says_what_rosnode_takes(call, says, kind):
    with pytest.raises(kind) as caught:
        call()
    assert says in one_line(caught.value)


def test_one_line_for_what_used_to_be_a_traceback(make_node, tmp_path):
    nd = make_node("one_line_node")
    nd.new.publish("/one_line/out", msgType=String)
    cases = [
        (lambda: rosNode("one_line_x", session=engine_of(nd).session).discover(), errors.DeclarationError,
         "wraps no basenode, so there is nothing to discover"),
        (lambda: nd.baseBag(5), errors.DeclarationError, "baseBag(5): give the bag's path"),
        (lambda: nd.export(5), errors.DeclarationError, "export(5): give a path"),
        (lambda: nd.save(tmp_path), errors.DeclarationError, "that is a directory; give a file"),
        (lambda: nd.save(5), errors.DeclarationError, "save(5): give a path"),
        (lambda: nd.timer(1, print, name="bad name"), errors.DeclarationError, "timer name 'bad name'"),
        (lambda: nd.params["nope"], KeyError, "has no parameter 'nope' (it has none yet)"),
        (lambda: nd.baseNode("talker", remaps={"a": ["b"] * 100000}), errors.DeclarationError, "characters)"),
        (lambda: nd.baseNode("talker", args="x" * 200000), errors.DeclarationError, "characters)"),
    ]
    for call, kind, says in cases:
        with pytest.raises(kind) as caught:
            call()
        text = one_line(caught.value)
        assert says in text, text
    nd.params["gain"] = 1
    with pytest.raises(KeyError, match="it has 'gain'"):
        del nd.params["nope"]


def test_a_garbage_bag_is_one_line(make_node, tmp_path):
    garbage = tmp_path / "garbage.bag"
    garbage.write_bytes(bytes(range(256)) * 64)
    with pytest.raises(errors.DeclarationError) as caught:
        make_node("garbage_bag").baseBag(garbage)
    assert f"cannot read the bag {garbage}" in one_line(caught.value)


def test_a_model_with_an_unknown_role_is_one_line(tmp_path):
    from ipyros.files import modelfile as keep

    path = tmp_path / "role.yaml"
    path.write_text(f"{keep.FORMAT_KEY}: {keep.FORMAT}\nnode: {{name: x, topics: [{{name: /a, resolved: /a, "
                    "direction: publish, type: std_msgs/String, role: borrowed}]}\n")
    with pytest.raises(errors.IpyrosError) as caught:
        rosNode.load(path)
    assert "role 'borrowed' is not one of new, reuse" in one_line(caught.value)


def test_a_full_disk_is_one_line_and_keeps_the_file(make_node, tmp_path, monkeypatch):
    import errno
    import os

    from ipyros.files import modelfile as keep

    nd = make_node("full_disk")
    nd.new.publish("/full/out", msgType=String)
    target = tmp_path / "node.yaml"
    target.write_text("before")

    def no_space(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(keep.os, "fsync", no_space)
    with pytest.raises(errors.IpyrosError) as caught:
        nd.save(target)
    assert "No space left on device; nothing was changed there" in one_line(caught.value)
    assert target.read_text() == "before" and [p.name for p in tmp_path.iterdir()] == ["node.yaml"]


def test_a_basenode_given_100000_arguments_fails_in_one_readable_line(make_node, tmp_path):
    """The basenode's own complaint and its log are quoted, never its 100,000 arguments whole."""
    script = tmp_path / "too_many.py"
    script.write_text(f"#!{sys.executable}\nimport sys\nsys.exit(f'given {{len(sys.argv) - 1}} arguments, wanted none')\n")
    script.chmod(0o755)
    nd = make_node("many_args").baseNode(str(script), name="many_args_base", args=["x"] * 100_000)
    with pytest.raises(errors.BaseNodeError) as caught:
        nd.create()
    text = one_line(caught.value)
    assert "characters cut" in text and "arguments, wanted none" in text, text[-300:]  # its own last words


@pytest.mark.parametrize("make, size", [
    (lambda make_node: make_node("n" * 5_000), 5_000),
    (lambda make_node: make_node("long_ns", namespace="/" + "s" * 3_000), 3_001),
    (lambda make_node: make_node("long_topic").new.publish("/" + "t" * 6_000, msgType=String), 6_001),
])
def test_long_names_are_quoted_cut_with_their_size(make_node, session, make, size):
    """On ROS 2 they are refused by its length rules (a node's name 255, a namespace 245, a topic 247); on ROS 1,
    which has none, they are taken; what an error quotes of them is cut either way."""
    if session.backend.name == "ROS 1":
        make(make_node)
        return
    with pytest.raises(errors.TopicNameError) as caught:
        make(make_node)
    text = one_line(caught.value)
    assert f"is {size:,} characters; ROS 2 allows" in text and len(text) < 300, text


def test_names_follow_the_rules_of_the_sessions_ros(make_node, session):
    """ROS 2 reserves '__' in every name; ROS 1 allows it."""
    if session.backend.name == "ROS 1":
        nd = make_node("underscores")
        nd.new.publish("/a__b", msgType=String)
        assert nd.model().topics[0].resolved == "/a__b"
        return
    for declare in (lambda: make_node("underscores").new.publish("/a__b", msgType=String),
                    lambda: make_node("a__b"),
                    lambda: make_node("ns_underscores", namespace="/r__1")):
        with pytest.raises(errors.TopicNameError) as caught:
            declare()
        assert "ROS 2 reserves '__'" in one_line(caught.value)


@pytest.mark.parametrize("value", [2**70, [2**70], [1, -2**64]])
def test_an_integer_parameter_out_of_64_bits_is_refused_in_one_line(make_node, session, value):
    """ROS 2's parameters hold 64-bit integers, ROS 1's parameter server (XML-RPC) 32-bit ones."""
    nd = make_node("wide_param").create()
    with pytest.raises(errors.DeclarationError) as caught:
        nd.params["p"] = value
    text = one_line(caught.value)
    bits = "64-bit" if session.backend.name == "ROS 2" else "32-bit"
    assert "does not fit" in text and bits in text, text
    assert "p" not in nd.model().params
