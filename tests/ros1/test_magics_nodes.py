"""%handler, %%handler, %try and %status on live nodes, driven through a real shell."""

from __future__ import annotations

import textwrap

import pytest
from IPython.core.error import UsageError
from peer import Peer
from ros1_fixtures import wait_for
from shell import error_of, ok

from ipyros.core.errors import HandlerError, IpyrosError, NotDeclaredError
from ipyros.dsl import engine_of
from ipyros.ipython.extension import _loaded

LISTENER = textwrap.dedent("""\
    from std_msgs.msg import String, UInt32
    heard = []
    def on_number(msg):
        heard.append(('old', msg.data))
    def on_tick():
        heard.append(('tick', None))
    nd = rosNode('mn_node')
    nd.new.subscribe('/mn/numbers', on_number, msgType=UInt32).publish('/mn/out', msgType=String)
    nd.timer(0.05, on_tick)
    nd.create()
    """)


@pytest.fixture
def node_ip(ip):
    """``ip`` with ``nd``: a running node handling /mn/numbers (std_msgs/UInt32) and a timer."""
    ok(ip, LISTENER)
    yield ip
    ok(ip, "nd.shutdown()")


def feed(count: int, topic: str = "/mn/numbers") -> None:
    """Publish 0..count-1 on ``topic`` from a peer process (it waits for our subscription)."""
    with Peer("publish_seq.py", topic, count, 100) as peer:
        peer.wait_line("done")


def test_handler_puts_the_source_in_the_next_input_and_running_it_swaps(node_ip, capsys):
    ip = node_ip
    ok(ip, "%handler nd /mn/numbers")
    assert ip.rl_next_input == "def on_number(msg):\n    heard.append(('old', msg.data))"
    assert "ipyros: edit on_number and run it: it replaces the handler of mn_node /mn/numbers" in \
        capsys.readouterr().out
    ok(ip, "x = 1")  # an unrelated cell: nothing happens
    assert ip.user_ns["nd"].handler("/mn/numbers") is ip.user_ns["on_number"]
    ok(ip, ip.rl_next_input.replace("'old'", "'new'"))
    assert "ipyros: mn_node /mn/numbers is now handled by the new on_number" in capsys.readouterr().out
    assert ip.user_ns["nd"].handler("/mn/numbers") is ip.user_ns["on_number"]
    feed(5)
    wait_for(lambda: len([h for h in ip.user_ns["heard"] if h[0] == "new"]) == 5, what="the new handler")
    assert not [h for h in ip.user_ns["heard"] if h[0] == "old"]
    ok(ip, "def on_number(msg): pass")  # the edit is done: a later redefinition is not swapped in
    assert "now handled" not in capsys.readouterr().out


def test_handler_edits_a_timer_too(node_ip):
    ip = node_ip
    ok(ip, "%handler nd on_tick")
    assert ip.rl_next_input.startswith("def on_tick():")
    ok(ip, "def on_tick():\n    heard.append(('tock', None))")
    ok(ip, "heard.clear()")
    wait_for(lambda: ("tock", None) in ip.user_ns["heard"], what="the new timer handler")
    assert ip.user_ns["nd"].model().timer("on_tick").period == 0.05


def test_handler_edits_a_service_too(node_ip, capsys):
    ip = node_ip
    ok(ip, "from std_srvs.srv import Trigger, TriggerResponse\n"
           "def answer(req):\n    return TriggerResponse(True, 'old')\n"
           "nd.new.service('/mn/ask', 'std_srvs/Trigger', answer)")
    ok(ip, "%handler nd /mn/ask")
    assert ip.rl_next_input.startswith("def answer(req):")
    ok(ip, ip.rl_next_input.replace("'old'", "'new'"))
    assert "mn_node service /mn/ask is now handled by the new answer" in capsys.readouterr().out
    handler = ip.user_ns["nd"].handler("/mn/ask")
    assert handler is ip.user_ns["answer"] and handler(None).message == "new"
    assert ip.user_ns["nd"].model().service("/mn/ask").type == "std_srvs/Trigger"


def test_cell_handler_defines_and_swaps_at_once(node_ip, capsys):
    ip = node_ip
    ok(ip, "%%handler nd /mn/numbers\ndef doubled(msg):\n    heard.append(('doubled', 2 * msg.data))")
    assert "mn_node /mn/numbers is now handled by the new doubled" in capsys.readouterr().out
    feed(3)
    wait_for(lambda: [h for h in ip.user_ns["heard"] if h[0] == "doubled"] == [("doubled", 0), ("doubled", 2),
                                                                              ("doubled", 4)], what="doubled")
    # the swapped-in handler can be edited in turn: its source is known
    ok(ip, "%handler nd /mn/numbers")
    assert ip.rl_next_input.startswith("def doubled(msg):")


