"""The basenode: lookup as rosrun does it, and the managed process (log, restart, crash, no orphans).

Basenodes here are real: Debian's C++ topic_tools relay, the Python test node
tests/nodes/ipyros_test_nodes/echo_node, and ipyros's own demo robot.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import pytest
import rosgraph
from helpers import TEST_NODES, pid_alive, use_test_nodes
from peer import Peer
from ros1_fixtures import master_state, ros1_process, wait_for

from ipyros.core.errors import BaseNodeError, NodeStateError
from ipyros.core.model import BaseModel
from ipyros.processes.basenode import BaseProcess, exit_reason, param_value
from ipyros.ros1.nodes import command, find_executable, list_executables, list_packages


@pytest.fixture(autouse=True)
def packages_of_the_tests_found(monkeypatch):
    use_test_nodes(monkeypatch)


def echo_node() -> Path:
    return find_executable("ipyros_test_nodes", "echo_node")


def log_has(proc: BaseProcess, text: str, timeout: float = 20.0) -> str:
    """Wait until a line the process wrote to its log (not ipyros's notes) contains ``text``; return it."""
    def found():
        return next((line for line in proc.tail(200) if text in line and not line.startswith("[ipyros]")), None)

    return wait_for(found, timeout, what=f"{text!r} in the log of {proc.executable.name}: {proc.tail(5)}")


class Exits:
    """An ``on_exit`` callback that records what it is told."""

    def __init__(self) -> None:
        self.calls: list[tuple[BaseProcess, int, list[str]]] = []

    def __call__(self, proc: BaseProcess, returncode: int, last_lines: list[str]) -> None:
        self.calls.append((proc, returncode, last_lines))

    def wait(self, timeout: float = 20.0) -> tuple[BaseProcess, int, list[str]]:
        return wait_for(lambda: self.calls and self.calls[-1], timeout, what="on_exit to be called")


@pytest.fixture
def stopper():
    """Processes to stop at the end of the test, whatever happened."""
    procs: list[BaseProcess] = []
    yield procs.append
    for proc in procs:
        proc.stop()


@pytest.fixture
def forget(ros_master):
    """Parameters a node's ``_name:=value`` arguments set on the run's master, deleted at the end of the test: they
    would outlive it there (a later /move_base would start at the speed given here)."""
    names: list[str] = []
    yield names.append
    master = rosgraph.Master("/pytest", master_uri=ros_master)
    for name in names:
        if master.hasParam(name):
            master.deleteParam(name)


# -- lookup ------------------------------------------------------------------------

def test_debian_executables_are_found_in_their_libexec_dir():
    relay = find_executable("topic_tools", "relay")  # <prefix>/lib/topic_tools/relay, whatever the prefix
    assert relay.parent.name == "topic_tools" and relay.parent.parent.name == "lib" and os.access(relay, os.X_OK)
    assert "topic_tools" in list_packages()
    assert {"relay", "throttle", "mux"} <= set(list_executables("topic_tools"))


def test_packages_on_ros_package_path_and_the_bundled_demo_are_found():
    assert echo_node() == TEST_NODES / "ipyros_test_nodes" / "echo_node"
    assert {"ipyros_test_nodes", "ipyros_demo", "rospy"} <= set(list_packages())
    assert list_executables("ipyros_demo") == ["move_base", "speed_monitor", "turtle_sim"]
    assert list_executables("no_such_package") == []


def test_package_name_comes_from_package_xml_and_new_packages_are_found(tmp_path, monkeypatch):
    monkeypatch.setenv("ROS_PACKAGE_PATH", f"{tmp_path}{os.pathsep}{os.environ['ROS_PACKAGE_PATH']}")
    assert "my_pkg" not in list_packages()  # the index is now cached without it
    pkg = tmp_path / "src" / "my_pkg_source"
    (pkg / "scripts").mkdir(parents=True)
    (pkg / "package.xml").write_text("<package format='2'><name>my_pkg</name></package>")
    script = pkg / "scripts" / "talker"
    script.write_text("#!/bin/sh\n")
    script.chmod(0o755)
    (pkg / "scripts" / "notes").write_text("not executable")
    (pkg / "build").mkdir()
    (pkg / "build" / "talker").write_text("")
    (pkg / "build" / "talker").chmod(0o755)

    assert find_executable("my_pkg", "talker") == script  # found although created after the index was cached
    assert find_executable("my_pkg", "scripts/talker") == script  # a path relative to the package, as rosrun allows
    assert list_executables("my_pkg") == ["talker"]  # not the non-executable file, not the build dir's copy
    with pytest.raises(BaseNodeError, match="no executable 'notes'"):
        find_executable("my_pkg", "notes")


def test_two_executables_with_one_name_must_be_named_by_path(tmp_path, monkeypatch):
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path))
    (tmp_path / "dup" / "a").mkdir(parents=True)
    (tmp_path / "dup" / "b").mkdir()
    (tmp_path / "dup" / "package.xml").write_text("<package><name>dup</name></package>")
    for sub in "ab":
        (tmp_path / "dup" / sub / "run").write_text("#!/bin/sh\n")
        (tmp_path / "dup" / sub / "run").chmod(0o755)
    with pytest.raises(BaseNodeError, match=r"several executables named 'run'.*name one by its path"):
        find_executable("dup", "run")
    assert find_executable("dup", "b/run") == tmp_path / "dup" / "b" / "run"


