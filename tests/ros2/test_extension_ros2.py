"""%load_ext ipyros on ROS 2: one line naming the ROS, and the DSL at the prompt with its one-line errors."""

from __future__ import annotations

import os

import pytest
from IPython.core.interactiveshell import InteractiveShell
from traitlets.config import Config
from shell import end_shell, error_of


@pytest.fixture
def ip(ros2_session, capsys):
    config = Config()
    config.HistoryManager.hist_file = ":memory:"
    config.InteractiveShell.colors = "nocolor"
    InteractiveShell.clear_instance()
    shell = InteractiveShell.instance(config=config)
    yield shell
    if "ipyros" in shell.extension_manager.loaded:
        shell.run_line_magic("unload_ext", "ipyros")
    end_shell(shell)
    InteractiveShell.clear_instance()


def test_load_line_names_ros2_and_the_dsl_works_at_the_prompt(ip, capsys):
    ip.run_line_magic("load_ext", "ipyros")
    line = capsys.readouterr().out.strip()
    assert line.startswith("ipyros: ROS 2 Kilted (rclpy 9."), line
    assert f"ROS_DOMAIN_ID {os.environ['ROS_DOMAIN_ID']}, rmw_fastrtps_cpp, discovery localhost" in line
    assert "the DSL, wrapping, %topics, %echo, %pub, %demo and completion run here" in line
    result = ip.run_cell("from std_msgs.msg import String\n"
                         "nd = rosNode('prompt_node', namespace='/r2').new.publish('out', msgType=String).create()\n"
                         "nd.write('out', String(data='a'))")
    assert result.success, result.error_in_exec
    ip.run_cell("%status nd")
    assert "status of /r2/prompt_node" in capsys.readouterr().out
    result = ip.run_cell("nd.timer(0, print)")
    assert not result.success
    shown = capsys.readouterr()
    assert "DeclarationError: timer period must be a number of seconds" in shown.out + shown.err
    assert "Traceback" not in shown.out + shown.err, "one line, no traceback"
    ip.run_cell("nd.shutdown()")


def test_wrap_magic_and_its_completion_from_the_ament_index(ip, capsys, tmp_path, monkeypatch):
    import shutil
    import sys
    from pathlib import Path

    from IPython.core.completer import provisionalcompleter

    prefix = tmp_path / "install"  # a package as colcon installs one
    (prefix / "share" / "ament_index" / "resource_index" / "packages").mkdir(parents=True)
    (prefix / "share" / "ament_index" / "resource_index" / "packages" / "echo_pkg").touch()
    (prefix / "lib" / "echo_pkg").mkdir(parents=True)
    node = prefix / "lib" / "echo_pkg" / "echo_node"
    node.write_text(f"#!{sys.executable}\n" + (Path(__file__).parent / "peers" / "echo_node.py").read_text())
    node.chmod(0o755)
    monkeypatch.setenv("AMENT_PREFIX_PATH", os.pathsep.join([str(prefix), sys.prefix]))

    ip.run_line_magic("load_ext", "ipyros")
    with provisionalcompleter():
        assert [c.text for c in ip.Completer.completions("%wrap echo_p", 12)] == ["echo_pkg"]
        assert [c.text for c in ip.Completer.completions("%wrap echo_pkg ec", 17)] == ["echo_node"]
    capsys.readouterr()
    result = ip.run_cell("%wrap echo_pkg echo_node --ns robot8 --as ew")
    assert result.success, result.error_in_exec
    out = capsys.readouterr().out
    assert "rosNode /robot8/ew (running) wrapping echo_pkg/echo_node" in out and "bound to ew" in out
    assert "/robot8/check" in out and "/robot8/out" in out
    ip.run_cell("ew.shutdown()")
    shutil.rmtree(prefix)


def _completions(ip, line: str) -> list[str]:
    from IPython.core.completer import provisionalcompleter

    with provisionalcompleter():
        return [c.text for c in ip.Completer.completions(line, len(line))]


