"""Black-box discovery of a running basenode's interface, read from a real master."""

from __future__ import annotations

import pytest
from helpers import one_call, use_test_nodes
from rich.console import Console
from ros1_fixtures import free_port, ros1_process, wait_for

from ipyros.core.errors import BaseNodeError, MasterError
from ipyros.core.records import Interface
from ipyros.ipython.display import interface_table, renderable
from ipyros.processes.basenode import BaseProcess
from ipyros.ros1.discovery import discover, wait_for_node
from ipyros.ros1.nodes import find_executable


@pytest.fixture(autouse=True)
def packages_of_the_tests_found(monkeypatch):
    use_test_nodes(monkeypatch)


@pytest.fixture
def launch(ros_master):
    """Start a basenode for the test; all are stopped at its end."""
    procs: list[BaseProcess] = []

    def start(package: str, executable: str, *args: str, **options) -> BaseProcess:
        proc = ros1_process(find_executable(package, executable), args, master_uri=ros_master, **options)
        procs.append(proc)
        return proc.start()

    yield start
    for proc in procs:
        proc.stop()


def render(table) -> str:
    console = Console(record=True, width=140)
    console.print(table)
    return console.export_text()


def test_python_node_in_a_namespace_with_a_remap(ros_master, launch):
    launch("ipyros_test_nodes", "echo_node", node_name="probe", namespace="/robot", remaps={"/robot/in": "/w/in"})
    interface = wait_for_node(ros_master, "/robot/probe")
    assert interface == Interface(
        node="/robot/probe",
        publications=[("/robot/out", "std_msgs/String")],
        subscriptions=[("/robot/crash", "std_msgs/Int32"), ("/w/in", "std_msgs/String")],
        services=[("/robot/probe/reset", "std_srvs/Empty")],
        left_out=["/rosout (publishes)", "/robot/probe/get_loggers (service)",
                  "/robot/probe/set_logger_level (service)"],
    )
    assert discover(ros_master, "/robot/probe") == interface  # once registered, one read gives the same


def test_the_demo_robot_as_the_paper_session_would_discover_it(ros_master, launch):
    launch("ipyros_demo", "turtle_sim")
    launch("ipyros_demo", "move_base")
    # Settled is not complete on a loaded machine (a node may register its last endpoint later): what is
    # checked here is what discovery reads once the node has registered everything.
    sim = wait_for(lambda: (found := wait_for_node(ros_master, "turtle_sim")).subscriptions and found,
                           timeout=30, what="turtle_sim's whole interface")  # a name without namespace is global
    assert sim.publications == [("/turtle1/pose", "geometry_msgs/Pose"), ("/turtle1/speed_exceeded", "std_msgs/Bool")]
    assert sim.subscriptions == [("/turtle1/cmd_vel", "geometry_msgs/Twist")]
    assert sim.services == []
    nav = wait_for(lambda: len((found := wait_for_node(ros_master, "/move_base")).subscriptions) == 2
                           and found.services and found, timeout=30, what="move_base's whole interface")
    assert nav.publications == [("/cmd_vel", "geometry_msgs/Twist")]
    assert nav.subscriptions == [("/move_base_simple/goal", "geometry_msgs/PoseStamped"),
                                 ("/turtle1/pose", "geometry_msgs/Pose")]
    assert nav.services == [("/move_base/clear_goal", "std_srvs/Empty")]

    text = render(interface_table(nav))
    assert "Interface of /move_base" in text
    assert "publishes" in text and "/cmd_vel" in text and "geometry_msgs/Twist" in text
    assert "service" in text and "/move_base/clear_goal" in text and "std_srvs/Empty" in text
    assert "not shown" in text and "/rosout, ~get_loggers, ~set_logger_level" in text and "ROS plumbing" in text
    assert render(renderable(nav)) == text  # an Interface is shown as its table


def test_cpp_relay_subscribes_with_any_type_so_the_type_is_unknown(ros_master, launch):
    launch("topic_tools", "relay", "/relay_in", "/relay_out", node_name="lazy_relay")
    interface = wait_for_node(ros_master, "/lazy_relay")
    # topic_tools relay subscribes as "any type" and advertises its output only at the first message.
    assert interface.subscriptions == [("/relay_in", "")]
    assert interface.publications == []
    assert "unknown" in render(interface_table(interface))


def test_a_node_that_is_not_running_is_reported_with_the_nodes_that_are(ros_master, launch):
    launch("ipyros_test_nodes", "echo_node", node_name="present")
    wait_for_node(ros_master, "/present")
    with pytest.raises(BaseNodeError, match=r"node /absent is not registered .* after 0.3s: start it first "
                                            r"\(registered nodes: .*/present"):
        discover(ros_master, "absent", timeout=0.3)
    with pytest.raises(BaseNodeError, match="after 0.3s"):
        wait_for_node(ros_master, "/absent", timeout=0.3)


def test_no_master_is_a_master_error():
    with pytest.raises(MasterError, match="no ROS master answers at http://127.0.0.1:"):
        discover(f"http://127.0.0.1:{free_port()}/", "/any", timeout=0.2)


def test_an_empty_interface_renders_as_such():
    text = render(interface_table(Interface(node="/quiet")))
    assert "Interface of /quiet" in text and "no topics or services" in text


def test_a_service_whose_server_never_answers_is_listed_without_a_type_and_hangs_nothing(ros_master):
    """A node frozen in a debugger still accepts connections (the kernel does) and never answers: its
    services are listed with their type unknown, after the probe's timeout, instead of discovery hanging."""
    import socket
    import threading

    with socket.create_server(("127.0.0.1", 0)) as frozen:  # listens; nobody ever reads or writes
        port = frozen.getsockname()[1]
        master = one_call(ros_master)
        api = f"http://127.0.0.1:{free_port()}/"
        master.registerService("/frozen", "/frozen/reset", f"rosrpc://127.0.0.1:{port}", api)
        try:
            found: list[Interface] = []
            asking = threading.Thread(target=lambda: found.append(discover(ros_master, "/frozen")), daemon=True)
            asking.start()
            asking.join(20)
            assert found, "discovery hung on a server that never answers"
            assert found[0].services == [("/frozen/reset", "")]
        finally:
            master.unregisterService("/frozen", "/frozen/reset", f"rosrpc://127.0.0.1:{port}")
