"""Wrapping real basenodes: the paper's Kobuki session, Debian's C++ relay, a namespace, errors."""

from __future__ import annotations

import os
import subprocess

import pytest
from geometry_msgs.msg import Pose, PoseStamped, Twist
from ros1_fixtures import master_state, wait_for
from std_msgs.msg import String

from ipyros import rosNode
from ipyros.core import errors
from ipyros.dsl import engine_of

speed = 4.5


def listen(make_node, name, topic, type_):
    """A DSL node in this process that collects what arrives on ``topic``."""
    seen: list = []
    make_node(name).new.subscribe(topic, handler=seen.append, msgType=type_).create()
    return seen


def test_the_papers_kobuki_session_as_typed(ros_session, make_node, ros_master):
    global speed
    # move_base's private params may be left on the parameter server by other tests: its default speed is 1.0.
    from helpers import one_call

    master = one_call(ros_master)
    if master.hasParam("/pytest", "/move_base")[2]:
        master.deleteParam("/pytest", "/move_base")
    # The world around the basenode: a robot pose, a goal, and someone listening to the robot's base.
    world = make_node("kobuki_world")
    world.new.publish("/turtle1/pose", msgType=Pose, latch=True).publish("/move_base_simple/goal", msgType=PoseStamped,
                                                                          latch=True)
    world.create()
    world.write("/turtle1/pose", Pose())
    goal = PoseStamped()
    goal.pose.position.x = 10.0
    velocities = listen(make_node, "kobuki_base", "/mobile_base/commands/velocity", Twist)
    outside_cmd_vel = listen(make_node, "kobuki_cmd_vel_listener", "/cmd_vel", Twist)

    wnode = rosNode("experimental_move_base")
    {
    wnode
       .baseNode("move_base")
       .basePackage("ipyros_demo")
    }
    {
     wnode.reuse
        .publish( topic = "cmd_vel", type = Twist)
        .subscribe(topic = "move_base_simple/goal", type = PoseStamped)
    }

    def relayVelocity(data):  # noqa: N802
        wnode.write( "mobile_base/commands/velocity", data)

    {
    wnode.new
        .subscribe( topic = "cmd_vel", handler = relayVelocity, type = Twist)
        .publish( topic = "mobile_base/commands/velocity", type = Twist)
    }
    wnode.create()
    try:
        world.write("/move_base_simple/goal", goal)  # reaches move_base only through the wrapping node
        wait_for(lambda: len(velocities) > 3, timeout=20, what="move_base's velocities through relayVelocity")
        assert velocities[-1].linear.x == pytest.approx(1.0)  # move_base's own ~speed

        speed = 4.5

        def controlVelocity(data):  # noqa: N802
            global speed
            if data.linear.x > 0:
                data.linear.x = speed
            wnode.write( "mobile_base/commands/velocity", data)

        wnode.new.subscribe( topic = "cmd_vel", handler = controlVelocity, msgType = Twist)
        wait_for(lambda: velocities[-1].linear.x == 4.5, timeout=10, what="the replaced handler")
        speed = 6
        wait_for(lambda: velocities[-1].linear.x == 6, timeout=10, what="the global to take effect")
        assert outside_cmd_vel == [], "cmd_vel is intercepted: the basenode's output must not reach /cmd_vel"

        # What ROS shows: the basenode talks to the wrapping node on internal names.
        state = master_state(ros_master)
        assert state["pub"]["/experimental_move_base/base/cmd_vel"] == ["/move_base"]
        assert state["sub"]["/experimental_move_base/base/move_base_simple/goal"] == ["/move_base"]
        assert "/ipyros_test" in state["pub"]["/mobile_base/commands/velocity"]
        assert "/move_base" not in state["pub"].get("/cmd_vel", [])
    finally:
        wnode.shutdown()
    assert not wnode.base, "shutdown stops the basenode"


