"""End to end: ipyros in a Jupyter kernel (ipykernel), driven over the messaging protocol.

What a notebook front end sends and gets back: execute requests (the magics' output as
stream and display_data messages, errors as error replies), complete requests (live
topic names and message types), and the ``set_next_input`` payload by which
``%handler`` puts a handler's source into the next cell.

The kernel is the venv's Python, on the test master (see tests/kernels.py).
"""

from __future__ import annotations

import re

import pytest
from peer import Peer
from ros1_fixtures import master_state, wait_for

TOPIC = "/e2e_kernel/ticks"  # std_msgs/UInt32 0, 1, 2, ... from peers/ticker.py

HANDLER = '''\
ticks = []
def on_tick(msg):
    print("OLD", msg.data)
    ticks.append(("OLD", msg.data))
'''


@pytest.fixture
def ticks(ros_master):
    with Peer("ticker.py", TOPIC, 20) as peer:
        peer.wait_line("ready")
        yield peer


def test_magics_and_completion_through_a_kernel(kernel, ticks, ros_master):
    cell = kernel.ok("%load_ext ipyros")
    assert cell.stdout() == f"ipyros: ROS master {ros_master} (found running)\n"

    # Completion from the live graph (refreshed in the background: ask until it has the topic).
    wait_for(lambda: kernel.complete("%topics /e2e_k") == [TOPIC], timeout=20, what=f"{TOPIC} completed")
    assert "std_msgs/UInt32" in kernel.complete("%topics --type std_msgs/UInt")
    # JupyterLab shows each completion's type in lower case: there it says the kind of name, not a message type.
    assert kernel.complete_typed("%topics /e2e_k") == [(TOPIC, "topic")]

    # %topics shows a table (rich: text and HTML).
    cell = kernel.ok(f"%topics {TOPIC}")
    row = next(line for line in cell.shown().splitlines() if TOPIC in line)
    assert "std_msgs/UInt32" in row and "/ticker_" in row
    assert TOPIC in cell.shown("text/html")

    # A node declared and created in cells; completion inside its DSL calls.
    kernel.ok(HANDLER + "from std_msgs.msg import UInt32\nnd = rosNode('e2e_kernel_node')")
    assert TOPIC in kernel.complete('nd.new.subscribe(topic="/e2e_k')
    assert "std_msgs/UInt32" in kernel.complete(f'nd.new.subscribe(topic="{TOPIC}", msgType="std_msgs/UInt')
    cell = kernel.ok(f'nd.new.subscribe(topic="{TOPIC}", handler=on_tick, msgType=UInt32)\nnd.create()')
    (area,) = cell.outputs("display_data")  # where the node's handlers print: below the cell that created it
    area = area["transient"]["display_id"]
    cell = kernel.ok("nd")
    assert "/e2e_kernel_node" in cell.shown("text/html") and "on_tick" in cell.shown("text/html")

    # Handler prints from ROS threads stay below the creating cell, whichever cell runs now.
    cell = kernel.ok(wait_ticks("OLD", 10))
    assert re.search(r"^OLD \d+$", cell.updated(area), re.MULTILINE) and "OLD" not in cell.stdout(), cell.messages

    # %handler puts the source into the next cell; running the edited source swaps it in.
    cell = kernel.ok(f"%handler nd {TOPIC}")
    assert cell.said() == [f"ipyros: edit on_tick and run it: it replaces the handler of e2e_kernel_node {TOPIC}"]
    source = cell.payload("set_next_input")["text"]
    assert source == HANDLER.split("\n", 1)[1].rstrip("\n")
    cell = kernel.ok(source.replace("OLD", "NEW"))
    assert cell.said() == [f"ipyros: e2e_kernel_node {TOPIC} is now handled by the new on_tick"]
    cell = kernel.ok(wait_ticks("NEW", 10))
    assert re.search(r"^NEW \d+$", cell.updated(area), re.MULTILINE), cell.messages
    # What the handlers saw: OLD up to the swap, NEW after, no message lost.
    seen = kernel.value("[tuple(tick) for tick in ticks]")
    words = [word for word, _ in seen]
    assert words == sorted(words, key=["OLD", "NEW"].index), f"OLD after NEW: {seen}"
    numbers = [number for _, number in seen]
    assert numbers == list(range(numbers[0], numbers[0] + len(numbers))), f"a message lost or repeated: {seen}"

    # %status: per-handler figures of the node, and the session's nodes.
    cell = kernel.ok("%status nd")
    row = next(line for line in cell.shown().splitlines() if TOPIC in line)
    assert "on_tick" in row and "/e2e_kernel_node" in cell.shown()
    cell = kernel.ok("%status")
    assert "/e2e_kernel_node" in cell.shown() and "nd" in cell.shown()

    # Errors come back as error replies: a usage error, and an ipyros error in one line.
    cell = kernel.run("%status ghost")
    assert cell.reply["ename"] == "UsageError" and "no rosNode called 'ghost'" in cell.reply["evalue"]
    cell = kernel.run("%handler nd /e2e_kernel/nothing")
    assert not cell.ok and "has no handler for /e2e_kernel/nothing" in cell.reply["evalue"]
    assert len(cell.reply["traceback"]) == 1, cell.reply["traceback"]

    # Shutting the kernel down takes its ROS node off the master.
    ros_node = kernel.value("import rospy\nrospy.get_name()")
    assert ros_node in (state := master_state(ros_master))["sub"].get(TOPIC, ()), (ros_node, state)
    kernel.shutdown()
    wait_for(lambda: not registered(ros_master, ros_node), timeout=10, what=f"{ros_node} to leave the master")


