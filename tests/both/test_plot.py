"""``%plot`` on either ROS: what it cannot draw is refused in one line before any message, nothing left running."""

from __future__ import annotations

from shell import error_of
from support import wait_for


def test_a_field_the_type_lacks_or_that_is_no_number_is_refused_before_any_message(ip, session, peer):
    twist = peer("talk.py", "/pl/cmd", "geometry_msgs/Twist", "5")
    renamed = ["__name:=talk_words"] if session.backend.name == "ROS 1" else ["--ros-args", "-r", "__node:=talk_words"]
    words = peer("talk.py", "/pl/name", "std_msgs/String", "5", "data='hello'", *renamed)
    twist.wait_line("ready")
    words.wait_line("ready")
    wait_for(lambda: {"/pl/cmd", "/pl/name"} <= set(session.backend.graph_snapshot().topics), timeout=30,
             what="both topics in the graph")
    before = set(session.nodes)
    cases = {"%plot /pl/cmd linear.q": "/pl/cmd.linear.q: geometry_msgs/Vector3 has no field 'q' (it has x, y, z)",
             "%plot /pl/cmd.linear.q": "/pl/cmd.linear.q: geometry_msgs/Vector3 has no field 'q'",
             "%plot /pl/name data": "/pl/name.data: a string, not a number: a plot draws numbers; name a number field",
             "%plot /pl/cmd linear": "/pl/cmd.linear: a geometry_msgs/Vector3 message, not a number"}
    for line, says in cases.items():
        error = error_of(ip, line + " --duration 1")
        assert says in str(error) and "\n" not in str(error), (line, str(error))
    assert set(session.nodes) == before  # no plot node was made
