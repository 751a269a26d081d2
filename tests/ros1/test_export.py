"""Export as a ROS package: the exported node runs under roslaunch and rosrun, without ipyros, and
passes the same live checks as the ipyros node it was exported from.

Each check (:func:`check_plain`, :func:`check_wrapper`) runs once against the live DSL node, so
that it is known to pass there, and once against the export, started by Debian's ``roslaunch``
(or ``rosrun``) as a subprocess on the test master. The exported processes get a PYTHONPATH
whose ``ipyros`` raises on import: an export that needed ipyros would fail loudly. Every test
uses a namespace of its own, so a parameter left on the server by one cannot pass another's check.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import threading
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterator

import pytest
from geometry_msgs.msg import Pose, Twist
from helpers import pid_alive
from ros1_fixtures import ROS1_PYTHON, master_state, wait_for
from std_msgs.msg import String
from std_srvs.srv import Empty

from ipyros.core.errors import IpyrosError
from ipyros.core.remapping import basenode_remaps
from ipyros.ros1 import params as param_server, services

speed = 2.5  # read by on_pose when called: exported as a literal
plain = wrapper = None  # the nodes the handlers write with: bound to the live node by the builders below


def on_pose(data):
    print(f"pose x={data.position.x}")
    cmd = Twist()
    cmd.linear.x = speed * data.position.x
    plain.write("cmd_vel", cmd)


def plain_alive():
    plain.write("~alive", String("alive"))


def shout(msg):
    print(f"shout {msg.data}")
    wrapper.write("loud", String(msg.data.upper()))


def wrapper_tick(event):
    wrapper.write("~tick", String("tick"))


def plain_node(make_node, namespace: str):
    """A plain node: a handler that prints and writes, a timer, params of three kinds."""
    global plain
    plain = make_node("export_plain", namespace=namespace)
    (plain.new.subscribe("pose", handler=on_pose, msgType=Pose)
              .publish("cmd_vel", msgType=Twist)
              .publish("~alive", msgType=String))
    plain.timer(0.2, plain_alive)
    plain.params["gain"] = 1.5
    plain.params["label"] = "plain"
    plain.params["limits"] = [1, 2]
    return plain


def wrapper_node(make_node, namespace: str):
    """echo_node wrapped: `in` and `out` relayed unchanged, its ~reset relayed; a handler, a timer, params."""
    global wrapper
    wrapper = make_node("export_wrapper", namespace=namespace)
    (wrapper.baseNode("echo_node", args=["--prefix", "echo> "], params={"exit_after": 0})
            .basePackage("ipyros_test_nodes"))
    wrapper.reuse.subscribe("in", type=String).publish("out", type=String).service("~reset", type=Empty)
    wrapper.new.subscribe("chatter", handler=shout, type=String).publish("loud", type=String)
    wrapper.new.publish("~tick", type=String)
    wrapper.timer(0.2, wrapper_tick, name="tick")
    wrapper.params["volume"] = 11
    wrapper.params["mode"] = "loud"
    return wrapper


def world(make_node, namespace: str, publish: dict, listen: dict):
    """A DSL node in this process around the node under test: it publishes the topics of ``publish``
    ({topic: type}) and collects what arrives on those of ``listen`` in ``heard[topic]``."""
    node = make_node("world_" + namespace.strip("/"))
    heard: dict[str, list] = {}
    for topic, type_ in publish.items():
        node.new.publish(topic, msgType=type_)
    for topic, type_ in listen.items():
        node.new.subscribe(topic, handler=heard.setdefault(topic, []).append, msgType=type_)
    return node.create(), heard


# -- the live checks ------------------------------------------------------------------------------

Output = Callable[[], list[str]]  # the lines the node under test (and its basenode) printed so far


def printed(output: Output, text: str) -> Callable[[], bool]:
    return lambda: any(text in line for line in output())


def check_plain(make_node, ns: str, output: Output, gain: float = 1.5) -> None:
    """The plain node in ``ns`` answers a pose with a velocity (and prints), ticks, and has its params."""
    driver, heard = world(make_node, ns, {f"{ns}/pose": Pose},
                          {f"{ns}/cmd_vel": Twist, f"{ns}/export_plain/alive": String})
    velocities, alive = heard[f"{ns}/cmd_vel"], heard[f"{ns}/export_plain/alive"]
    pose = Pose()
    pose.position.x = 2.0
    wait_for(lambda: driver.write(f"{ns}/pose", pose) or velocities, timeout=30,
             what=f"a velocity from on_pose (output: {output()[-5:]})")
    assert velocities[-1].linear.x == 5.0  # speed 2.5 * 2.0
    wait_for(printed(output, "pose x=2.0"), timeout=10, what="on_pose's print")
    wait_for(lambda: alive, timeout=10, what="the timer's message")
    assert alive[-1].data == "alive"
    params = wait_for(lambda: param_server.has_param(f"{ns}/export_plain/label") and
                      param_server.get_param(f"{ns}/export_plain"), timeout=10, what="the node's params")
    assert params == {"gain": gain, "label": "plain", "limits": [1, 2]}


def check_wrapper(make_node, ns: str, output: Output) -> None:
    """The wrapping node in ``ns``: echo_node reached through unchanged relays, the handler, the timer,
    the params of both, the basenode at its own name and its service relayed."""
    driver, heard = world(make_node, ns, {f"{ns}/in": String, f"{ns}/chatter": String},
                          {f"{ns}/out": String, f"{ns}/loud": String, f"{ns}/export_wrapper/tick": String})
    out, loud, tick = heard[f"{ns}/out"], heard[f"{ns}/loud"], heard[f"{ns}/export_wrapper/tick"]
    wait_for(lambda: driver.write(f"{ns}/in", String("hi")) or out, timeout=30,
             what=f"echo_node's answer through the relays (output: {output()[-5:]})")
    assert out[-1].data == "echo> hi"  # in and out relayed unchanged: only echo_node's prefix added
    wait_for(printed(output, "heard hi"), timeout=10, what="echo_node's print")
    wait_for(lambda: driver.write(f"{ns}/chatter", String("hey")) or loud, timeout=20, what="shout's answer")
    assert loud[-1].data == "HEY"
    wait_for(printed(output, "shout hey"), timeout=10, what="shout's print")
    wait_for(lambda: tick, timeout=10, what="the timer's message")

    base = f"{ns}/echo_node"
    assert listed(base), "the basenode runs at its own name"
    assert base in master_state(os.environ["ROS_MASTER_URI"])["sub"][f"{ns}/export_wrapper/base{ns}/in"]
    assert param_server.get_param(f"{ns}/export_wrapper") == {"volume": 11, "mode": "loud"}
    assert param_server.get_param(f"{base}/exit_after") == 0
    service = services.service_proxy(f"{base}/reset", Empty)
    service.wait_for_service(10)
    service()  # answered by echo_node, through the wrapping node's service relay
    wait_for(printed(output, "reset"), timeout=10, what="echo_node to print reset")


def listed(node: str) -> bool:
    """Whether ``rosnode list`` would list ``node``: it has a publication, subscription or service.

    (Not the master's lookupNode, which can keep a name whose registrations are all gone.)
    """
    return any(node in nodes for kind in master_state(os.environ["ROS_MASTER_URI"]).values()
               for nodes in kind.values())


def test_live_nodes_pass_the_checks(make_node, ros_master, capsys):
    """The checks themselves, on the live ipyros nodes: what the exports must match."""
    seen: list[str] = []

    def output(base=None) -> list[str]:
        seen.extend(capsys.readouterr().out.splitlines())
        return seen + (base.tail(50) if base is not None else [])

    plain_node(make_node, "/live_plain").create()
    check_plain(make_node, "/live_plain", output)
    live = wrapper_node(make_node, "/live_wrapper").create()
    check_wrapper(make_node, "/live_wrapper", lambda: output(live.base))


# -- running the export ---------------------------------------------------------------------------

def export_env(packages: Path, no_ipyros: Path) -> dict[str, str]:
    """The environment of roslaunch/rosrun: the exports' parent on ROS_PACKAGE_PATH, ipyros poisoned."""
    return {**os.environ, "PYTHONUNBUFFERED": "1", "PYTHONPATH": str(no_ipyros),
            "ROS_PACKAGE_PATH": os.pathsep.join([str(packages), os.environ["ROS_PACKAGE_PATH"]])}


class Run:
    """A roslaunch or rosrun process in a process group of its own; ``lines`` fills as it prints."""

    STARTED = re.compile(r"process\[(.+?)-\d+\]: started with pid \[(\d+)\]")

    def __init__(self, argv: list[str], env: dict[str, str]) -> None:
        self.proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
                                     start_new_session=True)
        self.lines: list[str] = []
        self._reader = threading.Thread(target=lambda: self.lines.extend(line.rstrip("\n") for line in
                                                                         self.proc.stdout), daemon=True)
        self._reader.start()

    def started(self) -> dict[str, int]:
        """The nodes roslaunch says it started: {process name: pid}."""
        return {m[1]: int(m[2]) for m in map(self.STARTED.search, list(self.lines)) if m}

    def interrupt(self, timeout: float = 30) -> int:
        """Ctrl-C, as a user stops it: SIGINT to its process group; its return code."""
        os.killpg(self.proc.pid, signal.SIGINT)
        return self.proc.wait(timeout)

    def close(self) -> None:
        """After a failure too: the group stopped, and what roslaunch started (in sessions of their own)."""
        if self.proc.poll() is None:
            try:
                self.interrupt()
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
        for pid in self.started().values():
            if pid_alive(pid):
                os.kill(pid, signal.SIGKILL)
        self._reader.join(5)