def test_wrapping_debians_cpp_relay(make_node, ros_master):
    """topic_tools/relay as the basenode: reuse its input, intercept its output, add a topic, swap live."""
    out_seen = listen(make_node, "cpp_out_listener", "/cpp/out", String)
    shouted = listen(make_node, "cpp_shout_listener", "/cpp/shouted", String)
    feeder = make_node("cpp_feeder").new.publish("/cpp/in", msgType=String).create()

    w = make_node("cpp_wrapper")
    w.baseNode("relay", args=["/cpp/in", "/cpp/out"]).basePackage("topic_tools")
    w.reuse.subscribe("/cpp/in", type=String).publish("/cpp/out", type=String)
    w.create()
    send = lambda text: feeder.write("/cpp/in", String(text))  # noqa: E731
    wait_for(lambda: send("plain") or out_seen, timeout=20, what="relay through the C++ basenode")
    assert {m.data for m in out_seen} == {"plain"}
    # A relayed topic has no handler to edit (%handler, versions): said, with what to declare.
    with pytest.raises(errors.NotDeclaredError, match=r"^cpp_wrapper relays /cpp/in unchanged \(reuse\), with no "
                       r"handler to edit; to handle it, declare one: cpp_wrapper.new.subscribe\('/cpp/in', handler, "
                       r"msgType='std_msgs/String'\)$"):
        w.versions("/cpp/in")

    # Intercept the basenode's output with a handler that writes to a new topic; swap it while traffic flows.
    w.new.publish("/cpp/shouted", msgType=String)
    w.new.subscribe("/cpp/out", handler=lambda m: w.write("/cpp/shouted", String(m.data.upper())), msgType=String)
    wait_for(lambda: send("hello") or any(m.data == "HELLO" for m in shouted), timeout=20, what="intercept")
    out_count = len(out_seen)
    w.new.subscribe("/cpp/out", handler=lambda m: w.write("/cpp/shouted", String(m.data[::-1])), msgType=String)
    wait_for(lambda: send("abc") or any(m.data == "cba" for m in shouted), timeout=20, what="swapped handler")
    assert all(m.data == "plain" for m in out_seen[:out_count]) and len(out_seen) == out_count, \
        "while intercepted, the basenode's output does not reach /cpp/out"

    # Or write the intercepted output back on its own public name, changed: it works with no more declared.
    w.new.subscribe("/cpp/out", handler=lambda m: w.write("/cpp/out", String(m.data + "!")), msgType=String)
    wait_for(lambda: send("back") or any(m.data == "back!" for m in out_seen), timeout=20, what="written back")
    assert not any(m.data == "back" for m in out_seen), "the basenode's own message does not also reach /cpp/out"

    # Give the topic back to the relay: remove the interception.
    w.new.unsubscribe("/cpp/out")
    wait_for(lambda: send("again") or any(m.data == "again" for m in out_seen), timeout=20, what="relay back")


def test_a_python_basenode_in_a_namespace(make_node, ros_master):
    out = listen(make_node, "ns_listener", "/robot1/out", String)
    feeder = make_node("ns_feeder").new.publish("/robot1/in", msgType=String).create()
    w = make_node("ns_wrapper")
    w.baseNode("echo_node", namespace="robot1", args=["--prefix", "echo:"]).basePackage("ipyros_test_nodes")
    w.reuse.subscribe("in", type=String).publish("out", type=String)
    assert [t.resolved for t in w.model().topics] == ["/robot1/in", "/robot1/out"]
    w.create()
    assert w.fullname == "/robot1/ns_wrapper"
    state = master_state(ros_master)
    assert state["sub"]["/robot1/ns_wrapper/base/robot1/in"] == ["/robot1/echo_node"]
    wait_for(lambda: feeder.write("/robot1/in", String("x")) or out, timeout=20, what="echo through the namespace")
    assert out[0].data == "echo:x"


def test_a_script_given_by_its_path_is_wrapped_like_any_basenode(make_node, tmp_path):
    from helpers import TEST_NODES

    script = tmp_path / "my_echo.py"  # a script of the user's, in no package, not executable
    script.write_text((TEST_NODES / "ipyros_test_nodes" / "echo_node").read_text())
    out = listen(make_node, "script_listener", "/scripted/out", String)
    feeder = make_node("script_feeder").new.publish("/scripted/in", msgType=String).create()
    w = make_node("script_wrapper")
    w.baseNode(str(script), namespace="scripted", args=["--prefix", "py:"])
    w.reuse.subscribe("in", type=String).publish("out", type=String)
    w.create()
    assert w.basenode_name == "/scripted/echo_node"  # the name its code gives it, not the file's
    wait_for(lambda: feeder.write("/scripted/in", String("x")) or out, timeout=20, what="echo through the script")
    assert out[0].data == "py:x"
    w.base.restart()
    assert w.base.running


