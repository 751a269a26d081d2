"""A basenode without ``name=`` keeps the name its own code gives it, as when it runs by hand (issue 24): its
private topics, parameters and services are where its clients look for them. Its source is read, not run."""

from __future__ import annotations

import pytest
from helpers import one_call
from support import wait_for

from ipyros.core.errors import DeclarationError

#: A node whose file is ``odom.py`` and whose node is ``odometry_node``, publishing ``~status`` (``/odometry_node/
#: status``) with its private parameter ``~label`` in it (read each time), written once per ROS as a user writes it.
ODOM = {
    "ROS 1": '''
import rospy
from std_msgs.msg import String

NODE_NAME = "odometry_node"
rospy.init_node(NODE_NAME)
status = rospy.Publisher("~status", String, queue_size=10)
rate = rospy.Rate(10)
while not rospy.is_shutdown():
    status.publish(String(data=f"{rospy.get_name()} {rospy.get_param('~label', 'none')}"))
    rate.sleep()
''',
    "ROS 2": '''
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from std_msgs.msg import String


class Odometry(Node):
    def __init__(self):
        super().__init__("odometry_node")
        self.declare_parameter("label", "none")
        status = self.create_publisher(String, "~/status", 10)
        self.create_timer(0.1, lambda: status.publish(String(
            data=f"{self.get_fully_qualified_name()} {self.get_parameter('label').value}")))


rclpy.init()
try:
    rclpy.spin(Odometry())
except (KeyboardInterrupt, ExternalShutdownException):
    pass
''',
}


def set_from_outside(request, session, name: str, value: str) -> None:
    """Set parameter ``name`` (``/node/key``) as another program does: ROS 1 on the parameter server (as rosparam),
    ROS 2 through the node's own parameter service (as ros2 param set)."""
    if session.backend.name == "ROS 1":
        import os

        code, status, _ = one_call(os.environ["ROS_MASTER_URI"]).setParam("/outsider", name, value)
        assert code == 1, status
        return
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters

    node, _, key = name.rpartition("/")
    parameter = Parameter(name=key, value=ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=value))
    answer = request.getfixturevalue("caller")(f"{node}/set_parameters", SetParameters,
                                               SetParameters.Request(parameters=[parameter]))
    assert answer.results[0].successful, answer


def test_a_basenode_without_a_name_runs_under_the_one_its_code_gives(request, session, make_node, tmp_path):
    script = tmp_path / "odom.py"
    script.write_text(ODOM[session.backend.name])
    heard: list[str] = []
    make_node("odom_listener").new.subscribe("/odom_robot/odometry_node/status", lambda m: heard.append(m.data),
                                             msgType="std_msgs/String").create()
    w = make_node("odom_wrap")
    w.baseNode(str(script), namespace="odom_robot", params={"label": "L1"})
    w.reuse.publish("~status", type="std_msgs/String")
    assert w.model().base.own_name == "odometry_node" and w.model().base.node_name is None
    w.create()
    wait_for(lambda: heard, timeout=30, what="the basenode's private topic, relayed")
    assert heard[-1] == "/odom_robot/odometry_node L1"  # its name, and its private parameter under it
    set_from_outside(request, session, "/odom_robot/odometry_node/label", "L2")  # where its clients look for it
    wait_for(lambda: heard[-1] == "/odom_robot/odometry_node L2", timeout=20, what="the parameter set from outside")
    assert "/odom_robot/odometry_node" in session.backend.graph_snapshot().nodes
    assert "/odom_robot/odom" not in session.backend.graph_snapshot().nodes


def test_an_installed_entry_point_script_is_followed_to_the_module_it_runs(session, make_node, tmp_path, monkeypatch):
    """What colcon and pip install is a script that names nothing (``from pkg.mod import main``): its module is read,
    found on the path and not imported (this package's __init__ would refuse), for the name given there."""
    import textwrap

    package = tmp_path / "site" / "mynodes"
    package.mkdir(parents=True)
    (package / "__init__.py").write_text("raise SystemExit('importing the package is running it')\n")
    body = ODOM[session.backend.name].replace("rospy.init_node(NODE_NAME)", 'rospy.init_node("odometry_node")')
    (package / "odom.py").write_text("def main():\n" + textwrap.indent(body, "    "))
    script = tmp_path / "bin" / "odom"
    script.parent.mkdir()
    script.write_text("#!/usr/bin/env python3\nimport sys\nfrom mynodes.odom import main\n"
                      "if __name__ == '__main__':\n    sys.exit(main())\n")
    script.chmod(0o755)
    monkeypatch.syspath_prepend(str(tmp_path / "site"))
    w = make_node("entry_wrap").baseNode(str(script), namespace="entry_robot")
    assert w.model().base.own_name == "odometry_node"


def test_a_name_given_or_one_the_code_does_not_say_is_used_as_before(session, make_node, tmp_path):
    computed = tmp_path / "computed_name.py"
    computed.write_text(ODOM[session.backend.name].replace('"odometry_node"', '"odometry_" + "node"'))
    assert make_node("odom_computed").baseNode(str(computed)).model().base.own_name is None
    named = make_node("odom_named").baseNode(str(tmp_path / "absent.py"), name="given")
    assert named.model().base.node_name == "given"
    script = tmp_path / "odom.py"
    script.write_text(ODOM[session.backend.name])
    w = make_node("odom_unsaved").baseNode(str(script))
    assert w.model().base.own_name == "odometry_node"
    w.baseNode(str(computed))  # another file: read again
    assert w.model().base.own_name is None


def test_a_wrapping_node_of_its_basenodes_own_name_is_refused_and_starts_nothing(session, make_node, tmp_path):
    script = tmp_path / "odom.py"
    script.write_text(ODOM[session.backend.name])
    same = make_node("odometry_node").baseNode(str(script))  # two nodes of one name: the master would stop one
    with pytest.raises(DeclarationError, match=r"odometry_node and its basenode would both be /odometry_node \(the "
                                               r"name its code gives it\).*rosNode\('odometry_node_wrap'\)"):
        same.create()
    assert not same.created and same.base is None
    assert "/odometry_node" not in session.backend.graph_snapshot().nodes