@contextmanager
def running(argv: list[str], env: dict[str, str]) -> Iterator[Run]:
    run = Run(argv, env)
    try:
        yield run
    finally:
        run.close()


def assert_stops_everything(run: Run, *nodes: str) -> None:
    """SIGINT to roslaunch's group stops it and every node it started; they unregister from the master."""
    pids = run.started()
    assert len(pids) == len(nodes), pids
    assert run.interrupt() == 0, run.lines[-10:]
    for name, pid in pids.items():
        wait_for(lambda pid=pid: not pid_alive(pid), timeout=10, what=f"{name} (pid {pid}) to end")
    for node in nodes:
        assert not listed(node), f"{node} is still registered"


def test_exported_plain_package_runs_under_roslaunch(make_node, tmp_path, ros_master, no_ipyros):
    ns = "/launched_plain"
    package = plain_node(make_node, ns).export(tmp_path / "plain_pkg")
    assert package == tmp_path / "plain_pkg"
    assert sorted(p.relative_to(package).as_posix() for p in package.rglob("*") if p.is_file()) == [
        "CMakeLists.txt", "launch/export_plain.launch", "package.xml", "scripts/export_plain"]
    script = package / "scripts" / "export_plain"
    text = script.read_text()
    assert text.startswith(f"#!{ROS1_PYTHON}\n") and os.access(script, os.X_OK)
    assert "import ipyros" not in text and "from ipyros" not in text
    assert "os.environ.setdefault(\"ROS_NAMESPACE\", '/launched_plain/')" in text
    env = export_env(tmp_path, no_ipyros)
    for python_path, why in ((no_ipyros, "must run without ipyros"), ("", "No module named 'ipyros'")):
        tried = subprocess.run([ROS1_PYTHON, "-c", "import ipyros"], check=False, capture_output=True, text=True,
                               cwd=tmp_path, env={**env, "PYTHONPATH": str(python_path)})
        assert tried.returncode != 0 and why in tried.stderr  # the exported node's interpreter has no ipyros

    with running(["roslaunch", "plain_pkg", "export_plain.launch"], env) as launch:
        check_plain(make_node, ns, lambda: launch.lines)
        assert_stops_everything(launch, f"{ns}/export_plain")