def test_discovery_declares_the_whole_interface(make_node):
    w = make_node("disc_wrapper")
    w.baseNode("echo_node").basePackage("ipyros_test_nodes")
    interface = w.discover()
    declared = {(t.resolved, t.direction, t.type) for t in w.model().topics}
    assert ("/out", "publish", "std_msgs/String") in declared
    assert ("/in", "subscribe", "std_msgs/String") in declared
    assert {(s.resolved, s.type) for s in w.model().services} == {("/echo_node/reset", "std_srvs/Empty")}
    assert all(t.role == "reuse" for t in w.model().topics)
    from ipyros.ipython.display import render_text

    assert "/out" in render_text(interface)
    out = listen(make_node, "disc_listener", "/out", String)
    feeder = make_node("disc_feeder").new.publish("/in", msgType=String).create()
    w.create()
    wait_for(lambda: feeder.write("/in", String("d")) or out, timeout=20, what="discovered relays to work")


def test_service_reuse_and_interception(make_node, ros_master):
    from std_srvs.srv import Empty, EmptyResponse

    w = make_node("srv_wrapper")
    w.baseNode("echo_node").basePackage("ipyros_test_nodes")
    w.reuse.service("~reset", type=Empty)
    w.create()
    wait_for(lambda: "/echo_node/reset" in master_state(ros_master)["srv"], what="the relayed service")
    result = subprocess.run(["rosservice", "call", "/echo_node/reset"], capture_output=True, text=True, timeout=30)
    assert result.returncode == 0, result.stderr
    wait_for(lambda: any("reset" in line for line in w.base.tail()), what="the basenode to serve the call")
    assert master_state(ros_master)["srv"]["/echo_node/reset"] == ["/ipyros_test"]

    calls = []
    w.new.service("~reset", type=Empty, handler=lambda req: calls.append(req) or EmptyResponse())
    subprocess.run(["rosservice", "call", "/echo_node/reset"], capture_output=True, timeout=30, check=True)
    assert len(calls) == 1


def test_wrapping_errors(make_node):
    with pytest.raises(errors.BaseNodeError, match="unknown ROS package 'topic_tool'.*topic_tools"):
        make_node("bad_pkg").baseNode("relay").basePackage("topic_tool").create()
    with pytest.raises(errors.BaseNodeError, match="has no executable 'rely'.*relay"):
        make_node("bad_exe").baseNode("rely").basePackage("topic_tools").create()
    w = make_node("twice")
    w.baseNode("echo_node").basePackage("ipyros_test_nodes")
    w.reuse.publish("out", type=String)
    with pytest.raises(errors.DeclarationError, match="/out is already wrapped as reuse.publish"):
        w.reuse.subscribe("out", type=String)
    with pytest.raises(errors.DeclarationError, match="reuses in but has no basenode"):
        make_node("no_base").reuse.subscribe("in", type=String).create()


def test_a_base_topic_declared_with_the_wrong_type(make_node):
    w = make_node("wrong_type")
    w.baseNode("echo_node", namespace="wt").basePackage("ipyros_test_nodes")
    w.reuse.publish("out", type=Twist)
    with pytest.raises(errors.TopicTypeConflict, match="basenode /wt/echo_node uses /wt/out as std_msgs/String, but "
                                                       "wrong_type declares geometry_msgs/Twist"):
        w.create()
    assert not w.created and w.base is None, "nothing is left running"


def test_wrapping_the_same_basenode_twice(make_node):
    a = make_node("first_wrapper")
    a.baseNode("echo_node").basePackage("ipyros_test_nodes").create()
    b = make_node("second_wrapper")
    b.baseNode("echo_node").basePackage("ipyros_test_nodes")
    with pytest.raises(errors.DeclarationError, match="basenode /echo_node is already wrapped by /first_wrapper"):
        b.create()


def test_what_rostopic_and_rosnode_show(make_node):
    """The README's "What ROS tools show" section, checked with the real command-line tools."""
    w = make_node("shown_wrapper")
    w.baseNode("echo_node", namespace="shown").basePackage("ipyros_test_nodes")
    w.reuse.subscribe("in", type=String).publish("out", type=String)
    w.create()
    # rosnode info types only published topics: give /shown/in a publisher, as a running system has.
    make_node("shown_feeder").new.publish("/shown/in", msgType=String).create()

    def run(*argv: str) -> str:
        result = subprocess.run(argv, capture_output=True, text=True, timeout=30)
        assert result.returncode == 0, result.stderr
        return result.stdout

    topics = run("rostopic", "list").split()
    for name in ("/shown/in", "/shown/out", "/shown/shown_wrapper/base/shown/in", "/shown/shown_wrapper/base/shown/out"):
        assert name in topics
    assert "/shown/echo_node" in run("rosnode", "list").split()

    base = run("rosnode", "info", "/shown/echo_node")
    assert "/shown/shown_wrapper/base/shown/out [std_msgs/String]" in base.split("Subscriptions:")[0]
    assert "/shown/shown_wrapper/base/shown/in [std_msgs/String]" in base.split("Subscriptions:")[1]

    host = run("rosnode", "info", w.ros_name)
    publications, subscriptions = host.split("Subscriptions:")[0], host.split("Subscriptions:")[1].split("Services:")[0]
    assert "/shown/out [std_msgs/String]" in publications
    assert "/shown/shown_wrapper/base/shown/in [std_msgs/String]" in publications
    assert "/shown/in [std_msgs/String]" in subscriptions
    assert "/shown/shown_wrapper/base/shown/out [std_msgs/String]" in subscriptions


