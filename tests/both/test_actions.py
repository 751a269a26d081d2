"""Actions on both ROS: served and called in the DSL, relayed and intercepted when wrapped, kept, and at the prompt.

Each test counts to N in the test action of its ROS (``counting``: actionlib/Test on ROS 1,
test_msgs/Fibonacci on ROS 2); the client that checks is the ROS's own (actionlib,
rclpy.action), as another program would be, and the basenodes are real processes.
"""

from __future__ import annotations

import os
import threading
import time

import pytest
from IPython.core.completer import provisionalcompleter
from helpers import run_exported, stop_exported
from shell import ctrl_c_after, error_of, ok
from support import wait_for

from ipyros.core.graph import actions_of
from ipyros.dsl import rosNode
from ipyros.node.session import current


def counter(counting, seen_cancel: list | None = None, step: float = 0.02):
    """An action handler that counts to the goal's N, a feedback per step, and stops at a cancel."""

    def count(goal, action):
        n = counting.n_of(goal)
        for i in range(1, n + 1):
            if action.cancelled:
                if seen_cancel is not None:
                    seen_cancel.append(n)
                return counting.result(i - 1)
            action.feedback(counting.feedback(i))
            time.sleep(step)
        return counting.result(n)

    return count


def test_a_node_serves_an_action_with_feedback_and_a_result(make_node, counting):
    server = make_node("act_server").new.action("/act/count", counting.type, counter(counting)).create()
    assert counting.plain_send("/act/count", 5) == ("succeeded", 5, [1, 2, 3, 4, 5])
    # ... and a DSL node calls it
    feedbacks: list[int] = []
    client = make_node("act_client").create()
    goal = client.send_goal("/act/count", counting.goal(3), feedback=lambda f: feedbacks.append(counting.i_of(f)))
    assert counting.k_of(goal.result(timeout=20)) == 3 and goal.status == "succeeded"
    assert feedbacks == [1, 2, 3]
    row = server.status().row("/act/count")
    assert (row.kind, row.handler, row.calls, row.errors) == ("action", "count", 2, 0)


def test_a_cancel_reaches_the_handler_from_any_client(make_node, counting):
    cancelled: list[int] = []
    make_node("act_cancel").new.action("/act/slow", counting.type, counter(counting, cancelled, 0.05)).create()
    state, reached, feedbacks = counting.plain_send("/act/slow", 1000, cancel_after=2)
    assert state == "cancelled" and reached < 1000 and cancelled == [1000]
    client = make_node("act_cancel_client").create()
    goal = client.send_goal("/act/slow", counting.goal(999))
    wait_for(lambda: goal.feedback is not None, timeout=20, what="the first feedback")
    assert goal.cancel() is True
    goal.result(timeout=20)
    assert goal.status == "cancelled" and cancelled == [1000, 999]


def test_the_handler_is_swapped_live_and_a_failing_one_aborts_the_goal(make_node, counting, failures):
    server = make_node("act_swap").new.action("/act/swap", counting.type, counter(counting)).create()
    assert counting.plain_send("/act/swap", 2)[:2] == ("succeeded", 2)

    def double(goal):
        return counting.result(2 * counting.n_of(goal))

    server.new.action("/act/swap", counting.type, double)
    assert counting.plain_send("/act/swap", 2) == ("succeeded", 4, [])
    assert [v.name for v in server.versions("/act/swap")] == ["count", "double"]

    def broken(goal):
        raise ValueError("no counting today")

    server.new.action("/act/swap", counting.type, broken)
    assert counting.plain_send("/act/swap", 2)[0] == "aborted"
    wait_for(lambda: failures, what="the handler's failure reported")
    assert "no counting today" in failures[0].traceback and server.status().row("/act/swap").errors == 1