def test_topics_echo_and_live_completion_read_the_ros2_graph(ip, capsys):
    """%topics, %echo and TAB on live names, from what ROS 2 discovery found (a peer process in the graph)."""
    from ros2_fixtures import Peer, wait_for

    ip.run_line_magic("load_ext", "ipyros")
    capsys.readouterr()
    with Peer("echo.py", "/g2/chatter") as peer:  # a subscriber of /g2/chatter in another process
        peer.wait_line("ready")
        # fresh within a second or so: the peer's topic is offered by TAB without anything else done
        wait_for(lambda: _completions(ip, "%echo /g2/ch") == ["/g2/chatter"], timeout=5, interval=0.1,
                 what="the peer's topic in completion")
        assert "/g2/chatter" in _completions(ip, "nd = rosNode('x'); nd.new.subscribe('/g2/")
        # types in both spellings, from the installed message packages
        assert "geometry_msgs/msg/Twist" in _completions(ip, "%topics --type geometry_msgs/msg/Tw")
        assert "geometry_msgs/Twist" in _completions(ip, "nd.new.publish('/x', 'geometry_msgs/Tw")
        result = ip.run_cell("from std_msgs.msg import String\n"
                             "talker = rosNode('g2_talker', namespace='/g2').new.publish('chatter', type=String).create()\n"
                             "talker.timer(0.05, lambda: talker.write('chatter', String(data='tick')))")
        assert result.success, result.error_in_exec
        wait_for(lambda: any("heard: tick" in x for x in peer.lines), timeout=10, what="the peer to hear the ticks")
        capsys.readouterr()
        ip.run_line_magic("topics", "/g2 --type std_msgs/String")
        out = capsys.readouterr().out
        assert f"1 live topic at ROS_DOMAIN_ID {os.environ['ROS_DOMAIN_ID']}" in out, out
        assert "/g2/chatter" in out and "std_msgs/String" in out and "/msg/" not in out and "/g2/g2_talker" in out and "/echo_peer" in out
        assert "_ipyros_" not in out, "ipyros's hidden nodes stay hidden"
        msgs = ip.run_line_magic("echo", "/g2/chatter -n 2")
        out = capsys.readouterr().out
        assert [m.data for m in msgs] == ["tick", "tick"] and out.count("data: tick") == 2, out
        ip.run_line_magic("echo", "/g2/chatter -n 1 --field data")
        assert "data: tick" in capsys.readouterr().out
        ip.run_cell("talker.shutdown()")
    # %pub: a message built field by field, checked, sent; the echo's YAML goes back into %pub
    ip.run_cell("from geometry_msgs.msg import Twist\nheard = []\n"
                "ear = rosNode('g2_ear').new.subscribe('/g2/cmd', lambda m: heard.append(m), type=Twist).create()")
    line = "%pub /g2/cmd geometry_msgs/msg/Twist "
    template = _completions(ip, line)
    assert template == ["{linear: {x: 0.0, y: 0.0, z: 0.0}, angular: {x: 0.0, y: 0.0, z: 0.0}}"], template
    assert ip.run_cell(line + "{linear: {x: 0.5}, angular: {z: 1.0}}").success
    wait_for(lambda: ip.user_ns["heard"], timeout=10, what="the message %pub sent")
    assert (ip.user_ns["heard"][0].linear.x, ip.user_ns["heard"][0].angular.z) == (0.5, 1.0)
    assert "published a geometry_msgs/" in capsys.readouterr().out
    from ipyros.core.msgbuild import to_yaml
    ip.user_ns["echoed"] = to_yaml(ip.user_ns["heard"][0])
    assert ip.run_cell("%%pub /g2/cmd geometry_msgs/Twist\n" + ip.user_ns["echoed"]).success
    wait_for(lambda: len(ip.user_ns["heard"]) >= 2, timeout=10, what="the echoed message sent back")
    assert ip.user_ns["heard"][1] == ip.user_ns["heard"][0]
    result = ip.run_cell("%pub /g2/cmd geometry_msgs/Twist {linear: {q: 1}}")
    shown = capsys.readouterr()
    assert not result.success and "linear.q: no such field (geometry_msgs/Vector3 has x, y, z)" in shown.out + shown.err
    ip.run_cell("ear.shutdown()")
    # gone within a second or so of the peer's clean exit (a killed one lingers for DDS's lease time)
    wait_for(lambda: "/g2/chatter" not in _completions(ip, "%echo /g2/ch"), timeout=5, interval=0.1,
             what="the topic to leave completion when no node has it")