def test_exported_wrapper_package_starts_its_basenode_under_roslaunch(make_node, tmp_path, ros_master, no_ipyros):
    ns = "/launched_wrapper"
    package = wrapper_node(make_node, ns).export(tmp_path / "wrapper_pkg")
    text = (package / "scripts" / "export_wrapper").read_text()
    assert "start_basenode" not in text and "subprocess" not in text  # roslaunch starts the basenode
    assert "roslaunch wrapper_pkg export_wrapper.launch" in text
    with running(["roslaunch", "wrapper_pkg", "export_wrapper.launch"],
                 export_env(tmp_path, no_ipyros)) as launch:
        check_wrapper(make_node, ns, lambda: launch.lines)
        assert sorted(launch.started()) == [f"{ns[1:]}/echo_node", f"{ns[1:]}/export_wrapper"]
        assert_stops_everything(launch, f"{ns}/export_wrapper", f"{ns}/echo_node")
    assert "echo_node shut down" in launch.lines  # stopped by SIGINT, so it unregistered


def test_the_basenode_stops_with_the_exported_node(make_node, tmp_path, ros_master, no_ipyros):
    """As under ipyros, the basenode does not outlive its wrapper: the launch file marks the node required."""
    ns = "/required_wrapper"
    wrapper_node(make_node, ns).export(tmp_path / "required_pkg")
    with running(["roslaunch", "required_pkg", "export_wrapper.launch"], export_env(tmp_path, no_ipyros)) as launch:
        pids = wait_for(lambda: len(launch.started()) == 2 and launch.started(), timeout=30, what="both nodes")
        # Both well into their spin: rospy can deadlock on a SIGINT that lands while it registers.
        wait_for(printed(lambda: launch.lines, "echo_node ready"), timeout=30, what="echo_node to be up")
        driver, heard = world(make_node, ns, {f"{ns}/chatter": String}, {f"{ns}/loud": String})
        wait_for(lambda: driver.write(f"{ns}/chatter", String("hey")) or heard[f"{ns}/loud"], timeout=30,
                 what=f"the wrapper to answer (output: {launch.lines[-5:]})")
        os.kill(pids[f"{ns[1:]}/export_wrapper"], signal.SIGINT)  # the wrapper alone ends
        assert launch.proc.wait(30) == 0, launch.lines[-10:]
        wait_for(lambda: not pid_alive(pids[f"{ns[1:]}/echo_node"]), timeout=10, what="the basenode to end")
    assert not listed(f"{ns}/echo_node")