def test_cell_handler_errors_leave_the_live_handler(node_ip):
    ip = node_ip
    live = ip.user_ns["on_number"]
    assert "the cell defines no function" in str(error_of(ip, "%%handler nd /mn/numbers\nx = 2"))
    error = error_of(ip, "%%handler nd /mn/numbers\ndef a(m): pass\ndef b(m): pass")
    assert isinstance(error, UsageError) and "defines a, b; which is the handler? name it on_number" in str(error)
    assert isinstance(error_of(ip, "%%handler nd /mn/numbers\ndef on_number(): pass"), HandlerError)
    error = error_of(ip, "%%handler nd /mn/numbers\ndef on_number(msg):\n    return 1/0\nraise ValueError('cell')")
    assert str(error) == "the cell failed, so mn_node /mn/numbers keeps its handler on_number"
    assert ip.user_ns["nd"].handler("/mn/numbers") is live


def test_handler_offers_a_lambda_as_a_def_and_running_it_swaps(node_ip, capsys):
    """A lambda has no name to rebind: %handler offers it as a def of a fresh name (as %versions lists it)."""
    ip = node_ip
    ok(ip, "nd.new.subscribe('/mn/lambda', lambda m: heard.append(('lam', m.data)), msgType=UInt32)\n"
           "nd.timer(0.5, lambda: None)")
    ok(ip, "on_lambda = 'taken'")
    capsys.readouterr()
    ok(ip, "%handler nd /mn/lambda")
    assert ip.rl_next_input == "def on_lambda_2(m):\n    return heard.append(('lam', m.data))"
    assert "is a lambda, here as def on_lambda_2: edit it and run it" in capsys.readouterr().out
    ok(ip, ip.rl_next_input.replace("'lam'", "'def'"))
    assert ip.user_ns["nd"].handler("/mn/lambda") is ip.user_ns["on_lambda_2"]
    feed(2, "/mn/lambda")
    wait_for(lambda: [h for h in ip.user_ns["heard"] if h[0] == "def"] == [("def", 0), ("def", 1)], what="the def")
    ok(ip, "%versions nd <lambda>")  # the timer, named after its lambda, is edited the same way
    ok(ip, "%handler nd <lambda>")
    assert ip.rl_next_input == "def on_timer():\n    return None"


def test_handler_says_when_the_source_cannot_be_found(node_ip):
    ip = node_ip
    ok(ip, "exec('def hidden(msg): pass', globals())\nnd.new.subscribe('/mn/hidden', hidden, msgType=UInt32)")
    error = error_of(ip, "%handler nd /mn/hidden")
    assert "cannot find the source of handler hidden (defined in <string>)" in str(error)
    ok(ip, "nd.new.subscribe('/mn/builtin', print, msgType=UInt32)")
    assert "is builtin_function_or_method 'print', not a function" in str(error_of(ip, "%handler nd /mn/builtin"))


def test_handler_errors_name_the_node_and_topic(node_ip):
    ip = node_ip
    error = error_of(ip, "%handler nobody /mn/numbers")
    assert isinstance(error, UsageError) and "no rosNode called 'nobody'" in str(error) and "nd" in str(error)
    ok(ip, "three = 3")
    assert "three is a int, not a rosNode" in str(error_of(ip, "%handler three /mn/numbers"))
    error = error_of(ip, "%handler nd /mn/unknown")
    assert isinstance(error, NotDeclaredError)
    assert str(error) == ("mn_node has no handler for /mn/unknown; its handlers: /mn/numbers (on_number), "
                          "timer on_tick (on_tick)")
    assert "the following arguments are required: topic" in str(error_of(ip, "%handler nd"))
    ok(ip, "%handler mn_node /mn/numbers")  # the node's name works as well as its variable


def test_try_runs_a_candidate_beside_the_live_handler_without_publishing(node_ip, capsys):
    ip = node_ip
    with Peer("echo_topic.py", "/mn/out", "std_msgs/String") as out_listener:
        out_listener.wait_line("ready")
        ok(ip, "def on_number(msg):\n    print('live', msg.data)\n    nd.write('/mn/out', String(f'live {msg.data}'))\n"
               "nd.new.subscribe('/mn/numbers', on_number, msgType=UInt32)")
        feed(4)
        wait_for(lambda: len([line for line in out_listener.lines if "live" in line]) == 4, what="live writes")
        capsys.readouterr()
        ok(ip, "def candidate(msg):\n    print('cand', msg.data * 10)\n"
               "    nd.write('/mn/out', String(f'cand {msg.data}'))\n    nd.write('/mn/nowhere', msg)")
        ok(ip, "%try nd /mn/numbers candidate")
        out = capsys.readouterr().out
        assert "mn_node /mn/numbers: live on_number vs candidate candidate: 4 of 4 messages give different" in out
        assert out.count(" ≠ ") + out.count(" ≠│") >= 4, "each differing row is marked"
        for i in range(4):
            assert f"live {i}" in out and f"cand {i * 10}" in out
        assert "→ write /mn/out: {data: cand 3}" in out
        assert "→ write /mn/nowhere would fail: mn_node does not publish" in out  # (folded at the column's width)
        ok(ip, "%try -n 2 nd /mn/numbers lambda m: print('lam', m.data)")
        out = capsys.readouterr().out
        assert "lam 2" in out and "lam 3" in out and "lam 1" not in out
        # nothing the tries wrote was published; the live handler still works and still publishes
        feed(1)
        wait_for(lambda: len([line for line in out_listener.lines if "live" in line]) == 5, what="one more live")
        assert not [line for line in out_listener.lines if "cand" in line]
        assert ip.user_ns["nd"].handler("/mn/numbers") is ip.user_ns["on_number"]