def _ok(ip, code: str):
    result = ip.run_cell(code)
    assert result.success, result.error_before_exec or result.error_in_exec
    return result.result


def test_handler_try_versions_revert_and_qos_by_endpoint_at_the_ros2_prompt(ip, capsys):
    """The live-editing magics on ROS 2: %handler, %try, %versions, %revert, %status, %topics -v and --hz."""
    from ros2_fixtures import wait_for

    ip.run_line_magic("load_ext", "ipyros")
    _ok(ip, "from std_msgs.msg import String, UInt32\nheard = []\n"
            "def on_number(msg):\n    heard.append(('old', msg.data))\n"
            "nd = rosNode('m2_node', namespace='/m2')\n"
            "nd.new.subscribe('numbers', on_number, msgType=UInt32).publish('latched', String, qos='latched')\n"
            "nd.create()\n"
            "feeder = rosNode('m2_feeder', namespace='/m2').new.publish('numbers', msgType=UInt32).create()\n"
            "count = [0]\n"
            "def feed():\n    count[0] += 1\n    feeder.write('numbers', UInt32(data=count[0]))\n"
            "feeder.timer(0.05, feed)")
    wait_for(lambda: len(ip.user_ns["heard"]) >= 3, timeout=10, what="messages for the old handler")
    capsys.readouterr()
    _ok(ip, "%handler nd /m2/numbers")
    assert ip.rl_next_input == "def on_number(msg):\n    heard.append(('old', msg.data))"
    _ok(ip, ip.rl_next_input.replace("'old'", "'new'"))
    assert "ipyros: m2_node numbers is now handled by the new on_number" in capsys.readouterr().out
    wait_for(lambda: ip.user_ns["heard"][-1][0] == "new", timeout=10, what="the new handler")
    _ok(ip, "%try nd /m2/numbers lambda m: heard.append(('new', m.data))")
    assert "same results on all" in capsys.readouterr().out
    _ok(ip, "%versions nd /m2/numbers")
    out = capsys.readouterr().out
    assert "on_number" in out and "(now)" in out
    _ok(ip, "%revert nd /m2/numbers 1")
    assert "ipyros: m2_node /m2/numbers is handled by version 1 (on_number) again" in capsys.readouterr().out
    wait_for(lambda: ip.user_ns["heard"][-1][0] == "old", timeout=10, what="version 1 again")
    _ok(ip, "nd.params['gain'] = 1.5")
    _ok(ip, "%status nd")
    out = capsys.readouterr().out
    assert "topic" in out and "~gain" in out and "1.5" in out, out
    _ok(ip, "%topics /m2/ -v")
    out = capsys.readouterr().out
    assert "/m2/latched" in out and "reliable transient-local" in out and "/m2/m2_node" in out, out
    assert "/m2/m2_feeder" in out and "publisher" in out and "subscription" in out
    _ok(ip, "%config RosMagics.hz_window = 1.0")
    _ok(ip, "%topics /m2/numbers --hz")
    rate = [row for row in capsys.readouterr().out.splitlines() if "/m2/numbers" in row]
    assert rate and any(17.0 <= float(cell) <= 23.0 for cell in rate[0].replace("│", " ").split()
                        if cell.replace(".", "", 1).isdigit() and "." in cell), rate
    # A transient-local message sent again to the new listener is not a publication: said "latched".
    _ok(ip, "nd.write('latched', String(data='once'))")
    _ok(ip, "%hz /m2/latched /m2/numbers -w 0.6 -n 2")
    out = capsys.readouterr().out
    rows = {cells[0]: cells for line in out.splitlines() if line.startswith("│")
            for cells in [[c.strip() for c in line.strip("│").split("│")]]}
    assert rows.get("/m2/latched", [])[1:3] == ["0 (+1 latched)", "latched"], (out, rows)
    assert 17.0 <= float(rows["/m2/numbers"][2]) <= 23.0, rows
    _ok(ip, "feeder.shutdown(); nd.shutdown()")


