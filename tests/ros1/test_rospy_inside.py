"""rospy's internals, behind one door (ipyros/ros1/rospy_inside.py): rospy is shaped as ipyros relies on, and if it
is not, the suite says so loudly, naming rospy's version and what is missing."""

from __future__ import annotations

import pytest

from ipyros.ros1 import rospy_inside


def test_this_rospy_is_shaped_as_ipyros_relies_on():
    rospy_inside.check()


def test_a_rospy_of_another_shape_is_said_with_its_version_and_what_it_lacks(monkeypatch):
    import rospy.topics
    from rospy.impl import tcpros_pubsub

    monkeypatch.delattr(rospy.topics._TopicImpl, "remove_connection")  # where _SubscriberImpl has it from

    def robust_connect_subscriber(conn, dest_addr, dest_port, pub_uri, receive_cb, topic):
        pass

    monkeypatch.setattr(tcpros_pubsub, "robust_connect_subscriber", robust_connect_subscriber)
    with pytest.raises(rospy_inside.RospyShapeError) as caught:
        rospy_inside.check()
    text = str(caught.value)
    assert text.startswith(f"rospy {rospy_inside.rospy_version()} is not shaped as ipyros") and "\n" not in text
    assert "no _SubscriberImpl.add_connection and remove_connection (1, 2)" in text
    assert "robust_connect_subscriber with a local resolved_topic_name (5)" in text
    assert rospy_inside.rospy_version()[:1].isdigit()


def test_nothing_else_in_ros1_reaches_into_rospys_private_parts():
    """The door is the only one: rospy.impl, rospy.core, rospy.names and sys._getframe are named in rospy_inside.py
    alone (rospy's public API, rospy.Publisher and the like, is everyone's)."""
    from pathlib import Path

    import ipyros.ros1

    private = ("rospy.impl", "rospy.core", "rospy.names", "rospy.client", "_getframe", "get_topic_manager")
    found = []
    for path in Path(ipyros.ros1.__file__).parent.glob("*.py"):
        if path.name == "rospy_inside.py":
            continue
        for number, line in enumerate(path.read_text().splitlines(), 1):
            if not line.lstrip().startswith("#") and any(word in line for word in private):
                found.append(f"{path.name}:{number}: {line.strip()}")
    assert not found, "\n".join(found)


def test_a_rospy_endpoints_impl_is_reached_through_the_door_alone():
    """rospy's per-topic impl (its connections, its lock, its latch) is read by attribute in rospy_inside.py alone,
    through :func:`~ipyros.ros1.rospy_inside.impl_of`; the exported scripts' text is not ipyros's code, and may."""
    import ast
    from pathlib import Path

    import ipyros.ros1

    found = []
    for path in Path(ipyros.ros1.__file__).parent.glob("*.py"):
        if path.name != "rospy_inside.py":
            found += [f"{path.name}:{node.lineno}" for node in ast.walk(ast.parse(path.read_text()))
                      if isinstance(node, ast.Attribute) and node.attr == "impl"]
    assert not found, found