def test_a_wrapped_basenodes_action_is_relayed_then_intercepted(make_node, counting):
    w = make_node("act_wrap")
    w.baseNode(str(counting.server), namespace="act_robot")
    w.reuse.action("count", type=counting.type)
    w.create()
    assert counting.plain_send("/act_robot/count", 4) == ("succeeded", 4, [1, 2, 3, 4])
    state, reached, _ = counting.plain_send("/act_robot/count", 1000, cancel_after=2)
    assert state == "cancelled" and reached < 1000
    wait_for(lambda: "cancelled 1000" in w.base.tail(), what="the cancel to reach the basenode's server")

    def clamp(goal, action):  # the goal changed on its way: the basenode counts to 3 at most
        return action.forward(counting.goal(min(counting.n_of(goal), 3)))

    w.new.action("count", counting.type, clamp)
    assert counting.plain_send("/act_robot/count", 10) == ("succeeded", 3, [1, 2, 3])
    assert "goal 3" in w.base.tail()
    state, reached, _ = counting.plain_send("/act_robot/count", 2)
    assert state == "succeeded" and reached == 2
    w.remove(action="count")
    w.reuse.action("count", type=counting.type)  # given back to the basenode
    assert counting.plain_send("/act_robot/count", 5)[:2] == ("succeeded", 5)


def test_discovery_finds_a_basenodes_action(make_node, counting):
    w = make_node("act_discovered")
    w.baseNode(str(counting.server), namespace="act_found")
    interface = w.discover()
    assert interface.actions == [("/act_found/count", counting.type)]
    assert not [name for name, _ in interface.publications + interface.subscriptions + interface.services
                if name.startswith("/act_found/count/")], "an action's parts are one entry, not topics"
    assert [(a.name, a.role, a.type) for a in w.model().actions] == [("count", "reuse", counting.type)]


@pytest.mark.filterwarnings("ignore:ipyros. the saved file needs counting")  # the test's own helper, given at load
@pytest.mark.parametrize("suffix", [".yaml", ".py"])
def test_saving_keeps_served_and_intercepted_actions(make_node, counting, tmp_path, suffix):
    nd = make_node("act_kept")
    nd.baseNode(str(counting.server), namespace="act_kept_robot")
    nd.reuse.action("count", type=counting.type)

    def pass_on(goal, action):
        return action.forward(goal)

    nd.new.action("count", counting.type, pass_on)
    nd.new.action("/act/mine", counting.type, counter(counting))
    path = nd.save(tmp_path / f"kept{suffix}", namespace={"counter": counter})
    declared = [(a.name, a.role, a.type, a.handler) for a in nd.model().actions]
    nd.shutdown()
    again = rosNode.load(path, namespace={"counter": counter, "counting": counting, "time": time}, trust=True)
    try:
        assert [(a.name, a.role, a.type, a.handler) for a in again.model().actions] == declared
    finally:
        again.shutdown()


# -- at the prompt ----------------------------------------------------------------------------
def test_actions_lists_and_action_sends_a_goal_with_its_result(ip, make_node, counting, capsys):
    make_node("act_magic").new.action("/act_magic/count", counting.type, counter(counting)).create()
    wait_for(lambda: ok(ip, "%actions act_magic") and "/act_magic/count" in capsys.readouterr().out, timeout=20,
             interval=0.2, what="%actions to list the action")
    ok(ip, "%actions act_magic")
    listing = capsys.readouterr().out
    assert counting.type in listing and "/act_magic" in listing
    goal = str(counting.goal(3)).replace("'", "")
    ok(ip, f"%action /act_magic/count {goal}")
    out = capsys.readouterr().out
    assert "/act_magic/count: succeeded after" in out
    assert counting.result_yaml(3) in out, out
    assert "no live action /act_magic/nope" in str(error_of(ip, f"%action /act_magic/nope {goal}"))


def test_ctrl_c_cancels_the_goal_and_the_server_sees_it(ip, make_node, counting, capsys):
    cancelled: list[int] = []
    make_node("act_ctrl_c").new.action("/act_ctrl_c/count", counting.type,
                                      counter(counting, cancelled, 0.05)).create()
    wait_for(lambda: "/act_ctrl_c/count" in {a.name for a in _actions(ip)}, timeout=20, what="the action in the graph")
    goal = str(counting.goal(1000)).replace("'", "")
    with ctrl_c_after(2.0):
        ok(ip, f"%action /act_ctrl_c/count {counting.type} {goal}")
    out = capsys.readouterr().out
    assert "Ctrl-C: cancel sent; the server took it" in out, out
    assert "/act_ctrl_c/count: cancelled after" in out and cancelled == [1000]


