"""The paper's spelling, ``node.reuse.publish.cmd_vel(Twist)``, for publish, subscribe, service and action on
``new`` and ``reuse``, with TAB after the dot offering the names the graph has there (issue 25)."""

from __future__ import annotations

from IPython.core.completer import provisionalcompleter
from shell import ok
from support import wait_for


def test_a_name_spelled_as_attributes_declares_it(make_node, counting):
    nd = make_node("spelled")
    nd.new.publish.cmd_vel("geometry_msgs/Twist")
    nd.new.subscribe.turtle1.pose(print, msgType="geometry_msgs/Pose")
    nd.new.service.reset("std_srvs/Empty", handler=lambda request: None)
    nd.new.action.count(counting.type, lambda goal: None)
    model = nd.model()
    assert [(t.name, t.direction) for t in model.topics] == [("cmd_vel", "publish"), ("turtle1/pose", "subscribe")]
    assert [s.name for s in model.services] == ["reset"] and [a.name for a in model.actions] == ["count"]
    assert nd.new.publish("/plain", "std_msgs/String") is not None, "the method is still called as it was"
    assert "Publish ``topic``" in nd.new.publish.__doc__


def test_tab_after_the_dot_offers_the_graphs_names_there(ip):
    ok(ip, "talker = rosNode('spell_talker', namespace='/spell_tab')"
           ".new.publish('turtle1/pose', msgType='geometry_msgs/Pose').create()\n"
           "nd = rosNode('spell_tab_node', namespace='/spell_tab')")

    def completions(text):
        with provisionalcompleter():
            return [c.text for c in ip.Completer.completions(text, len(text))]

    wait_for(lambda: "turtle1" in completions("nd.new.subscribe.tu"), timeout=20, interval=0.3,
             what="the namespace's first name part to complete")
    assert "pose" in completions("nd.new.subscribe.turtle1.po")


def test_saving_writes_the_spelling_that_reads_best_and_loads_back(ip, tmp_path):
    path = tmp_path / "spelled.py"
    ok(ip, "def keep(msg):\n    return None\n"
           "sp = rosNode('spell_save')\n"
           "sp.new.publish.cmd_vel('geometry_msgs/Twist')\n"
           "sp.new.subscribe('/spell_save/absolute', keep, msgType='std_msgs/String')\n"
           "sp.new.subscribe.turtle1.pose(keep, msgType='geometry_msgs/Pose')\n"
           "sp.new.service('~reset', 'std_srvs/Empty', handler=keep)\n"
           f"sp.save({str(path)!r})")
    text = path.read_text()
    twist, string, pose = (ip.user_ns["sp"].model().topics[i].type for i in range(3))
    assert f"sp.new.publish.cmd_vel(msgType={twist!r})" in text, text
    assert f"sp.new.subscribe.turtle1.pose(handler=keep, msgType={pose!r})" in text, "relative: the paper's spelling"
    assert f"sp.new.subscribe('/spell_save/absolute', handler=keep, msgType={string!r})" in text, "global: a string"
    assert "sp.new.service('~reset', " in text, "a private name is a string"
    ok(ip, f"loaded = rosNode.load({str(path)!r}, get_ipython().user_ns)")
    assert ip.user_ns["loaded"].model().topics == ip.user_ns["sp"].model().topics
    assert ip.user_ns["loaded"].model().services == ip.user_ns["sp"].model().services
