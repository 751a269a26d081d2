"""Wrapping a node that a ROS 2 launch file starts (XML, including YAML): the rest runs as the file says.

The launch files are written by each test: /robot7/in → first (prefix from an arg) →
/robot7/mid (a launch remap) → second (from the included YAML file, its "in" remapped to
mid) → /robot7/out. The first is wrapped; the second is the rest, started as children.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers import pid_alive
from ros2_fixtures import wait_for
from std_msgs.msg import String

from ipyros.core import errors
from ipyros.dsl import rosNode
from ipyros.ros2 import launchfile

ECHO_NODE = str(Path(__file__).resolve().parent / "peers" / "echo_node.py")

ROBOT = """<launch>
  <arg name="prefix" default="A:"/>
  <arg name="second" default="true" description="run the second echo"/>
  <group>
    <push-ros-namespace namespace="robot7"/>
    <node exec="{echo}" name="first">
      <param name="prefix" value="$(var prefix)"/>
      <remap from="out" to="mid"/>
    </node>
    <node exec="{echo}" name="never" unless="$(var second)"/>
  </group>
  <include file="$(dirname)/second.launch.yaml" if="$(var second)">
    <arg name="ns" value="robot7"/>
  </include>
</launch>
"""

SECOND = """launch:
- arg: {{name: ns, default: /}}
- node:
    exec: {echo}
    name: second
    namespace: $(var ns)
    remap: [{{from: in, to: mid}}]
    param: [{{name: prefix, value: "B:"}}]
"""


@pytest.fixture
def robot(tmp_path):
    (tmp_path / "second.launch.yaml").write_text(SECOND.format(echo=ECHO_NODE))
    path = tmp_path / "robot.launch.xml"
    path.write_text(ROBOT.format(echo=ECHO_NODE))
    return str(path)


def node_names(node) -> set[str]:
    from ipyros.dsl import engine_of

    graph = engine_of(node).session.process.graph()
    return {ns.rstrip("/") + "/" + name for name, ns in graph.get_node_names_and_namespaces()}


def test_the_file_read_as_launch_reads_it(robot):
    launched = launchfile.read(robot, {"prefix": "W:"})
    first, second = launched.nodes
    assert (first.launch_node, first.namespace, first.remaps, first.params) == \
        ("/robot7/first", "/robot7", {"out": "mid"}, {"prefix": "W:"})
    assert (second.launch_node, second.remaps, second.params) == ("/robot7/second", {"in": "mid"}, {"prefix": "B:"})
    assert [n.launch_node for n in launchfile.read(robot, {"second": False}).nodes] == \
        ["/robot7/first", "/robot7/never"]


def test_wrapping_a_node_of_a_launch_file_runs_the_rest_as_children(make_node, robot, failures):
    out: list[str] = []
    make_node("l2_listener").new.subscribe("/robot7/out", handler=lambda m: out.append(m.data),
                                           msgType=String).create()
    feeder = make_node("l2_feeder").new.publish("/robot7/in", msgType=String).create()

    w = make_node("l2_wrap")
    w.baseLaunch(robot, "first", prefix="W:")
    w.reuse.subscribe("in", type=String).publish("mid", type=String)
    assert w.fullname == "/robot7/l2_wrap"  # in the basenode's namespace, as for baseNode
    w.create()
    rest = w.base.rest
    assert set(rest.processes) == {"/robot7/second"}
    # The arg given here, the launch remap composed with the wrapping, and the included file's node: all as the file says.
    wait_for(lambda: feeder.write("/robot7/in", String(data="x")) or "B:W:x" in out, timeout=30, interval=0.2,
             what="a message through the wrapped node and the rest")
    # Node names travel apart from the data (ros_discovery_info): a message through both nodes does not mean
    # the session has heard both names yet.
    wait_for(lambda: {"/robot7/first", "/robot7/second"} <= node_names(w), timeout=20, what="both nodes' names")
    assert "/robot7/never" not in node_names(w)
    pids = [p.pid for p in rest.processes.values()] + [w.base.pid]
    w.shutdown()
    assert not any(pid_alive(pid) for pid in pids), "the rest is stopped with the wrapping node"
    wait_for(lambda: "/robot7/second" not in node_names(feeder), timeout=20, what="the rest to leave the graph")
    assert failures == []


def test_a_launch_wrapped_node_is_kept_and_brought_back(make_node, robot, tmp_path):
    w = make_node("l2_kept")
    w.baseLaunch(robot, "first", prefix="K:")
    w.reuse.subscribe("in", type=String)
    path = w.save(tmp_path / "kept.yaml")
    loaded = rosNode.load(str(path), {}, trust=True)
    base = loaded.model().base
    assert (base.launch, base.launch_node, base.launch_args, base.params) == \
        (robot, "/robot7/first", {"prefix": "K:"}, {"prefix": "K:"})
    assert "baseLaunch(" in w.save(tmp_path / "kept.py").read_text()


@pytest.mark.parametrize("name, text, message", [
    ("robot.launch.py", "from launch import LaunchDescription\n", "is a Python launch file"),
    ("ros1.launch", '<launch><node pkg="p" type="t" name="n"/></launch>', "ROS 1's spelling: ROS 2 names it exec="),
    ("eval.launch.xml", '<launch><node exec="/x" name="n" if="$(eval \'1 == 1\')"/></launch>',
     "would run code from the launch file"),
    ("needs.launch.xml", '<launch><arg name="robot"/><node exec="/x" name="n"/></launch>',
     "needs the argument 'robot'"),
    ("bad.launch.yaml", "launch: [node: {exec: /x, name: n, if: maybe}]", "if/unless needs true or false"),
    ("other.launch.xml", '<launch><node exec="/x" name="planner"/></launch>', "did you mean /planner?"),
])
def test_bad_launch_input_is_one_line_and_declares_nothing(make_node, tmp_path, name, text, message):
    path = tmp_path / name
    path.write_text(text)
    w = make_node("l2_bad")
    with pytest.raises(errors.BaseNodeError, match=message) as raised:
        w.baseLaunch(str(path), "plan")
    assert "\n" not in str(raised.value)
    assert w.model().base is None


def test_an_arg_the_file_does_not_declare_is_refused_with_the_ones_it_does(make_node, robot):
    with pytest.raises(errors.BaseNodeError, match=r"has no argument 'prefx'; did you mean prefix\? its arguments: "
                                                   r"prefix, second"):
        make_node("l2_arg").baseLaunch(robot, "first", prefx="W:")


def test_a_node_of_the_rest_that_cannot_start_or_ends_is_told(make_node, tmp_path, notices):
    path = tmp_path / "shaky.launch.yaml"
    path.write_text(f"""launch:
