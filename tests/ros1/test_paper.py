"""The paper's turtle example (section III-B), typed as the paper types it, against the demo robot."""

from __future__ import annotations

from pathlib import Path

import rospy
from geometry_msgs.msg import Pose, Twist
from peer import Peer
from ros1_fixtures import wait_for

from ipyros import rosNode

TURTLE_SIM = Path(__file__).resolve().parents[2] / "ipyros" / "demo" / "turtle_sim"
poses: list = []


def test_turtle_example_runs_as_typed(ros_session):
    def showPose(data):  # noqa: N802 - the paper's names
        poses.append(data)

    with Peer(str(TURTLE_SIM), "__name:=turtlesim"):
        nd = rosNode("turtle_control_node")
        {
        nd.new.subscribe(topic = "/turtle1/pose", handler = showPose, msgType = Pose)
              .publish(topic = "/turtle1/cmd_vel", msgType = Twist)
        }
        nd.create()
        try:
            wait_for(lambda: len(poses) > 3, timeout=20, what="poses from the demo robot")
            assert poses[-1].position.x == 0.0

            def onTimer(event):  # noqa: N802
                msg = Twist()
                msg.linear.x = 2.0
                msg.angular.z = 1.8
                nd.write("/turtle1/cmd_vel", msg )

            timer = rospy.Timer(rospy.Duration(0.1), onTimer)
            try:
                wait_for(lambda: abs(poses[-1].position.x) > 0.2, timeout=20, what="the turtle to move")
                wait_for(lambda: poses[-1].orientation.z != 0.0, timeout=10, what="the turtle to turn")
            finally:
                timer.shutdown()
        finally:
            nd.shutdown()
