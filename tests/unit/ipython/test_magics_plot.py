"""What %plot reads from its words (:mod:`ipyros.ipython.magics.plot`), without ROS: a topic and its fields, or
message paths into one topic or several."""

from __future__ import annotations

import pytest
from IPython.core.error import UsageError

from ipyros.ipython.magics.plot import _topic_and_fields


@pytest.mark.parametrize("topic, fields, read", [
    ("/odom", ["twist.twist.linear.x"], ("/odom", ["twist.twist.linear.x"], {})),
    ("/odom.twist.twist.linear.x", ["/odom.pose.pose.position.x"],
     ("/odom", ["twist.twist.linear.x", "pose.pose.position.x"], {})),
    ("/odom.twist.twist.linear.x", ["/cmd_vel.linear.x", "angular.z"],
     ("/odom", ["twist.twist.linear.x"], {"/cmd_vel": ["linear.x", "angular.z"]})),
])
def test_the_words_of_a_plot_are_topics_and_their_fields(topic, fields, read):
    assert _topic_and_fields(topic, fields) == read


def test_a_plot_refuses_what_only_echo_reads():
    with pytest.raises(UsageError, match=r"/scan.ranges\[0\]: a plot draws number fields"):
        _topic_and_fields("/scan.ranges[0]", [])