def test_a_reuse_relay_keeps_latching(make_node):
    """turtle_sim latches speed_exceeded: a subscriber that comes late still gets it, marked latched."""
    from std_msgs.msg import Bool

    w = make_node("latch_wrapper")
    w.baseNode("turtle_sim", namespace="latch").basePackage("ipyros_demo")
    w.reuse.publish("turtle1/speed_exceeded", type=Bool)
    w.create()
    wait_for(lambda: any(f.topic == "/latch/turtle1/speed_exceeded" and f.messages >= 1 for f in engine_of(w).sent()),
             timeout=20, what="the latched message to pass the relay")
    late = listen(make_node, "latch_late", "/latch/turtle1/speed_exceeded", Bool)
    wait_for(lambda: late, timeout=20, what="the latched message for a late subscriber")
    assert late[0].data is False and late[0]._connection_header["latching"] == "1"


@pytest.mark.parametrize("typed_first", [True, False], ids=["typed-then-relay", "relay-then-typed"])
def test_a_relay_and_a_typed_subscriber_on_one_topic_each_get_what_they_asked_for(make_node, failures,
                                                                                   typed_first):
    """rospy keeps one subscription per topic in a process: a reuse relay (bytes) and a handler
    (a message) on the same topic, in either order, with %echo as a third party, each get theirs."""
    from ipyros.tools.probe import Echo

    topic = f"/share_{int(typed_first)}/in"
    feeder = make_node(f"share_feeder_{int(typed_first)}").new.publish(topic, msgType=String).create()
    relayed = listen(make_node, f"share_out_{int(typed_first)}", f"/share_{int(typed_first)}/out", String)

    def wrap():
        w = make_node(f"share_wrapper_{int(typed_first)}")
        w.baseNode("relay", args=[topic, f"/share_{int(typed_first)}/out"]).basePackage("topic_tools")
        w.reuse.subscribe(topic, type=String)
        w.create()

    typed: list = []
    if not typed_first:
        wrap()
    make_node(f"share_typed_{int(typed_first)}").new.subscribe(
        topic, handler=lambda m: typed.append(m.data), msgType=String).create()
    if typed_first:
        wrap()
    with Echo(topic, "std_msgs/String") as echo:
        wait_for(lambda: feeder.write(topic, String("x")) or (relayed and len(typed) > 1),
                 timeout=20, interval=0.2, what="the message to reach both the relay and the handler")
        echoed = echo.get(timeout=10)
    assert set(typed) == {"x"} and {m.data for m in relayed} == {"x"} and echoed.data == "x"
    assert not failures


def test_a_package_link_that_leads_outside_is_run_and_said(make_node, tmp_path, monkeypatch, notices):
    """rosrun follows a package's links; so does ipyros, saying where one leads when it leaves the package."""
    from helpers import TEST_NODES

    outside = tmp_path / "elsewhere" / "tool"
    outside.parent.mkdir()
    outside.write_text((TEST_NODES / "ipyros_test_nodes" / "echo_node").read_text())
    outside.chmod(0o755)
    package = tmp_path / "pkgs" / "link_pkg"
    (package / "bin").mkdir(parents=True)
    (package / "package.xml").write_text("<package format='2'><name>link_pkg</name></package>")
    (package / "bin" / "linked_tool").symlink_to(outside)
    monkeypatch.setenv("ROS_PACKAGE_PATH", f"{tmp_path / 'pkgs'}{os.pathsep}{os.environ['ROS_PACKAGE_PATH']}")
    nd = make_node("link_wrapper").baseNode("linked_tool").basePackage("link_pkg")
    nd.create()
    assert nd.base.running
    told = [n for n in notices if "link_pkg/linked_tool is a link to" in n]
    assert told and str(outside) in told[0], notices