def test_a_node_shows_once_in_a_notebook(kernel):
    kernel.ok("%load_ext ipyros")
    cell = kernel.ok("nd = rosNode('e2e_kernel_shown')\nnd")
    assert not cell.outputs("display_data"), "showing a node must not display anything besides the result"
    (result,) = cell.outputs("execute_result")
    assert "/e2e_kernel_shown" in result["data"]["text/plain"]
    assert "/e2e_kernel_shown" in result["data"]["text/html"]


def registered(master_uri: str, node: str) -> list[str]:
    """The topics and services ``node`` is registered for on the master."""
    return [name for kind in master_state(master_uri).values() for name, nodes in kind.items() if node in nodes]


def wait_ticks(word: str, count: int) -> str:
    """A cell that waits (20 s at most) until the handler has seen ``count`` more messages marked ``word``
    (at 20 Hz: long enough for the node's output area to be redrawn while the cell runs)."""
    return (f"import time\ndeadline = time.monotonic() + 20\nstart = sum(w == {word!r} for w, _ in ticks)\n"
            f"while sum(w == {word!r} for w, _ in ticks) < start + {count} and time.monotonic() < deadline:\n"
            f"    time.sleep(0.02)\n"
            f"assert sum(w == {word!r} for w, _ in ticks) >= start + {count}, 'too few messages'")


def test_plot_and_record_in_a_kernel_redraw_below_the_cell_and_their_data_stays(kernel, ticks, tmp_path):
    import base64

    kernel.ok("%load_ext ipyros")
    wait_for(lambda: kernel.complete("%topics /e2e_k") == [TOPIC], timeout=20, what=f"{TOPIC} in the graph")
    cell = kernel.ok(f"p = %plot {TOPIC} data --duration 2")
    images = [out["data"]["image/png"] for out in cell.outputs("display_data") if "image/png" in out["data"]]
    assert images and base64.b64decode(images[0])[:8] == b"\x89PNG\r\n\x1a\n", "a figure below the cell"
    assert cell.outputs("display_data")[0].get("transient", {}).get("display_id"), "redrawn in place, by its id"
    # the prompt is free while it records; after the duration it stops by itself, and the data stays
    shown = kernel.ok("p").shown()
    assert "(recording)" in shown and "samples;" not in shown, "no count that is stale the moment it shows"
    cell = kernel.ok("import time\nwhile p.running: time.sleep(0.1)\n"
                     "print('DATA', len(p.data['t']), list(p.data['data']) == sorted(p.data['data']))")
    found = re.search(r"DATA (\d+) (True|False)", cell.stdout())
    assert found and int(found[1]) >= 20 and found[2] == "True", cell.stdout()
    assert f"(stopped): {found[1]} samples;" in kernel.ok("p").shown()
    # %record for a duration: its seconds shown as one line redrawn in place while the prompt is free, gone when
    # the time is up; then how many messages it wrote, said once
    bag = tmp_path / "k.bag"
    kernel.ok("import ipyros.ipython.progress as progress\nprogress.DELAY = 0.0")
    started = kernel.ok(f"rec = %record {bag} {TOPIC} --duration 2")
    ended = kernel.ok("import time\nwhile rec.running: time.sleep(0.1)\ntime.sleep(0.3)")
    lines = [c["data"].get("text/html", "") for cell in (started, ended)
             for c in cell.outputs("display_data", "update_display_data")]
    assert any(f"recording {TOPIC} to k.bag: " in line and " of 2 s" in line for line in lines), lines
    assert lines[-1] == "", "gone when done"
    count = kernel.value("rec.count")
    said = "".join(c["text"] for cell in (started, ended) for c in cell.outputs("stream"))
    assert count >= 15 and said.count(f"ipyros: recorded {count} messages of {TOPIC} to {bag} (its 2 s are up)") == 1, \
        said