def test_unknown_package_error_suggests_close_names():
    with pytest.raises(BaseNodeError, match=r"unknown ROS package 'tpic_tools': did you mean topic_tools\?"):
        find_executable("tpic_tools", "relay")
    with pytest.raises(BaseNodeError, match=r"unknown ROS package 'zzzqqq': check the name with `rospack list`"):
        find_executable("zzzqqq", "relay")


def test_unknown_executable_error_suggests_and_lists_the_package_executables():
    with pytest.raises(BaseNodeError) as err:
        find_executable("topic_tools", "rely")
    message = str(err.value)
    assert "package 'topic_tools' has no executable 'rely': did you mean relay?" in message
    assert "its executables: demux, drop, mux" in message and "\n" not in message
    with pytest.raises(BaseNodeError, match="did you mean turtle_sim"):
        find_executable("ipyros_demo", "turtlesim")


def test_a_package_runs_only_its_own_files():
    with pytest.raises(BaseNodeError, match=r"with a package, the executable is a name in it .* not the path '/bin/sh'; "
                                            r"to run a file by its path, give no package: baseNode\('/bin/sh'\)"):
        find_executable("topic_tools", "/bin/sh")
    # A path out of the package, as deep as it needs to be from wherever this clone is (any depth).
    outside = os.path.relpath("/bin/true", TEST_NODES / "ipyros_test_nodes")
    with pytest.raises(BaseNodeError, match=rf"'{re.escape(outside)}' leads out of package 'ipyros_test_nodes'"):
        find_executable("ipyros_test_nodes", outside)


def test_a_basenode_given_by_its_path_runs_as_a_script(tmp_path):
    script = tmp_path / "node.py"
    script.write_text(echo_node().read_text())  # a .py file, not executable: run with this interpreter
    argv = command(BaseModel(executable=str(script), node_name="scripted"))
    assert argv[:2] == [sys.executable, str(script)] and "__name:=scripted" in argv
    assert command(BaseModel(executable=str(echo_node())))[:2] == [sys.executable, str(echo_node())], \
        "an executable Python script for 'a python3' runs on this one, which has rospy, whatever comes first on PATH"
    with pytest.raises(BaseNodeError, match=r"basenode 'echo_node' needs its package: add .basePackage"):
        command(BaseModel(executable="echo_node"))


def test_the_command_line_looks_the_executable_up_and_adds_the_remaps_and_params():
    model = BaseModel(executable="echo_node", package="ipyros_test_nodes", node_name="b", namespace="/ns",
                      remaps={"/ns/x": "/y", "/ns/in": "/w/base/in"}, params={"rate": 2.5, "label": "5"},
                      args=["--prefix", "P"])
    assert command(model) == [sys.executable, str(echo_node()), "--prefix", "P", "__name:=b", "__ns:=/ns", "/ns/x:=/y",
                              "/ns/in:=/w/base/in", "_rate:=2.5", "_label:='5'"]
    with pytest.raises(BaseNodeError, match="no executable 'echo'"):
        command(BaseModel(executable="echo", package="ipyros_test_nodes"))
    with pytest.raises(BaseNodeError, match="not an executable file"):
        command(BaseModel(executable="/nonexistent/node"))


