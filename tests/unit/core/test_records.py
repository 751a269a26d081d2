"""Records print as the tables the prompt shows: ``print(nd.status())`` in a script or a handler
(:mod:`ipyros.core.records`)."""

from __future__ import annotations

from ipyros.core.journal import Change
from ipyros.core.records import History, Interface, NodeStatus, StatusRow, Versions
from ipyros.core.versions import HandlerVersion


def test_print_of_a_status_is_its_table_not_dataclass_text():
    status = NodeStatus("/talker", True, (StatusRow("subscribe", "/chatter", "on_chatter", 12, 10.0, 0.25, 1.5, 2),
                                         StatusRow("publish", "/out", "", 40, connections=3, dropped=1)),
                        (("~gain", "0.5"),))
    text = str(status)
    assert "StatusRow(" not in text and "NodeStatus(" not in text
    lines = text.splitlines()
    assert lines[0] == "status of /talker"
    assert lines[1].split() == ["kind", "name", "handler", "calls", "rate", "Hz", "mean", "ms", "max", "ms", "errors",
                                "subscribers", "dropped"]
    assert lines[3].split() == ["subscribe", "/chatter", "on_chatter", "12", "10.0", "0.250", "1.500", "2"]
    assert lines[4].split() == ["publish", "/out", "40", "3", "1"]
    assert lines[5].split() == ["param", "~gain", "0.5"]
    assert "(not running)" in str(NodeStatus("/talker", False, ()))


def test_a_status_row_with_errors_stands_out_in_the_table_data():
    table = NodeStatus("/n", True, (StatusRow("timer", "t", "tick", 3, errors=3),)).table()
    assert table.rows[0][7].style == "red" and str(table.rows[0][7]) == "3"


def test_print_of_a_history_and_of_versions():
    history = History("/n", (Change(0.0, "/n", "create()"), Change(1.0, "/n", "new.subscribe /x [std_msgs/String]")))
    lines = str(history).splitlines()
    assert lines[0] == "history of /n" and lines[3].split()[::2] == ["1", "create()"]
    assert lines[4].endswith("new.subscribe /x [std_msgs/String]")
    versions = Versions("n /x", (HandlerVersion(1, 0.0, "h", "def h(msg):\n    print(msg)\n"),
                                 HandlerVersion(2, 60.0, "h", None)), 2)
    text = str(versions)
    assert text.splitlines()[0] == "versions of the handler of n /x"
    assert "print(msg)" in text and "2 (now)" in text and "no source" in text


def test_print_of_an_interface_names_each_entry_and_what_was_left_out():
    interface = Interface("/nav", publications=[("/odom", "nav_msgs/Odometry")], subscriptions=[("/goal", "")],
                          left_out=["/nav/get_loggers (serves)"], not_seen=["/scan (subscribe)"])
    lines = str(interface).splitlines()
    assert lines[0] == "Interface of /nav"
    assert lines[3].split() == ["publishes", "/odom", "nav_msgs/Odometry"]
    assert lines[4].split() == ["subscribes", "/goal", "unknown"]
    assert any(line.split()[:3] == ["not", "seen", "/scan"] for line in lines)
    assert any("~get_loggers" in line and "ROS plumbing" in line for line in lines)


def test_a_bags_info_is_a_table_of_its_topics_with_the_storage_count_and_span():
    from ipyros.core.records import BagInfo, BagTopic

    info = BagInfo("run", "mcap", 100.0, 102.5, (BagTopic("/a", "std_msgs/msg/String", 3),
                                                  BagTopic("/b", "geometry_msgs/msg/Twist", 7)))
    assert (info.messages, info.duration) == (10, 2.5)
    text = str(info).splitlines()
    assert text[0].startswith("bag run (mcap): 10 messages, ") and text[0].endswith("(2.500 s)")
    assert text[3].split() == ["/a", "std_msgs/msg/String", "3"]
    assert str(BagInfo("empty", "bag", 0.0, 0.0, ())).splitlines()[0] == "bag empty (bag): 0 messages"


def test_a_records_repr_is_short_and_names_what_it_is():
    """At the prompt a record shows as its table; its repr (a list of them, a debugger) is one short line naming
    its kind and its title, not a dataclass's every field (a BagInfo's was 300 characters)."""
    from ipyros.core.records import BagInfo, BagTopic

    info = BagInfo("/data/" + "long_name_" * 20 + ".bag", "bag", 0.0, 2.0,
                   tuple(BagTopic(f"/t{i}", "std_msgs/UInt32", 5) for i in range(30)))
    text = repr(info)
    assert text.startswith("<BagInfo: bag /data/long_name_") and text.endswith("…>") and len(text) <= 115, text
    assert "\n" not in text and "BagTopic" not in text


def test_an_interfaces_repr_counts_what_it_holds():
    from ipyros.core.records import Interface

    interface = Interface("/turtle_sim", publications=[("/turtle1/pose", "turtlesim/Pose")] * 3,
                          subscriptions=[("/turtle1/cmd_vel", "geometry_msgs/Twist")])
    assert repr(interface) == "<Interface: /turtle_sim: 3 published, 1 subscribed, 0 services, 0 actions>"