def test_record_on_ros2_then_replay_the_bag_through_two_handler_versions(ip, capsys, tmp_path):
    """%record a live topic to a ROS 2 bag (rosbags); baseBag plays it as the basenode; a handler swap and
    base.restart() give the new version's outputs on the same messages, one for one."""
    from ros2_fixtures import wait_for

    ip.run_line_magic("load_ext", "ipyros")
    bag = tmp_path / "counts_bag"
    _ok(ip, "from std_msgs.msg import UInt32\ncount = [0]\n"
            "src = rosNode('b2_source', namespace='/b2').new.publish('counts', msgType=UInt32).create()\n"
            "def tick():\n    count[0] += 1\n    src.write('counts', UInt32(data=count[0]))\n"
            "src.timer(0.02, tick)")
    wait_for(lambda: "/b2/counts" in _completions(ip, "%topics /b2/c"), timeout=10, what="the topic in the graph")
    capsys.readouterr()
    _ok(ip, f"rec = %record {bag} /b2/counts --duration 1")
    assert f"to {bag} (mcap) for 1 s" in capsys.readouterr().out  # rosbag2's own default storage
    wait_for(lambda: not ip.user_ns["rec"].running, timeout=10, what="the recording to end")
    _ok(ip, f"rec_sqlite = %record {tmp_path / 'sqlite_bag'} /b2/counts --duration 0.3 --storage sqlite3")
    wait_for(lambda: not ip.user_ns["rec_sqlite"].running, timeout=10, what="the sqlite3 recording to end")
    _ok(ip, "src.shutdown()")
    recorded = ip.user_ns["rec"].count
    assert recorded >= 25 and (bag / "metadata.yaml").exists() and list(bag.glob("*.mcap"))
    from mcap.reader import make_reader  # read back by MCAP's own reader too, not only by rosbags

    with next(bag.glob("*.mcap")).open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert [c.topic for c in summary.channels.values()] == ["/b2/counts"]
    assert summary.statistics.message_count == recorded
    assert [c.message_encoding for c in summary.channels.values()] == ["cdr"]
    assert list((tmp_path / "sqlite_bag").glob("*.db3"))
    capsys.readouterr()
    _ok(ip, f"%bag info {bag}")  # shown once, as the cell's result
    _ok(ip, f"info = %bag info {bag}")
    info, shown = ip.user_ns["info"], capsys.readouterr().out
    assert shown.count("/b2/counts") == 1 and "BagInfo(" not in shown, shown
    assert (info.storage, [(r.topic, r.type, r.count) for r in info.rows]) == \
        ("mcap", [("/b2/counts", "std_msgs/msg/UInt32", recorded)])
    assert 0.5 < info.duration < 1.5 and "/b2/counts" in shown and f"{recorded} messages" in shown
    _ok(ip, f"info = %bag info {tmp_path / 'sqlite_bag'}")
    assert ip.user_ns["info"].storage == "sqlite3" and ip.user_ns["info"].rows[0].count == ip.user_ns["rec_sqlite"].count

    _ok(ip, "outs = []\n"
            "def double(msg):\n    w.write('/b2/out', UInt32(data=msg.data * 2))\n"
            "ear = rosNode('b2_ear').new.subscribe('/b2/out', lambda m: outs.append(m.data), msgType=UInt32).create()\n"
            "w = rosNode('b2_wrapper')\n"
            f"w.baseBag({str(bag)!r}, rate=2.0)\n"
            "w.reuse.publish('/b2/counts', type=UInt32)\n"
            "w.new.subscribe('/b2/counts', double, msgType=UInt32).publish('/b2/out', msgType=UInt32)\n"
            "w.create()")
    outs = ip.user_ns["outs"]
    wait_for(lambda: len(outs) >= recorded, timeout=20, what="the whole bag through the handler")
    inputs = [x // 2 for x in outs]
    assert len(outs) == recorded and inputs == list(range(inputs[0], inputs[0] + recorded)), "in order, none lost"
    _ok(ip, "def triple(msg):\n    w.write('/b2/out', UInt32(data=msg.data * 3))\n"
            "w.new.subscribe('/b2/counts', triple, msgType=UInt32)\nouts.clear()\nw.base.restart()")
    wait_for(lambda: len(outs) >= recorded, timeout=20, what="the bag again through the new handler")
    assert list(outs) == [3 * x for x in inputs]
    capsys.readouterr()
    _ok(ip, "%status")  # the basenode is the bag, by name (not ipyros's player script)
    assert "bag " in capsys.readouterr().out
    _ok(ip, f"w.save({str(tmp_path / 'w.py')!r})")
    assert f"w.baseBag({str(bag)!r}, rate=2.0, loop=False, delay=5.0)" in (tmp_path / "w.py").read_text()
    _ok(ip, "w.shutdown()")
    # A bare .mcap file (as other tools write them) plays too.
    bare = next(bag.glob("*.mcap"))
    _ok(ip, f"outs.clear()\nw2 = rosNode('b2_bare').baseBag({str(bare)!r}, rate=4.0)\n"
            "w2.reuse.publish('/b2/counts', type=UInt32)\n"
            "w2.new.subscribe('/b2/counts', lambda m: w2.write('/b2/out', m), msgType=UInt32)"
            ".publish('/b2/out', msgType=UInt32)\nw2.create()")
    wait_for(lambda: len(outs) >= recorded, timeout=20, what="the bare .mcap file through the handler")
    assert list(outs) == inputs
    _ok(ip, "w2.shutdown(); ear.shutdown()")


def test_a_ros1_bag_plays_on_ros2_through_a_handler(make_node, tmp_path):
    """A bag recorded on ROS 1 (a .bag file) is played on ROS 2: its messages become ROS 2 messages."""
    from ros2_fixtures import wait_for
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore
    from std_msgs.msg import UInt32

    store = get_typestore(Stores.ROS2_JAZZY)
    bag = tmp_path / "from_ros1.bag"
    with Writer(bag) as writer:  # as rosbag record on ROS 1 writes it: ROS 1 serialization, its msgdef and md5
        msgdef, md5 = store.generate_msgdef("std_msgs/msg/UInt32", ros_version=1)
        connection = writer.add_connection("/r1/counts", "std_msgs/msg/UInt32", msgdef=msgdef, md5sum=md5)
        Msg = store.types["std_msgs/msg/UInt32"]
        for i in range(20):
            writer.write(connection, 1_000_000_000 + i * 20_000_000, store.serialize_ros1(Msg(data=i), Msg.__msgtype__))
    heard: list[int] = []
    w = make_node("r1_replay")
    w.baseBag(str(bag), rate=2.0)
    w.reuse.publish("/r1/counts", type=UInt32)
    w.new.subscribe("/r1/counts", lambda m: heard.append(m.data), type=UInt32)
    w.create()
    wait_for(lambda: len(heard) >= 20, timeout=20, what="the ROS 1 bag's messages through the handler")
    assert heard == list(range(20))


def test_services_call_params_and_nodes_at_the_ros2_prompt(ip, capsys):
    """%services, %call, %params, %param, %nodes and %node on ROS 2: a python basenode's service and
    parameters, read and set through its parameter services."""
    from ros2_fixtures import Peer, wait_for

    ip.run_line_magic("load_ext", "ipyros")
    with Peer("echo_node.py", "--ros-args", "-r", "__ns:=/mi2", "-p", "prefix:=P>") as peer:
        peer.wait_line("echo_node ready")
        graph = __import__("ipyros.ipython.extension", fromlist=["_loaded"])._loaded[id(ip)].graph
        wait_for(lambda: "/mi2/check" in graph.refresh_now().services, what="/mi2/check discovered")
        capsys.readouterr()
        _ok(ip, "%services /mi2/")
        out = capsys.readouterr().out
        row = next(line for line in out.splitlines() if "/mi2/check" in line)
        assert "std_srvs/SetBool" in row and "/mi2/echo_node" in row, out  # one spelling: pkg/Type
        _ok(ip, "%call /mi2/check {data: true}")
        out = capsys.readouterr().out
        assert "success: true" in out and "P> checked" in out, out
        said = str(error_of(ip, "%call /mi2/check std_srvs/SetBool -t -1 {data: true}"))
        assert said.startswith("-t -1: give the seconds to wait") and "\n" not in said, said
        _ok(ip, "%params /mi2")
        out = capsys.readouterr().out
        assert "/mi2/echo_node/prefix" in out and "P>" in out, out
        assert "use_sim_time" not in out and "start_type_description_service" not in out, "every node has them"
        _ok(ip, "%params /mi2 --all")
        assert "/mi2/echo_node/use_sim_time" in capsys.readouterr().out
        _ok(ip, "%param /mi2/echo_node/prefix Q>")
        _ok(ip, "%param /mi2/echo_node/prefix")
        assert "/mi2/echo_node/prefix: Q>" in capsys.readouterr().out
        _ok(ip, "%param /mi2/echo_node/check_delay 0")  # a double parameter given an integer stays a double
        assert "/mi2/echo_node/check_delay = 0.0" in capsys.readouterr().out
        _ok(ip, "%param /mi2/echo_node/check_delay")
        assert "/mi2/echo_node/check_delay: 0.0" in capsys.readouterr().out
        _ok(ip, "%nodes /mi2")
        assert "/mi2/echo_node" in capsys.readouterr().out
        _ok(ip, "%node /mi2/echo_node")
        out = capsys.readouterr().out
        assert "/mi2/out" in out and "/mi2/in" in out and "/mi2/check" in out, out


def test_lifecycle_shows_and_drives_a_managed_node(ip, capsys):
    """%lifecycle NODE [TRANSITION]: a managed node's state and transitions (ros2 lifecycle get/set), TAB for both."""
    from ros2_fixtures import Peer, wait_for

    ip.run_line_magic("load_ext", "ipyros")
    with Peer("managed_node.py") as peer:
        peer.wait_line("managed_node ready")
        wait_for(lambda: "/managed_talker" in _completions(ip, "%lifecycle /managed"), timeout=20,
                 what="the managed node to complete")
        assert _completions(ip, "%lifecycle /managed_talker con") == ["configure"]
        capsys.readouterr()
        _ok(ip, "%lifecycle /managed_talker")
        assert "/managed_talker: state unconfigured; it offers configure" in capsys.readouterr().out
        _ok(ip, "%lifecycle /managed_talker configure")
        assert "/managed_talker: configure → inactive; it offers" in capsys.readouterr().out
        peer.wait_line("configured")
        _ok(ip, "%lifecycle /managed_talker activate")
        assert "activate → active" in capsys.readouterr().out
        peer.wait_line("activated")
        result = ip.run_cell("%lifecycle /managed_talker configure")
        assert "cannot configure now; it offers" in str(result.error_in_exec)
