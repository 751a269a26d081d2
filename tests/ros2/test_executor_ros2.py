"""The one executor thread of a ROS 2 session is supervised: a callback that ends it does not end the session."""

from __future__ import annotations

import logging

from ros2_fixtures import wait_for
from std_msgs.msg import UInt32


def test_a_callback_that_raises_system_exit_does_not_stop_the_nodes(make_node, ros2_session, caplog):
    seen = []
    listener = make_node("supervised_listener").new.subscribe("/supervised", handler=lambda m: seen.append(m.data),
                                                             msgType=UInt32).create()
    talker = make_node("supervised_talker").new.publish("/supervised", msgType=UInt32).create()
    wait_for(lambda: talker.write("/supervised", UInt32(data=0)) or seen, interval=0.2, timeout=20,
             what="the first message")
    # A callback that is not a handler (none of ipyros's slots guards it) ends the executor's spin().
    host = ros2_session.process.host(listener.fullname)
    fired = []

    def end_it():
        fired.append(1)
        timer.cancel()
        raise SystemExit("not a handler's")

    with caplog.at_level(logging.WARNING, logger="ipyros"):
        timer = host.create_timer(0.01, end_it)
        wait_for(lambda: fired, what="the rogue callback")
        for i in range(1, 4):
            talker.write("/supervised", UInt32(data=i))
        wait_for(lambda: {1, 2, 3} <= set(seen), what="messages after the executor was ended once")
    host.destroy_timer(timer)
    assert any("raised SystemExit" in r.getMessage() and "runs again" in r.getMessage() for r in caplog.records)