def test_private_params_become_command_line_args_ros_reads_back():
    def param_arg(name, value):
        return command(BaseModel(executable=str(echo_node()), params={name: value}))[-1]

    assert param_arg("rate", 10) == "_rate:=10"
    assert param_arg("~gain", 0.5) == "_gain:=0.5"
    assert param_arg("flag", True) == "_flag:=true"
    assert param_arg("frame", "map") == "_frame:=map"
    assert param_arg("text", "two words") == "_text:=two words"
    assert param_value("007") == "'007'"  # would otherwise be read as the int 7
    assert param_arg("xs", [1, 2]) == "_xs:=[1, 2]"
    assert exit_reason(3) == "exited with code 3" and exit_reason(-9) == "killed by SIGKILL"


# -- the managed process -------------------------------------------------------

def test_python_basenode_output_goes_to_the_log(ros_master, tmp_path, stopper):
    log = tmp_path / "echo.log"
    proc = ros1_process(echo_node(), ["--prefix", ">"], node_name="logged", master_uri=ros_master, log_path=log)
    stopper(proc)
    proc.start()
    assert proc.running and proc.pid and proc.returncode is None
    line = log_has(proc, "echo_node ready")
    assert "/logged" in line and "'--prefix', '>'" in line
    assert proc.tail(200)[0].startswith("[ipyros]") and "starting:" in proc.tail(200)[0]
    assert proc.tail(1) == [line] and proc.tail(0) == []
    with pytest.raises(NodeStateError, match="already running"):
        proc.start()
    assert proc.stop() == 0
    assert "stopped (exited with code 0)" in proc.tail(1)[0]
    assert log.read_text().count("echo_node ready") == 1


def test_debian_relay_runs_remapped_and_restart_keeps_the_remaps(ros_master, stopper):
    remaps = {"/in": "/w/base/in", "/out": "/w/base/out"}
    proc = ros1_process(find_executable("topic_tools", "relay"), ["/in", "/out"], node_name="relay_r",
                       remaps=remaps, master_uri=ros_master)
    stopper(proc)
    master = rosgraph.Master("/test_base", master_uri=ros_master)

    def registered_uri():
        try:
            return master.lookupNode("/relay_r")
        except rosgraph.MasterError:
            return None

    proc.start()
    first_pid, first_uri = proc.pid, wait_for(registered_uri, 20, what="relay_r to register")
    state = wait_for(lambda: (s := master_state(ros_master)) and "/relay_r" in s["sub"].get("/w/base/in", []) and s,
                     20, what="relay_r to subscribe /w/base/in")
    assert "/relay_r" not in state["sub"].get("/in", [])

    proc.restart()
    assert proc.pid != first_pid and not pid_alive(first_pid)
    wait_for(lambda: registered_uri() not in (None, first_uri), 20, what="the restarted relay_r to register")
    state = wait_for(lambda: (s := master_state(ros_master)) and "/relay_r" in s["sub"].get("/w/base/in", []) and s,
                     20, what="restarted relay_r to subscribe /w/base/in")
    assert "/relay_r" not in state["sub"].get("/in", [])
    assert sum("starting:" in line for line in proc.tail(100)) == 2  # one log, both runs


def test_python_basenode_remapped_relays_through_its_internal_names(ros_master, stopper):
    proc = ros1_process(echo_node(), node_name="echo_remap", master_uri=ros_master,
                       remaps={"/in": "/w/base/in", "/out": "/w/base/out"})
    stopper(proc.start())
    log_has(proc, "echo_node ready")
    with Peer("echo_topic.py", "/w/base/out", "std_msgs/String") as echo:
        echo.wait_line("ready")
        with Peer("publish_type.py", "/w/base/in", "std_msgs/String") as pub:
            pub.wait_line("ready")
            log_has(proc, "heard ")  # the latched empty string arrived on the remapped input
            echo.wait_line("echo: ")


