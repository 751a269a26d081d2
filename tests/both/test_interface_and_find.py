"""%interface (rosmsg show / ros2 interface show), %topics --find and %services --find (issue 25)."""

from __future__ import annotations

from shell import error_of, ok
from support import response_of, wait_for

from ipyros.node.session import current


def test_interface_shows_a_types_definition(ip, capsys, counting):
    ok(ip, "%interface geometry_msgs/Twist")
    assert capsys.readouterr().out.split("\n")[:2] == ["geometry_msgs/Vector3 linear", "geometry_msgs/Vector3 angular"]
    ok(ip, "%interface geometry_msgs/Twist -r")
    assert "geometry_msgs/Vector3 linear\n  float64 x\n  float64 y\n  float64 z\n" in capsys.readouterr().out
    ok(ip, "%interface std_srvs/SetBool")
    assert capsys.readouterr().out == "bool data\n---\nbool success\nstring message\n"
    ok(ip, f"%interface {counting.type}")
    assert capsys.readouterr().out.count("---") == 2, "an action: goal, result, feedback"
    assert "geometry_msgs/Twst" in str(error_of(ip, "%interface geometry_msgs/Twst"))


def test_find_lists_the_topics_and_services_of_a_type(ip, make_node, capsys):
    from std_srvs.srv import SetBool

    make_node("find_it").new.publish("/find_it/speed", msgType="std_msgs/Float64") \
        .service("/find_it/enable", SetBool, handler=lambda request: response_of(SetBool)()).create()
    wait_for(lambda: "/find_it/enable" in current().backend.graph_snapshot().services, timeout=20,
             what="the service in the graph")
    capsys.readouterr()
    ok(ip, "%topics --find std_msgs/Float64")
    assert "/find_it/speed" in capsys.readouterr().out.split("\n")
    ok(ip, "%services --find std_srvs/SetBool")
    assert "/find_it/enable" in capsys.readouterr().out.split("\n")
    ok(ip, "%services /find_it --find std_srvs/Empty")
    assert "no live service of type std_srvs/Empty" in capsys.readouterr().out