def test_exported_plain_node_runs_with_rosrun(make_node, tmp_path, ros_master, no_ipyros):
    """rosrun, without the launch file: the script sets its params' defaults, a _param:= given wins."""
    ns = "/rosrun_plain"
    plain_node(make_node, ns).export(tmp_path / "rosrun_pkg")
    with running(["rosrun", "rosrun_pkg", "export_plain", "_gain:=4.0"], export_env(tmp_path, no_ipyros)) as run:
        check_plain(make_node, ns, lambda: run.lines, gain=4.0)
        assert run.interrupt() == 0, run.lines[-10:]
    assert not listed(f"{ns}/export_plain")


# -- the files, read by ROS's own tools ---------------------------------------------------------------

def test_launch_file_loads_with_roslaunch(make_node, tmp_path):
    """roslaunch's own loader reads what ipyros ran: names, namespaces, args, remaps, every kind of param."""
    from roslaunch.config import load_config_default

    node = wrapper_node(make_node, "/loaded")
    odd = {"count": 3, "on": True, "ratio": 0.25, "numeric": "5", "padded": "  x ", "dollar": "$(find nothing)",
           "lines": "a\nb", "mixed": [1, 2.5, "x", False], "nested": {"a": 1, "b": [True]}}
    for key, value in odd.items():
        node.params[key] = value
    node.baseNode("echo_node", params={"~rate": 10, "_label": "it's <b>"})
    package = node.export(tmp_path / "loaded_pkg")
    config = load_config_default([str(package / "launch" / "export_wrapper.launch")], None)
    params = {name: p.value for name, p in config.params.items()}
    expected = {**{k: v for k, v in odd.items() if k != "nested"}, "nested/a": 1, "nested/b": [True],
                "volume": 11, "mode": "loud"}
    assert {k: params[f"/loaded/export_wrapper/{k}"] for k in expected} == expected
    assert params["/loaded/echo_node/rate"] == 10 and params["/loaded/echo_node/label"] == "it's <b>"
    exported, base = config.nodes
    assert (exported.package, exported.type, exported.name, exported.namespace, exported.required) == \
           ("loaded_pkg", "export_wrapper", "export_wrapper", "/loaded/", True)
    assert (base.package, base.type, base.name, base.namespace) == \
           ("ipyros_test_nodes", "echo_node", "echo_node", "/loaded/")
    assert base.args == "--prefix 'echo> '"
    assert [tuple(r) for r in base.remap_args] == list(basenode_remaps(node.model()).items())  # as ipyros runs it