def test_crash_after_start_is_reported_with_exit_code_and_last_lines(ros_master, stopper, forget):
    forget("/crasher/exit_after")
    exits = Exits()
    proc = ros1_process(echo_node(), ["--spawn-child"], node_name="crasher", params={"exit_after": 0.5},
                       master_uri=ros_master, on_exit=exits)
    stopper(proc.start())
    child = int(log_has(proc, "child pid").split()[-1])
    reported, returncode, last_lines = exits.wait()
    assert reported is proc and returncode == 3
    assert "crashing with code 3: exit_after 0.5" in last_lines and "last words on stderr" in last_lines
    assert not proc.running and proc.returncode == 3 and proc.pid is None
    wait_for(lambda: not pid_alive(child), 10, what="the crashed basenode's own child to be killed")
    assert proc.stop() == 3  # stopping a crashed basenode signals nothing and says how it ended
    wait_for(lambda: "basenode exited with code 3" in proc.tail(1)[0], 10, what="the exit noted in the log")
    assert "exited with code 3" in repr(proc)


def test_crash_on_command_is_reported(ros_master, stopper):
    exits = Exits()
    proc = ros1_process(echo_node(), node_name="commanded", master_uri=ros_master, on_exit=exits)
    stopper(proc.start())
    log_has(proc, "echo_node ready")
    with Peer("publish_type.py", "/crash", "std_msgs/Int32") as pub:  # a latched Int32 0: "exit with code 0"
        pub.wait_line("ready")
        _, returncode, last_lines = exits.wait()
    assert returncode == 0 and "crashing with code 0: told to" in last_lines  # unasked-for, so reported even if 0


def test_crash_right_at_start_is_reported(ros_master, stopper):
    exits = Exits()
    proc = ros1_process(echo_node(), ["--no-such-option"], master_uri=ros_master, on_exit=exits)
    stopper(proc.start())
    _, returncode, last_lines = exits.wait()
    assert returncode == 2
    assert any("unrecognized arguments: --no-such-option" in line for line in last_lines)


def test_a_file_that_cannot_be_executed_fails_at_start(tmp_path):
    script = tmp_path / "not_a_program"
    script.write_text("no shebang, not executable")
    with pytest.raises(BaseNodeError, match="cannot run basenode .*not_a_program"):
        BaseProcess([script]).start()


def test_stop_ends_the_whole_process_group_and_is_not_reported(ros_master, stopper):
    exits = Exits()
    proc = ros1_process(echo_node(), ["--spawn-child"], node_name="parent", master_uri=ros_master, on_exit=exits)
    stopper(proc.start())
    child = int(log_has(proc, "child pid").split()[-1])
    log_has(proc, "echo_node ready")
    pid = proc.pid
    assert pid_alive(child)
    assert proc.stop() == 0
    assert not pid_alive(pid) and not proc.running
    wait_for(lambda: not pid_alive(child), 10, what="the basenode's own child to be stopped with it")
    assert exits.calls == []
    assert proc.stop() == 0  # stopping again is harmless


def test_stop_escalates_to_sigkill_when_sigint_and_sigterm_are_ignored(stopper):
    proc = BaseProcess(["/bin/sh", "-c", "trap '' INT TERM; echo up; while :; do sleep 0.05; done"])
    stopper(proc.start())
    log_has(proc, "up")
    assert proc.stop(timeout=1.0) == -signal.SIGKILL
    assert "stopped (killed by SIGKILL)" in proc.tail(1)[0]


def test_a_basenode_started_from_a_short_lived_thread_outlives_the_thread(ros_master, stopper):
    # PR_SET_PDEATHSIG fires when the forking *thread* exits: ipyros forks from a launcher thread.
    procs = []
    starter = threading.Thread(target=lambda: procs.append(
        ros1_process(echo_node(), node_name="from_thread", master_uri=ros_master).start()))
    starter.start()
    starter.join()
    proc = procs[0]
    stopper(proc)
    log_has(proc, "echo_node ready")  # long after the starting thread ended
    assert proc.running


def test_restart_is_possible_from_on_exit(ros_master, stopper):
    """The session may restart a crashed basenode from the callback itself (on the watcher thread)."""
    exits = Exits()

    def on_exit(proc, returncode, last_lines):
        exits(proc, returncode, last_lines)
        if len(exits.calls) == 1:  # the restarted run fails the same way: restart once only
            proc.restart()

    proc = ros1_process(echo_node(), ["--bad-arg"], master_uri=ros_master, on_exit=on_exit)
    stopper(proc)
    proc.start()
    wait_for(lambda: len(exits.calls) == 2, 20, what="the restarted run to fail too")
    assert sum("starting:" in line for line in proc.tail(100)) == 2