def test_echo_until_interrupted_in_a_kernel_is_one_rolling_view(kernel, ticks):
    """%echo without -n in Jupyter: the messages in one area redrawn in place, not a print each (which would run
    into the front end's output limit); interrupting the kernel stops it, as Ctrl-C does in a terminal."""
    import threading

    kernel.ok("%load_ext ipyros")
    interrupt = threading.Timer(3.0, kernel.manager.interrupt_kernel)
    interrupt.start()
    try:
        cell = kernel.run(f"%echo {TOPIC}")
    finally:
        interrupt.cancel()
    (area,) = cell.outputs("display_data")
    shown = cell.updated(area["transient"]["display_id"])
    assert shown.count("data: ") >= 10 and shown.count("---") >= 10, shown
    assert "stopped listening to" in cell.stdout() and "data: " not in cell.stdout(), cell.stdout()
    # %hz redraws one table in place, as an HTML table, report after report.
    cell = kernel.ok(f"%hz {TOPIC} -w 0.5 -n 3")
    (table,) = cell.outputs("display_data")
    updates = [c for c in cell.outputs("update_display_data")
               if c["transient"]["display_id"] == table["transient"]["display_id"]]
    assert len(updates) == 3 and "<table" in updates[-1]["data"]["text/html"] and TOPIC in updates[-1]["data"]["text/html"]


def test_action_feedback_in_a_kernel_is_one_view_updated_in_place(kernel):
    """%action in Jupyter: the goal's feedback in one display redrawn by its id, then how it ended and the result."""
    kernel.ok("%load_ext ipyros")
    kernel.ok("import time\n"
              "def count(goal, action):\n"
              "    for i in range(1, goal.goal + 1):\n"
              "        action.feedback({'feedback': i})\n"
              "        time.sleep(0.1)\n"
              "    return {'result': goal.goal}\n"
              "server = rosNode('e2e_kernel_act').new.action('/e2e_kernel_act/count', 'actionlib/Test', count)"
              ".create()")
    cell = kernel.ok("%action /e2e_kernel_act/count actionlib/Test {goal: 10}")
    (view,) = [out for out in cell.outputs("display_data") if out.get("transient", {}).get("display_id")]
    shown = cell.updated(view["transient"]["display_id"])
    assert "/e2e_kernel_act/count: " in shown and "feedback: {feedback:" in shown, shown
    assert "succeeded after" in cell.stdout(), cell.stdout()
    assert "result: 10" in cell.stdout() + cell.shown(), "the result, as YAML"