- node: {{exec: {ECHO_NODE}, name: steady, namespace: robot8}}
- node: {{pkg: ipyros_demo, exec: no_such_node, name: ghost}}
- node: {{exec: /bin/false, name: quitter}}
""")
    w = make_node("l2_shaky")
    w.baseLaunch(str(path), "steady")
    w.create()
    try:
        assert w.base.not_started == ["/ghost"]
        wait_for(lambda: any("node quitter of " in n and "exited with code 1" in n for n in notices), timeout=20,
                 what="the notice of the quitter")
        assert any("could not start /ghost of " in n and "l2_shaky.base.rest.tail()" in n for n in notices)
        assert any("/ghost: " in line and "no_such_node" in line for line in w.base.rest.tail())
        assert w.base.running  # the wrapped node runs on
    finally:
        w.shutdown()


def test_a_launched_node_without_a_name_is_known_by_the_one_its_code_gives(make_node, tmp_path):
    """As ros2 launch runs it: a <node> without name= is its code's own node (managed_node.py: "managed_talker"),
    found, wrapped and named so, and a sibling without name= runs under its own too."""
    managed = Path(ECHO_NODE).with_name("managed_node.py")
    path = tmp_path / "unnamed.launch.xml"
    path.write_text(f'<launch><node exec="{managed}" namespace="unnamed"/>'
                    f'<node exec="{managed}" namespace="unnamed_sibling"/></launch>')
    assert [(n.launch_node, n.own_name) for n in launchfile.read(str(path)).nodes] == [
        ("/unnamed/managed_talker", "managed_talker"), ("/unnamed_sibling/managed_talker", "managed_talker")]
    w = make_node("unnamed_wrap").baseLaunch(str(path), "/unnamed/managed_talker")
    w.reuse.publish("ticks", type=String)
    w.create()
    assert w.basenode_name == "/unnamed/managed_talker"
    wait_for(lambda: {"/unnamed/managed_talker", "/unnamed_sibling/managed_talker"} <= node_names(w), timeout=30,
             what="the wrapped node and its sibling, each under its code's name")