def test_try_compares_and_reports_exceptions(node_ip, capsys):
    ip = node_ip
    feed(2)
    wait_for(lambda: len(ip.user_ns["heard"]) >= 2, what="messages")
    capsys.readouterr()
    ok(ip, "%try nd /mn/numbers lambda m: heard.append(('old', m.data))")
    assert "same results on all 2 messages" in capsys.readouterr().out
    ok(ip, "%try nd /mn/numbers lambda m: 1 / m.data")
    out = capsys.readouterr().out
    assert "! ZeroDivisionError: division by zero" in out and "1 of 2 messages give different results" in out
    assert out.count("≠") == 1, "the one differing row is marked, the same one is not"


def test_try_runs_on_messages_as_they_arrived_not_as_the_live_handler_left_them(node_ip, capsys):
    """The paper's controlVelocity changes its message in place: %try must not see the changed one."""
    ip = node_ip
    ok(ip, "def on_number(msg):\n    msg.data += 1000\n    heard.append(('edited', msg.data))\n"
           "nd.new.subscribe('/mn/numbers', on_number, msgType=UInt32)")
    feed(3)
    wait_for(lambda: len([h for h in ip.user_ns["heard"] if h[0] == "edited"]) == 3, what="the live handler")
    capsys.readouterr()
    ok(ip, "%try nd /mn/numbers lambda m: print('saw', m.data)")
    out = capsys.readouterr().out
    assert "saw 0" in out and "saw 2" in out and "saw 1002" not in out
    ok(ip, "%try nd /mn/numbers lambda m: print('saw', m.data)")  # and again: the live run changed nothing kept
    assert "saw 1" in capsys.readouterr().out


def test_try_errors(node_ip):
    ip = node_ip
    error = error_of(ip, "%try nd /mn/numbers on_number")
    assert isinstance(error, IpyrosError) and "nothing to try on: mn_node has received no messages yet" in str(error)
    error = error_of(ip, "%try nd /mn/numbers not_defined_anywhere")
    assert isinstance(error, UsageError) and "name 'not_defined_anywhere' is not defined" in str(error)
    assert "give the candidate handler" in str(error_of(ip, "%try nd /mn/numbers"))
    assert "must take one argument" in str(error_of(ip, "%try nd /mn/numbers on_tick"))
    assert isinstance(error_of(ip, "%try nd /mn/unknown on_number"), NotDeclaredError)


def test_status_shows_the_figures_of_each_handler_and_the_nodes(node_ip, capsys):
    ip = node_ip
    ok(ip, "def on_number(msg):\n    if msg.data == 1:\n        raise ValueError(msg.data)\n"
           "nd.new.subscribe('/mn/numbers', on_number, msgType=UInt32)")
    session = _loaded[id(ip)].session
    previous, session.report = session.report, lambda failure: None
    try:
        feed(3)
        wait_for(lambda: ip.user_ns["nd"].status().row("/mn/numbers").calls == 3, what="3 calls")
    finally:
        session.report = previous
    capsys.readouterr()
    ok(ip, "%status nd")
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if "/mn/numbers" in line).split("│")
    cells = [c.strip() for c in row if c.strip()]
    assert cells[:4] == ["topic", "/mn/numbers", "on_number", "3"] and cells[-1] == "1"
    assert any("on_tick" in line for line in out.splitlines())
    ok(ip, "%pub /mn/out std_msgs/String hi")  # runs ipyros's own publisher node: not one of yours
    ok(ip, "%status")
    out = capsys.readouterr().out
    assert "/mn_node" in out and " nd " in out.replace("│", " ") and "ipyros_pub_" not in out, out
    assert isinstance(error_of(ip, "%status nobody"), UsageError)


def test_try_history_setting_resizes_what_subscriptions_keep(node_ip):
    ip = node_ip
    from ipyros.core.plan import topic_slot

    slot = engine_of(ip.user_ns["nd"]).slot(topic_slot("/mn/numbers"))
    assert slot.recent.maxlen == 20
    ok(ip, "%config RosMagics.try_history = 3")
    assert slot.recent.maxlen == 3
    feed(5)
    wait_for(lambda: len(slot.recent) == 3 and slot.recent_messages()[-1].data == 4, what="the last 3 messages")
    assert [m.data for m in slot.recent_messages()] == [2, 3, 4]
