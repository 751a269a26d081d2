"""rospy takes Python's logging for its log file; what IPython and traitlets say still reaches the user."""

from __future__ import annotations


def test_a_refused_setting_is_said_after_a_node_exists(ip, make_node, capsys):  # noqa: F811
    make_node("logging_first").create()  # rospy.init_node has run: it configured logging
    capsys.readouterr()
    ip.run_line_magic("config", "RosMagics.graph_period = 0")
    err = capsys.readouterr().err
    assert "graph_period must be from 0.05 to 3600 seconds, not 0.0" in err, err
    assert ip.run_line_magic("config", "RosMagics.graph_period") != 0
