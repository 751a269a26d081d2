"""Issue 5's whole story in fresh interpreters: build, change, save, stop, restore, revert.

Kernel one builds a wrapping node (echo_node as basenode, its ``in`` relayed, its ``out``
intercepted by a handler, a timer, params), changes the handler twice, saves the session
to a Python file and exits. Kernel two, a fresh interpreter, runs the file with ``%run``;
the same live checks pass (seen from this process through ROS), and reverting to the
first handler version gives the first behaviour.
"""

from __future__ import annotations

from kernels import start_kernel
from ros1_fixtures import master_state, wait_for

NS = "/e2e_keep"

BUILD = f'''
%load_ext ipyros
from std_msgs.msg import String
mark = "*"
def shout(msg):
    nd.write("loud", String("v1 " + msg.data))
def beat():
    nd.write("beat", String("beat " + str(nd.params["volume"])))
nd = rosNode("keeper", namespace="{NS}")
nd.baseNode("echo_node", args=["--prefix", "echo> "]).basePackage("ipyros_test_nodes")
nd.reuse.subscribe("in", type=String).publish("out", type=String)
nd.new.subscribe("out", handler=shout, type=String).publish("loud", type=String).publish("beat", type=String)
nd.timer(0.2, beat)
nd.params["volume"] = 11
nd.create()
'''

V2 = '''
def shout(msg):
    nd.write("loud", String("v2 " + msg.data.upper()))
nd.new.subscribe("out", handler=shout, type=String)
'''

V3 = '''
def decorate(text):
    return mark + text + mark
def shout(msg):
    nd.write("loud", String("v3 " + decorate(msg.data)))
nd.new.subscribe("out", handler=shout, type=String)
'''


def probe(make_node):
    """A node in this process: writes ``in``, collects ``loud`` and ``beat``."""
    from std_msgs.msg import String

    node = make_node("e2e_keep_probe")
    heard: dict[str, list[str]] = {"loud": [], "beat": []}
    node.new.publish(f"{NS}/in", msgType=String)
    for topic in heard:
        node.new.subscribe(f"{NS}/{topic}", handler=lambda m, t=topic: heard[t].append(m.data), msgType=String)
    return node.create(), heard


def answer(node, heard, text: str) -> str:
    """What the wrapper says on ``loud`` to the word ``text`` sent on ``in`` (resent until connections are up)."""
    from std_msgs.msg import String

    def got():
        node.write(f"{NS}/in", String(text))
        return next((h for h in reversed(heard["loud"]) if text in h.lower()), None)

    return wait_for(got, timeout=30, interval=0.2, what=f"an answer to {text!r} on {NS}/loud")


def live_checks(node, heard, ros_master, version: str, text: str) -> None:
    """The checks both interpreters must pass: relay + handler, timer, params, basenode where it was."""
    expected = {"v1": f"v1 echo> {text}", "v2": f"v2 ECHO> {text.upper()}", "v3": f"v3 *echo> {text}*"}[version]
    assert answer(node, heard, text) == expected
    heard["beat"].clear()
    wait_for(lambda: "beat 11" in heard["beat"], timeout=10, what="the timer's beat with the param")
    publishers = master_state(ros_master)["pub"]
    assert f"{NS}/echo_node" in publishers.get(f"{NS}/keeper/base{NS}/out", []), publishers  # remapped basenode


def test_save_stop_restore_in_a_fresh_interpreter_and_revert(ros_master, make_node, tmp_path):
    node, heard = probe(make_node)
    saved = tmp_path / "keeper.py"

    first = start_kernel(ros_master, tmp_path, "first")
    try:
        first.ok(BUILD)
        live_checks(node, heard, ros_master, "v1", "apple")
        first.ok(V2)
        live_checks(node, heard, ros_master, "v2", "plum")
        first.ok(V3)
        live_checks(node, heard, ros_master, "v3", "kiwi")
        cell = first.ok(f"%save_nodes {saved}")
        assert f"saved {NS}/keeper to {saved}" in cell.stdout()
    finally:
        first.shutdown()
    # Everything of the first interpreter is gone: the wrapper and its basenode.
    wait_for(lambda: not any(f"{NS}/" in n for nodes in master_state(ros_master)["pub"].values() for n in nodes),
             timeout=20, what="the first interpreter's nodes to leave the master")

    second = start_kernel(ros_master, tmp_path, "second")
    try:
        second.ok("%load_ext ipyros")
        second.ok(f"%run {saved}")
        live_checks(node, heard, ros_master, "v3", "grape")
        assert second.value("[v.name for v in nd.versions('out')]") == ["shout", "shout", "shout"]
        second.ok("%revert nd out 1")
        live_checks(node, heard, ros_master, "v1", "lemon")
        second.ok("nd.revert('out', 2)")
        live_checks(node, heard, ros_master, "v2", "mango")
    finally:
        second.shutdown()