def test_a_basenode_of_a_launch_file_is_exported_as_that_node(make_node, tmp_path):
    """From the BaseModel its launch file gave (roslaunch cannot include a file but one node of it);
    a comment says which file it came from and that the rest of it runs separately."""
    from roslaunch.config import load_config_default

    robot = Path(__file__).resolve().parents[1] / "launch" / "robot.launch"
    node = make_node("planner_export")
    node.baseLaunch(robot, "/robot1/planner")
    node.reuse.subscribe("in", type=String).publish("out", type=String)
    launch = node.export(tmp_path / "planner_pkg") / "launch" / "planner_export.launch"
    text = launch.read_text()
    assert f"It is /robot1/planner of {robot}, as ipyros wrapped it there" in text
    assert "Start the rest of that launch file separately, without this node" in text
    config = load_config_default([str(launch)], None)
    _exported, base = config.nodes
    assert (base.package, base.type, base.name, base.namespace, base.args) == \
           ("ipyros_test_nodes", "echo_node", "planner", "/robot1/", "--prefix 'planned: '")
    assert [tuple(r) for r in base.remap_args] == list(basenode_remaps(node.model()).items())
    assert ["/robot1/out", "/robot1/planner_export/base/robot1/plan"] in base.remap_args  # its own remap, composed
    params = {name: p.value for name, p in config.params.items() if name.startswith("/robot1/planner/")}
    assert params == flat("/robot1/planner", node.model().base.params)


def flat(prefix: str, params: dict) -> dict:
    """Parameters as roslaunch lists them: one per leaf, dicts spread into names."""
    out = {}
    for key, value in params.items():
        out.update(flat(f"{prefix}/{key}", value) if isinstance(value, dict) else {f"{prefix}/{key}": value})
    return out


def test_package_xml_and_catkin_make(make_node, tmp_path):
    """package.xml is valid for catkin_pkg and names what the node needs; catkin_make installs the package."""
    from catkin_pkg.package import parse_package

    workspace = tmp_path / "ws"
    package = wrapper_node(make_node, "/built").export(workspace / "src" / "built_pkg")
    manifest = parse_package(str(package))
    warnings: list[str] = []
    manifest.validate(warnings=warnings)
    assert manifest.name == "built_pkg" and warnings == []
    assert [d.name for d in manifest.exec_depends] == ["ipyros_test_nodes", "rospy", "std_msgs", "std_srvs"]
    # The Python with catkin_pkg: the python3 first on PATH may not be Debian's.
    build = subprocess.run(["catkin_make", "-C", str(workspace), "install", f"-DPYTHON_EXECUTABLE={ROS1_PYTHON}"],
                           check=False, capture_output=True, text=True, timeout=300)
    assert build.returncode == 0, build.stdout[-2000:] + build.stderr[-2000:]
    installed = workspace / "install"
    assert os.access(installed / "lib" / "built_pkg" / "export_wrapper", os.X_OK)
    assert (installed / "share" / "built_pkg" / "launch" / "export_wrapper.launch").is_file()


