"""%handler on a topic a wrapping node only relays offers a pass-through handler to start from (issue 25)."""

from __future__ import annotations

from shell import ok
from support import wait_for


def test_handler_on_a_relayed_topic_offers_a_pass_through(ip, make_node, counting, capsys):
    # The counting basenode is any basenode here: its action stays relayed, a topic of it is what we take over.
    ok(ip, "from std_msgs.msg import String\n"
           "heard = []\n"
           "ear = rosNode('pt_ear').new.subscribe('/pt_robot/said', lambda m: heard.append(m.data), msgType=String)"
           ".create()\n"
           f"w = rosNode('pt_wrap')\nw.baseNode({str(counting.server)!r}, namespace='pt_robot')\n"
           "w.reuse.publish('said', type=String)\n"
           "w.create()")
    capsys.readouterr()
    ok(ip, "%handler w said")
    assert "relays /pt_robot/said unchanged" in capsys.readouterr().out
    offered = ip.rl_next_input
    assert offered.startswith("def on_said(msg):") and "w.write('/pt_robot/said', msg)" in offered, offered
    ok(ip, offered.replace("msg)  #", "String(data=msg.data.upper()))  #"))
    assert "is now handled by the new on_said" in capsys.readouterr().out
    model = ip.user_ns["w"].model()
    assert [(t.role, t.direction, t.handler) for t in model.topics if t.name == "said"] == [
        ("reuse", "publish", None), ("new", "subscribe", "on_said")]
    # the wrapper now publishes /pt_robot/said itself: what it writes is what the world hears
    try:
        wait_for(lambda: ok(ip, "w.write('/pt_robot/said', String(data='shout'))") and "shout" in ip.user_ns["heard"],
                 timeout=20, interval=0.2, what="the handler's output on the public name")
    finally:
        ok(ip, "w.shutdown(); ear.shutdown()")