# -- no orphans when the interpreter ends ----------------------------------------

INTERPRETER = textwrap.dedent("""
    import sys, time
    from ipyros.core.model import BaseModel
    from ipyros.processes.basenode import BaseProcess
    from ipyros.ros1.nodes import command
    node = BaseModel(executable="echo_node", package="ipyros_test_nodes", node_name=sys.argv[1])
    proc = BaseProcess(command(node), node_name=sys.argv[1]).start()
    while not any("echo_node ready" in line for line in proc.tail()):
        time.sleep(0.02)
    print(proc.pid, flush=True)
    if sys.argv[2] == "linger":
        time.sleep(600)
""")


def run_interpreter(ros_master, node_name: str, mode: str) -> tuple[subprocess.Popen, int]:
    """A fresh interpreter that starts a basenode; returns it and the basenode's pid."""
    interp = subprocess.Popen([sys.executable, "-c", INTERPRETER, node_name, mode], stdout=subprocess.PIPE, text=True,
                              env={**os.environ, "ROS_MASTER_URI": ros_master})
    line = interp.stdout.readline()
    assert line.strip().isdigit(), f"interpreter said {line!r}"
    return interp, int(line)


def test_normal_interpreter_exit_stops_the_basenode(ros_master):
    interp, pid = run_interpreter(ros_master, "at_exit", "exit")
    assert interp.wait(30) == 0
    interp.stdout.close()
    assert not pid_alive(pid)  # stopped by the atexit hook before the interpreter was gone


def test_sigkilled_interpreter_takes_the_basenode_with_it(ros_master):
    interp, pid = run_interpreter(ros_master, "killed", "linger")
    assert pid_alive(pid)
    interp.send_signal(signal.SIGKILL)
    interp.wait(10)
    interp.stdout.close()
    wait_for(lambda: not pid_alive(pid), 20, what="the orphaned basenode to die (PR_SET_PDEATHSIG)")


# -- the bundled demo robot --------------------------------------------------------

def test_demo_move_base_drives_turtle_sim_to_a_goal_and_the_speed_guard_trips(ros_master, stopper, forget):
    forget("/turtle_sim/max_speed")
    forget("/move_base/speed")
    sim = ros1_process(find_executable("ipyros_demo", "turtle_sim"), master_uri=ros_master, params={"max_speed": 2.0})
    nav = ros1_process(find_executable("ipyros_demo", "move_base"), master_uri=ros_master,
                       remaps={"/cmd_vel": "/turtle1/cmd_vel"}, params={"speed": 1.5})
    stopper(sim.start())
    stopper(nav.start())
    log_has(sim, "turtle_sim ready")
    log_has(nav, "move_base ready")
    with Peer("echo_topic.py", "/turtle1/pose", "geometry_msgs/Pose") as poses:
        poses.wait_line("position")
        goal = BaseProcess([shutil.which("rostopic"), "pub", "-r", "2", "/move_base_simple/goal",
                            "geometry_msgs/PoseStamped", "{pose: {position: {x: 1.0, y: 1.0}}}"],
                           env={"ROS_MASTER_URI": ros_master})
        stopper(goal.start())
        log_has(nav, "goal reached", timeout=30)
        goal.stop()
        x, y = _last_position(poses.lines)
        assert abs(x - 1.0) < 0.15 and abs(y - 1.0) < 0.15
    with Peer("echo_topic.py", "/turtle1/speed_exceeded", "std_msgs/Bool") as exceeded:
        exceeded.wait_line("data: False")  # latched: known at once
        fast = BaseProcess([shutil.which("rostopic"), "pub", "-r", "5", "/turtle1/cmd_vel", "geometry_msgs/Twist",
                            "{linear: {x: 9.0}}"], env={"ROS_MASTER_URI": ros_master})
        stopper(fast.start())
        exceeded.wait_line("data: True")
        log_has(sim, "above max_speed 2.00 m/s")


def _last_position(lines: list[str]) -> tuple[float, float]:
    words = next(line for line in reversed(lines) if "position" in line).replace(",", " ").split()
    return float(words[words.index("x:") + 1]), float(words[words.index("y:") + 1])