# -- replacing an export, refusing anything else --------------------------------------------------

def test_an_earlier_export_is_replaced(make_node, tmp_path):
    target = tmp_path / "again_pkg"
    plain_node(make_node, "/again").export(target)
    other = make_node("other_node")
    other.new.publish("/again/x", msgType=String)
    assert other.export(target) == target  # the DSL method, the same export
    files = sorted(p.relative_to(target).as_posix() for p in target.rglob("*") if p.is_file())
    assert files == ["CMakeLists.txt", "launch/other_node.launch", "package.xml", "scripts/other_node"]
    assert "files: CMakeLists.txt launch/other_node.launch scripts/other_node\n" in \
           (target / "package.xml").read_text()


@pytest.mark.parametrize("existing, message", [
    ({"README.md": "mine"}, r"holds files that ipyros did not export \(README\.md\): export to a new or empty"),
    ({"package.xml": "<package/>", "src/a.py": ""}, r"did not export \(package\.xml, src/a\.py\)"),
    (None, r"is an earlier ipyros export, but holds files it did not write \(launch/mine\.launch\)"),
])
def test_a_directory_holding_other_files_is_refused(make_node, tmp_path, existing, message):
    target = tmp_path / "taken_pkg"
    node = plain_node(make_node, "/taken")
    if existing is None:  # an earlier export that someone added a file to
        node.export(target)
        existing = {"launch/mine.launch": "<launch/>"}
    for name, text in existing.items():
        (target / name).parent.mkdir(parents=True, exist_ok=True)
        (target / name).write_text(text)
    before = {p: p.read_bytes() for p in target.rglob("*") if p.is_file()}
    with pytest.raises(IpyrosError, match=message) as error:
        node.export(target)
    assert "\n" not in str(error.value)
    assert {p: p.read_bytes() for p in target.rglob("*") if p.is_file()} == before  # nothing written


@pytest.mark.parametrize("name", ["MyPkg", "my-pkg", "my__pkg", "x", "1pkg", "pkg_"])
def test_an_invalid_package_name_is_refused(make_node, tmp_path, name):
    with pytest.raises(IpyrosError, match=rf"'{re.escape(name)}' is not a valid ROS package name .*: export to a"):
        plain_node(make_node, "/invalid").export(tmp_path / name)
    assert not (tmp_path / name).exists()


def test_a_file_in_the_way_is_refused(make_node, tmp_path):
    (tmp_path / "file_pkg").write_text("mine")
    with pytest.raises(IpyrosError, match=r"file_pkg is a file: export to a directory .* or to a \.py script"):
        plain_node(make_node, "/file").export(tmp_path / "file_pkg")
    assert (tmp_path / "file_pkg").read_text() == "mine"


def test_an_export_removes_only_files_inside_its_own_folder(make_node, tmp_path):
    """A package.xml edited to list ../victim.txt as an earlier export's file does not make export delete it."""
    target = tmp_path / "victim_pkg"
    plain_node(make_node, "/victim").export(target)
    victim = tmp_path / "victim.txt"
    victim.write_text("mine")
    manifest = target / "package.xml"
    manifest.write_text(manifest.read_text().replace("files: ", "files: ../victim.txt /etc/hostname "))
    plain_node(make_node, "/victim2").export(target)
    assert victim.read_text() == "mine"
    assert "../victim.txt" not in manifest.read_text()


def test_package_xml_is_written_by_an_xml_library(make_node, tmp_path):
    """Every name in package.xml is escaped: the file parses, and says what it was given."""
    import xml.etree.ElementTree as ET

    node = plain_node(make_node, "/escaped")
    package = node.export(tmp_path / "escaped_pkg")
    root = ET.parse(package / "package.xml").getroot()
    assert root.tag == "package" and root.findtext("name") == "escaped_pkg"
    assert [e.text for e in root.findall("exec_depend")] == ["geometry_msgs", "rospy", "std_msgs"]