def test_pub_widget_in_a_kernel_is_a_form_that_publishes_as_its_slider_moves(kernel, make_node):
    """%pub --widget in Jupyter: a widget view (the form) below the cell; a slider moved publishes its value."""
    from geometry_msgs.msg import Twist

    heard: list = []
    make_node("e2e_wg_ear").new.subscribe("/e2e_wg/cmd", heard.append, msgType=Twist).create()
    kernel.ok("%load_ext ipyros")
    cell = kernel.ok("%pub --widget /e2e_wg/cmd geometry_msgs/Twist")
    views = [c["data"] for c in cell.outputs("display_data", "execute_result")
             if "application/vnd.jupyter.widget-view+json" in c["data"]]
    assert views, cell.messages
    kernel.ok("form = _")
    step = iter(range(1, 1000))
    wait_for(lambda: kernel.ok(f"form.fields['linear.x'].value = {next(step) / 10}") and
             any(m.linear.x > 0 for m in heard), timeout=30, interval=0.3, what="a slider's value at a subscriber")
    x = heard[-1].linear.x
    assert x > 0 and abs(x * 10 - round(x * 10)) < 1e-9 and kernel.value("form.sent") >= 1  # a slider's value
    kernel.ok("form.close()")


def test_try_over_a_bag_with_plot_in_a_kernel_is_a_figure(kernel, tmp_path):
    """%try ... --bag FILE --plot FIELD in Jupyter: both sides' field over bag time, as a figure below the cell."""
    bag = tmp_path / "kt.bag"
    kernel.ok("%load_ext ipyros")
    kernel.ok("from std_msgs.msg import UInt32\nfrom pathlib import Path\nfrom ipyros.tools.record import bag_module\n"
              f"writer = bag_module().BagWriter(Path({str(bag)!r}))\n"
              "for i in range(1, 21):\n    writer.write('/kt/in', UInt32(data=i), stamp=(1000 + i) * 10**9)\n"
              "writer.close()\n"
              "def double(m):\n    kt.write('/kt/out', UInt32(data=m.data * 2))\n"
              "def triple(m):\n    kt.write('/kt/out', UInt32(data=m.data * 3))\n"
              "kt = rosNode('kt')\nkt.new.subscribe('/kt/in', double, msgType=UInt32).publish('/kt/out', msgType=UInt32)")
    cell = kernel.ok(f"r = %try kt /kt/in triple --bag {bag} --plot data")
    pngs = [c["data"]["image/png"] for c in cell.outputs("display_data") if "image/png" in c["data"]]
    assert len(pngs) == 1 and kernel.value("r.differing") == 20
    # the try's progress: one line redrawn in place once the work has run a moment (here at once), gone when done
    kernel.ok("import time, ipyros.ipython.progress as progress\nprogress.DELAY = 0.0\n"
              "def slow(m):\n    time.sleep(0.05)\n    double(m)")
    cell = kernel.ok(f"r = %try kt /kt/in slow --bag {bag}")
    lines = [c["data"].get("text/html", "") for c in cell.outputs("display_data", "update_display_data")]
    assert any("%try /kt/in over kt.bag: " in line and "of 20 messages" in line for line in lines), lines
    assert lines[-1] == "" and kernel.value("r.total") == 20


def test_graph_live_in_a_kernel_is_one_picture_redrawn_as_the_graph_changes(kernel):
    """%graph --live: one SVG below the cell, replaced (not appended) when a node appears, until %graph --stop."""
    kernel.ok("%load_ext ipyros")
    cell = kernel.ok("import ipyros.ipython.magics.drawing as drawing\ndrawing.LIVE_LOOK = 0.2\n%graph /kl* --live")
    (shown,) = [c for c in cell.outputs("display_data") if "image/svg+xml" in c["data"]]
    place = shown["transient"]["display_id"]
    assert "/kl_node" not in shown["data"]["image/svg+xml"]
    cell = kernel.ok("from std_msgs.msg import UInt32\nimport time\nkl = rosNode('kl_node')\n"
                     "kl.new.publish('/kl/out', msgType=UInt32)\nkl.create()\ntime.sleep(3)")
    redrawn = [c for c in cell.outputs("update_display_data") if c["transient"]["display_id"] == place]
    assert any("/kl_node" in c["data"].get("image/svg+xml", "") for c in redrawn), len(redrawn)
    assert not [c for c in cell.outputs("display_data") if "image/svg+xml" in c["data"]], "redrawn, not appended"
    kernel.ok("%graph --stop\nkl.shutdown()")