def test_action_watch_shows_the_goals_others_send(ip, make_node, counting, capsys):
    make_node("act_watched").new.action("/act_watched/count", counting.type, counter(counting, step=0.1)).create()
    wait_for(lambda: "/act_watched/count" in {a.name for a in _actions(ip)}, timeout=20, what="the action in the graph")

    watched = threading.Event()

    def other_client():  # goals until the watch has seen one end: it shows goals from its start on
        while not watched.is_set():
            counting.plain_send("/act_watched/count", 3)

    sender = threading.Thread(target=other_client)
    sender.start()
    try:
        ok(ip, "%action --watch /act_watched/count -n 1")
    finally:
        watched.set()
        sender.join(60)
    out = capsys.readouterr().out
    assert "watching /act_watched/count" in out and "] goal" in out and "] succeeded" in out
    assert "] feedback: " in out


def test_tab_completes_action_names_types_and_the_goal(ip, make_node, counting):
    make_node("act_tab").new.action("/act_tab/count", counting.type, counter(counting)).create()

    def completions(text):
        with provisionalcompleter():
            return [c.text for c in ip.Completer.completions(text, len(text))]

    wait_for(lambda: "/act_tab/count" in completions("%action /act_t"), timeout=20, interval=0.3,
             what="the action's name to complete")
    offered = completions("%action /act_tab/count ")
    assert offered[0] == counting.type and any(text.startswith("{") for text in offered), offered
    assert completions(f"%action /act_tab/count {counting.type} ")[0].startswith("{")


def _actions(ip):
    """The actions the session's graph shows now."""
    return actions_of(current().backend.graph_snapshot())


# -- exported: the same behaviour without ipyros --------------------------------------------------
# The export copies a handler's globals in: literals and helper functions, written for either ROS here.
COUNT_IS_LIST = os.environ.get("IPYROS_ROS") == "2"  # Fibonacci's sequences (ROS 2), actionlib/Test's ints (ROS 1)
GOAL_FIELD, FEEDBACK_FIELD, RESULT_FIELD = ("order", "sequence", "sequence") if COUNT_IS_LIST else \
    ("goal", "feedback", "result")


def as_count(i):
    return list(range(i)) if COUNT_IS_LIST else i


def exported_count(goal, action):
    n = getattr(goal, GOAL_FIELD)
    for i in range(1, n + 1):
        if action.cancelled:
            return {RESULT_FIELD: as_count(i - 1)}
        action.feedback({FEEDBACK_FIELD: as_count(i)})
        time.sleep(0.02)
    return {RESULT_FIELD: as_count(n)}


def exported_clamp(goal, action):
    setattr(goal, GOAL_FIELD, min(getattr(goal, GOAL_FIELD), 3))
    return action.forward(goal)


def test_an_exported_node_serves_relays_and_intercepts_actions_without_ipyros(make_node, counting, tmp_path):
    nd = make_node("act_export")
    nd.baseNode(str(counting.server), namespace="act_exported")
    nd.reuse.action("count", type=counting.type)
    nd.new.action("count", counting.type, exported_clamp)
    nd.new.action("/act_exported/mine", counting.type, exported_count)
    relaying = make_node("act_export_relay")
    relaying.baseNode(str(counting.server), namespace="act_exported_relay")
    relaying.reuse.action("count", type=counting.type)
    scripts = [nd.export(tmp_path / "act_export.py"), relaying.export(tmp_path / "act_export_relay.py")]
    (proc, log), (relay_proc, _) = (run_exported(script, tmp_path) for script in scripts)
    try:
        assert counting.plain_send("/act_exported/mine", 3) == ("succeeded", 3, [1, 2, 3])
        assert counting.plain_send("/act_exported/count", 10) == ("succeeded", 3, [1, 2, 3])
        relayed = counting.plain_send("/act_exported_relay/count", 4)
        if relayed[:2] == ("succeeded", 4) and relayed[2] != [1, 2, 3, 4]:
            # Seen once in a whole ROS 2 run on a loaded machine (never alone, nor beside busy loops): feedback
            # 1 came, 2..4 never. A DDS sample lost on the way is sent again only at the writer's next
            # heartbeat (Fast DDS: 3 s), after the result, and an rclpy client drops feedback that comes
            # after its goal's result. A second goal tells a relay that loses feedback from such a moment.
            relayed = counting.plain_send("/act_exported_relay/count", 4)
        assert relayed == ("succeeded", 4, [1, 2, 3, 4])
    finally:
        stop_exported(proc)
        stop_exported(relay_proc)
    assert "goal 3" in log.read_text()
