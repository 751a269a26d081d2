"""%topics, %echo and %pub in a real shell, against the test master and peer processes."""

from __future__ import annotations

import threading

import pytest
from IPython.core.error import UsageError
from peer import Peer
from ros1_fixtures import master_state, wait_for
from shell import ctrl_c_after, error_of, ok

from ipyros.core.errors import MessageTypeError, TopicTypeConflict
from ipyros.dsl import engine_of
from ipyros.ipython.extension import _loaded


@pytest.fixture
def rate_peer():
    """A steady 50 Hz std_msgs/UInt32 source on /mg/rate."""
    with Peer("publish_rate.py", "/mg/rate", 50) as peer:
        peer.wait_line("ready")
        yield peer


def wait_listed(ip, topic):
    wait_for(lambda: topic in _loaded[id(ip)].graph.refresh_now().topics, what=f"{topic} on the master")


def test_topics_lists_live_topics_with_type_publishers_and_subscribers(ip, capsys, rate_peer):
    with Peer("echo_topic.py", "/mg/words", "std_msgs/String") as listener:
        listener.wait_line("ready")
        wait_listed(ip, "/mg/words")
        capsys.readouterr()
        ok(ip, "%topics /mg/")
        out = capsys.readouterr().out
        rows = {line.split()[1]: line for line in out.splitlines() if "/mg/" in line and line.startswith("│")}
        assert set(rows) == {"/mg/rate", "/mg/words"}
        assert "std_msgs/UInt32" in rows["/mg/rate"] and "/publish_rate_" in rows["/mg/rate"]
        assert "std_msgs/String" in rows["/mg/words"] and "/echo_topic_" in rows["/mg/words"]
        ok(ip, "%topics --type std_msgs/String /mg/*")
        out = capsys.readouterr().out
        assert "/mg/words" in out and "/mg/rate" not in out
        ok(ip, "%topics -v /mg/words")  # by endpoint: each node's own type (QoS is ROS 2's: here TCP)
        out = capsys.readouterr().out
        assert "/mg/words" in out and "subscriber" in out and "std_msgs/String" in out and "TCP" in out, out
        publisher = _loaded[id(ip)].graph.snapshot.publishers["/mg/rate"][0]  # this test's peer, not an older one
        ok(ip, f"%topics -n {publisher.lstrip('/')}")
        out = capsys.readouterr().out
        assert "/mg/rate" in out and "/mg/words" not in out


def test_topics_hz_measures_the_rate(ip, capsys, rate_peer):
    wait_listed(ip, "/mg/rate")
    ok(ip, "%config RosMagics.hz_window = 1.0")
    ok(ip, "%topics /mg/rate --hz")
    row = next(line for line in capsys.readouterr().out.splitlines() if "/mg/rate" in line and "│" in line)
    rate = float(row.rstrip(" │").split()[-1])
    assert 40 < rate < 60, row
    assert "/mg/rate" not in master_state(_loaded[id(ip)].graph.where)["sub"], "the listener is gone"


def _rows(out: str, prefix: str = "/mg/") -> dict[str, list[str]]:
    """The rows of the tables in ``out`` by topic, split at the column bars."""
    return {cells[0]: cells for line in out.splitlines() if line.startswith("│") and prefix in line
            for cells in [[c.strip() for c in line.strip("│").split("│")]]}


def test_rates_are_honest_about_latched_and_slow_topics(ip, capsys, rate_peer):
    """Two latched publishers answering a new listener together are not a 2 kHz topic; one message is no rate."""
    with Peer("publish_type.py", "/mg/latched", "std_msgs/String") as first, \
            Peer("publish_type.py", "/mg/latched", "std_msgs/String") as second:
        first.wait_line("ready")
        second.wait_line("ready")
        wait_for(lambda: len(_loaded[id(ip)].graph.refresh_now().publishers.get("/mg/latched", ())) == 2,
                 what="both latched publishers on the master")
        with Peer("publish_seq.py", "/mg/once", 1, 10) as once:
            wait_listed(ip, "/mg/once")
            ok(ip, "%config RosMagics.hz_window = 1.0")
            capsys.readouterr()
            ok(ip, "%topics /mg/ --hz")
            out = capsys.readouterr().out
            rows = _rows(out)
            assert rows["/mg/latched"][-1] == "latched", out
            assert rows["/mg/once"][-1] == "< 2", out
            assert 40 < float(rows["/mg/rate"][-1]) < 60, out
            assert "< N: one message per publisher in 1 s; %hz TOPIC listens longer" in out
            assert once.wait_line("done")
        # %hz keeps listening and reports again (-n of them): the latched messages counted apart.
        ok(ip, "%hz /mg/latched /mg/rate -w 0.6 -n 2")
        rows = _rows(capsys.readouterr().out)
        assert rows["/mg/latched"][1:3] == ["0 (+2 latched)", "latched"], rows
        assert 40 < float(rows["/mg/rate"][2]) < 60, rows
    # %bw: bytes per second and sizes; %delay: now - header.stamp of stamped messages.
    ok(ip, "%bw /mg/rate -w 1 -n 1")
    rows = _rows(capsys.readouterr().out)
    assert rows["/mg/rate"][2].endswith(" B/s") and 150 < float(rows["/mg/rate"][2].split()[0]) < 250, rows
    assert rows["/mg/rate"][3] == "4 B", rows  # a UInt32
    ok(ip, "import rospy, time\nfrom geometry_msgs.msg import PoseStamped\n"
           "stamped = rosNode('mg_stamped')\nstamped.new.publish('/mg/stamped', msgType=PoseStamped)\n"
           "def late():\n    msg = PoseStamped()\n    msg.header.stamp = rospy.Time.from_sec(time.time() - 0.25)\n"
           "    stamped.write('/mg/stamped', msg)\n"
           "stamped.timer(0.05, late)\nstamped.create()")
    try:
        wait_listed(ip, "/mg/stamped")
        ok(ip, "%delay /mg/stamped /mg/rate -w 1 -n 1")
        rows = _rows(capsys.readouterr().out)
        assert 0.2 < float(rows["/mg/stamped"][2]) < 0.5, rows
        assert rows["/mg/rate"][2] == "no header.stamp", rows
    finally:
        ok(ip, "stamped.shutdown()")


def test_topics_errors_and_empty_results(ip, capsys):
    assert "no node /mg_nobody" in str(error_of(ip, "%topics --node mg_nobody"))
    error = error_of(ip, "%topics --type geometry_msgs/Twst")
    assert isinstance(error, MessageTypeError) and "did you mean geometry_msgs/Twist" in str(error)
    capsys.readouterr()
    ok(ip, "%topics /mg/nothing_like_this")
    assert capsys.readouterr().out.strip() == "no live topics matching '/mg/nothing_like_this'"
    assert "unrecognized arguments" in str(error_of(ip, "%topics a b"))


def test_echo_prints_n_messages_and_leaves_no_subscription(ip, capsys, rate_peer):
    wait_listed(ip, "/mg/rate")
    capsys.readouterr()
    ok(ip, "%echo /mg/rate -n 3")
    out = capsys.readouterr().out
    assert out.count("---") == 3 and out.count("data: ") == 3
    values = [int(line.split()[1]) for line in out.splitlines() if line.startswith("data: ")]
    assert values == sorted(values) and len(set(values)) == 3
    assert "/mg/rate" not in master_state(_loaded[id(ip)].graph.where)["sub"]


def test_echo_stops_on_ctrl_c_without_killing_anything(ip, capsys, make_node):
    with Peer("publish_type.py", "/mg/latched", "std_msgs/String") as peer:
        peer.wait_line("ready")
        wait_listed(ip, "/mg/latched")
        capsys.readouterr()
        with ctrl_c_after(1.0):
            ok(ip, "%echo mg/latched")  # relative: resolved in ROS_NAMESPACE, i.e. /
        out = capsys.readouterr().out
        assert out.count("---") == 1, "the latched message, then nothing until Ctrl-C"
        assert "stopped listening to /mg/latched after 1 message" in out
        assert peer.proc.poll() is None
        assert "/mg/latched" not in master_state(_loaded[id(ip)].graph.where)["sub"]


def test_echo_waits_for_a_topic_not_published_yet_and_reads_field_paths(ip, capsys):
    """As rostopic echo: a topic nobody publishes yet is waited for (said once); Ctrl-C ends the wait;
    /topic/field.path prints that field."""
    with ctrl_c_after(1.0):
        ok(ip, "%echo /mg/not_there")
    out = capsys.readouterr().out
    assert "ipyros: /mg/not_there is not published yet; waiting for it (Ctrl-C stops)" in out
    assert "stopped waiting for /mg/not_there" in out
    peers: list = []
    publisher = threading.Timer(1.0, lambda: peers.append(Peer("publish_rate.py", "/mg/later", 20)))
    publisher.start()
    try:
        ok(ip, "%echo /mg/later -n 2")
        out = capsys.readouterr().out
        assert out.count("ipyros: /mg/later is not published yet") == 1 and out.count("data: ") == 2, out
        ok(ip, "%echo /mg/later/data -n 1")  # a field path, as rostopic echo takes it
        out = capsys.readouterr().out
        assert out.startswith("data: ") and out.count("---") == 1, out
    finally:
        publisher.join()
        for peer in peers:
            peer.stop()


def test_echo_errors(ip):
    assert "-n must be 0" in str(error_of(ip, "%echo /x -n -2"))
    assert "invalid topic name 'bad-name'" in str(error_of(ip, "%echo bad-name"))


def test_pub_sends_one_checked_message(ip, capsys):
    with Peer("echo_topic.py", "/mg/heard", "std_msgs/String") as listener:
        listener.wait_line("ready")
        ok(ip, "%pub /mg/heard std_msgs/String hello")
        listener.wait_line('data: "hello"')
        assert "published a std_msgs/String on /mg/heard (from ipyros_pub_" in capsys.readouterr().out
        wait_listed(ip, "/mg/heard")
        ok(ip, "%pub /mg/heard {'data': 'typed from the live topic'}")
        listener.wait_line('data: "typed from the live topic"')
        ok(ip, 'x = "expanded"')
        ok(ip, '%pub /mg/heard std_msgs/String "{x}"')  # no $/{} expansion: the text as typed
        listener.wait_line('data: "{x}"')
        ok(ip, "%%pub /mg/heard std_msgs/String\ndata: from a cell\n")
        listener.wait_line('data: "from a cell"')


def test_pub_mistakes_are_one_line_errors_naming_the_field(ip):
    error = error_of(ip, "%pub /mg/twist geometry_msgs/Twist {linear: {x: 1, q: 2}}")
    assert isinstance(error, MessageTypeError)
    assert str(error) == "geometry_msgs/Twist: linear.q: no such field (geometry_msgs/Vector3 has x, y, z)"
    error = error_of(ip, "%pub /mg/twist geometry_msgs/Twist {angular: {z: fast}}")
    assert "angular.z: expected a number (float64), got 'fast' (str)" in str(error)
    assert "unknown message type 'geometry_msgs/Twst'" in str(error_of(ip, "%pub /mg/twist geometry_msgs/Twst {}"))
    error = error_of(ip, "%pub /mg/nobody_knows {data: 1}")
    assert isinstance(error, UsageError) and "give its type: %pub /mg/nobody_knows pkg/Type" in str(error)
    assert "either on the line or in the cell" in str(error_of(ip, "%%pub /mg/x std_msgs/String hi\ndata: x"))
    assert "--rate must be a positive" in str(error_of(ip, "%pub -r 0 /mg/x std_msgs/String hi"))


def test_pub_through_a_node_that_publishes_the_topic_and_type_conflicts(ip, capsys):
    ok(ip, "from std_msgs.msg import String\n"
           "talker = rosNode('mg_talker').new.publish('/mg/talk', msgType=String).create()")
    try:
        with Peer("echo_topic.py", "/mg/talk", "std_msgs/String") as listener:
            listener.wait_line("ready")
            talker = ip.user_ns["talker"]  # a message written before the connection is up is lost: wait for it
            wait_for(lambda: engine_of(talker).writing.writer("/mg/talk")[0].connections(), what="the listener to connect")
            capsys.readouterr()
            ok(ip, "%pub /mg/talk std_msgs/String 'via the talker'")
            assert "(from mg_talker)" in capsys.readouterr().out
            listener.wait_line('data: "via the talker"')
        assert isinstance(error_of(ip, "%pub /mg/talk std_msgs/Int32 5"), TopicTypeConflict)
    finally:
        ok(ip, "talker.shutdown()")


def test_pub_at_a_rate_until_ctrl_c(ip, capsys):
    with Peer("echo_topic.py", "/mg/beat", "std_msgs/UInt32") as listener:
        listener.wait_line("ready")
        with ctrl_c_after(1.0):
            ok(ip, "%pub -r 20 /mg/beat std_msgs/UInt32 7")  # options before the message
        out = capsys.readouterr().out
        sent = int(out.split("published ")[1].split()[0])
        assert 10 <= sent <= 30 and "at 20 Hz" in out
        wait_for(lambda: sum("data: 7" in line for line in listener.lines) >= 5, what="the beats")


def test_pub_values_that_do_not_fit_are_one_line_errors(ip):
    for value, message in (
            ("{linear: {x: .nan}}", "linear.x: nan is not a number a robot can use; give a finite number"),
            ("{linear: {x: .inf}}", "linear.x: inf is not a number a robot can use"),
            ("{linear: {x: -.inf}}", "linear.x: -inf is not a number"),
            ("[" * 5000 + "]" * 5000, "nested too deeply"),
            ("{a: " * 3000 + "1" + "}" * 3000, "nested too deeply")):
        error = error_of(ip, f"%pub /mg/twist geometry_msgs/Twist {value}")
        assert isinstance(error, (MessageTypeError, UsageError)), (value[:20], error)
        assert message in str(error) and "\n" not in str(error), (value[:20], str(error))
    error = error_of(ip, '%pub "bad topic" std_msgs/String hi')
    assert "invalid topic name '\"bad topic\"'" in str(error) and "\n" not in str(error)
    error = error_of(ip, "%pub /mg/time std_msgs/Time {data: {secs: 99999999999}}")
    assert "data.secs: 99999999999 does not fit" in str(error) and "\n" not in str(error)
    ok(ip, "%pub --nonfinite /mg/range std_msgs/Float32 .inf")  # when it is meant


def test_echo_fields_filter_and_the_messages_kept(ip, capsys, rate_peer):
    wait_listed(ip, "/mg/rate")
    capsys.readouterr()
    ok(ip, "odd = 1")
    ok(ip, "kept = %echo /mg/rate -n 3 --filter 'm.data % 2 == odd' --field data")
    out = capsys.readouterr().out
    values = [int(line.split()[1]) for line in out.splitlines() if line.startswith("data: ")]
    assert len(values) == 3 and all(v % 2 == 1 for v in values), out
    kept = ip.user_ns["kept"]
    assert [m.data for m in kept] == values and repr(kept) == "<3 messages from /mg/rate: a list>"
    assert "/mg/rate" not in master_state(_loaded[id(ip)].graph.where)["sub"]

    error = error_of(ip, "%echo /mg/rate -n 1 --filter 'm.data >'")
    assert isinstance(error, UsageError) and "--filter 'm.data >' is not a Python expression" in str(error)
    error = error_of(ip, "%echo /mg/rate -n 1 --filter 'm.nothing > 0'")
    assert isinstance(error, UsageError) and "raised AttributeError" in str(error) and "on message 1" in str(error)
    error = error_of(ip, "%echo /mg/rate -n 1 --field dta")
    assert isinstance(error, UsageError) and "--field dta: no field 'dta' in std_msgs/UInt32 (it has data)" in str(error)
    error = error_of(ip, "%echo /mg/rate -n 1 --field data dta")  # several fields after one --field
    assert isinstance(error, UsageError) and "--field dta: no field 'dta'" in str(error)
    assert "/mg/rate" not in master_state(_loaded[id(ip)].graph.where)["sub"], "nothing left listening"


def test_echo_output_is_yaml_that_pub_takes_back(ip, capsys):
    with Peer("echo_topic.py", "/mg/round", "geometry_msgs/Twist") as listener:
        listener.wait_line("ready")
        ok(ip, "src = rosNode('mg_round_src').new.publish('/mg/round_src', msgType='geometry_msgs/Twist').create()")
        wait_listed(ip, "/mg/round_src")
        ok(ip, "import threading, time\nfrom geometry_msgs.msg import Twist\n"
               "t = Twist(); t.linear.x = 1.5; t.angular.z = -0.25\n"
               "stop = threading.Event()\n"
               "def feed():\n    while not stop.wait(0.05):\n        src.write('/mg/round_src', t)\n"
               "feeder = threading.Thread(target=feed, daemon=True); feeder.start()")
        capsys.readouterr()
        ok(ip, "heard = %echo /mg/round_src -n 1")
        text = str(ip.user_ns["heard"][0])
        assert "x: 1.5" in text
        ok(ip, "%%pub /mg/round geometry_msgs/Twist\n" + text)  # what %echo printed, sent as it is
        listener.wait_line("x: 1.5")
        listener.wait_line("z: -0.25")
        ok(ip, "stop.set(); feeder.join(5); src.shutdown()")


def test_echo_as_csv_and_as_a_table_and_hz_of_two_topics_at_once(ip, capsys, rate_peer):
    with Peer("publish_rate.py", "/mg/slow", 10) as slow:
        slow.wait_line("ready")
        wait_listed(ip, "/mg/rate")
        wait_listed(ip, "/mg/slow")
        capsys.readouterr()
        ok(ip, "%echo /mg/rate -n 3 --csv")
        lines = [line for line in capsys.readouterr().out.splitlines() if line and not line.startswith("Out[")]
        assert lines[0] == "data" and len(lines) == 4, lines
        values = [int(v) for v in lines[1:]]
        assert values == sorted(values) and len(set(values)) == 3
        ok(ip, "%echo /mg/rate -n 2 --table --field data")
        out = capsys.readouterr().out
        assert "2 messages from /mg/rate" in out and "data" in out
        assert isinstance(error_of(ip, "%echo /mg/rate -n 1 --csv --table"), UsageError)
        assert "--field dta: no field 'dta'" in str(error_of(ip, "%echo /mg/rate -n 1 --csv --field dta"))

        ok(ip, "%hz /mg/rate /mg/slow -w 1.5 -n 1")
        rows = {line.split()[1]: line.replace("│", " ").split() for line in capsys.readouterr().out.splitlines()
                if line.startswith("│") and "/mg/" in line}
        assert set(rows) == {"/mg/rate", "/mg/slow"}, rows
        assert 40 < float(rows["/mg/rate"][2]) < 60 and 7 < float(rows["/mg/slow"][2]) < 13, rows
        assert 0 <= float(rows["/mg/rate"][3]) <= float(rows["/mg/rate"][4]) < 0.5, "min and max intervals"
        assert "/mg/rate" not in master_state(_loaded[id(ip)].graph.where)["sub"], "the listener is gone"
        assert "no live topic /mg/nothing" in str(error_of(ip, "%hz /mg/rate /mg/nothing"))


def test_plot_in_the_terminal_until_ctrl_c_and_to_a_png(ip, capsys, rate_peer, tmp_path):
    import matplotlib.image
    from shell import ctrl_c_after

    wait_listed(ip, "/mg/rate")
    capsys.readouterr()
    p = ok(ip, "%plot /mg/rate data --duration 1.5").result
    out = capsys.readouterr().out
    assert "/mg/rate: * data" in out and "┌" in out and "time (s)" in out, out  # the chart of characters
    values = p.data["data"]
    assert len(values) > 30 and list(values) == sorted(values) and len(p.data["t"]) == len(values)
    assert not p.running and "/mg/rate" not in master_state(_loaded[id(ip)].graph.where)["sub"]

    with ctrl_c_after(1.0):  # no --duration: until Ctrl-C
        p = ok(ip, "%plot /mg/rate data").result
    out = capsys.readouterr().out
    assert "ipyros: plotted" in out and len(p.data["t"]) > 20 and not p.running
    assert "_.data (Out[" in out, "no variable holds it: the message names what does"
    ok(ip, "kept_plot = %plot /mg/rate data --duration 1")
    assert "kept_plot.data holds them" in capsys.readouterr().out

    png = tmp_path / "rate.png"
    ok(ip, f"%plot /mg/rate data --png {png} --duration 1")
    assert "plotted to" in capsys.readouterr().out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and matplotlib.image.imread(png).shape[:2] == (350, 700)

    p = ok(ip, "%plot /mg/rate.data --duration 1").result  # a message path: the topic and its field
    assert p.topic == "/mg/rate" and p.fields == ["data"] and len(p.data["data"]) > 10
    ok(ip, "from std_msgs.msg import UInt32\nother = rosNode('mg_other').new.publish('/mg/other', msgType=UInt32)"
           ".create()\nother.timer(0.02, lambda: other.write('/mg/other', UInt32(data=7)))")
    wait_listed(ip, "/mg/other")
    capsys.readouterr()
    two = ok(ip, "%plot /mg/rate.data /mg/other.data --duration 1").result  # paths into two topics, one plot
    assert two.topics == ["/mg/rate", "/mg/other"] and two.fields == ["/mg/rate.data", "/mg/other.data"]
    assert len(two.data["/mg/other.data"]) > 10 and set(two.data["/mg/other.data"]) == {7.0}
    assert len(two.data["t /mg/rate"]) == len(two.data["/mg/rate.data"]) > 10
    assert "* /mg/rate.data  o /mg/other.data" in capsys.readouterr().out
    ok(ip, "other.shutdown()")
    assert "a slice or a filter is for %echo" in str(error_of(ip, "%plot /mg/rate.data[0]"))
    assert "give two fields" in str(error_of(ip, "%plot /mg/rate data --xy"))
    assert "no field 'dta'" in str(error_of(ip, "%plot /mg/rate dta --duration 1"))
    assert "no live topic /mg/none" in str(error_of(ip, "%plot /mg/none data"))


def test_record_a_live_topic_then_replay_it_through_two_handler_versions(ip, capsys, rate_peer, tmp_path):
    """%record a live topic; wrap the bag with baseBag; intercept the topic with a handler; replay the bag
    after swapping the handler: the two versions' outputs, message for message, on the same recorded data."""
    wait_listed(ip, "/mg/rate")
    bag = tmp_path / "rate.bag"
    capsys.readouterr()
    ok(ip, f"rec = %record {bag} /mg/rate --duration 1")
    assert f"ipyros: recording /mg/rate to {bag} for 1 s" in capsys.readouterr().out
    wait_for(lambda: not ip.user_ns["rec"].running, timeout=10, what="the recording to end by itself")
    assert ip.user_ns["rec"].count >= 30 and "/mg/rate" not in master_state(_loaded[id(ip)].graph.where)["sub"]
    assert "exists; give a new file name" in str(error_of(ip, f"%record {bag} /mg/rate"))
    assert "a ROS 1 recording is a .bag file or an .mcap file (sqlite3 is ROS 2's)" in str(
        error_of(ip, f"%record {tmp_path / 'x'} /mg/rate --storage sqlite3"))
    assert "name it x.mcap" in str(error_of(ip, f"%record {tmp_path / 'x'} /mg/rate --storage mcap"))
    capsys.readouterr()
    ok(ip, f"%bag info {bag}")  # shown once, as the cell's result
    ok(ip, f"info = %bag info {bag}")
    info, shown = ip.user_ns["info"], capsys.readouterr().out
    assert shown.count("/mg/rate") == 1 and "BagInfo(" not in shown, shown
    assert (info.storage, [(r.topic, r.type, r.count) for r in info.rows]) == \
        ("bag", [("/mg/rate", "std_msgs/UInt32", ip.user_ns["rec"].count)])
    assert 0.5 < info.duration < 1.5 and "/mg/rate" in shown
    assert "no bag at" in str(error_of(ip, f"%bag info {tmp_path / 'nothing.bag'}"))

    ok(ip, "from std_msgs.msg import UInt32\nouts = []\n"
           "def double(msg):\n    w.write('/mg/out', UInt32(data=msg.data * 2))\n"
           "listener = rosNode('mg_bag_listener')\n"
           "listener.new.subscribe('/mg/out', lambda m: outs.append(m.data), msgType=UInt32).create()\n"
           "w = rosNode('mg_bag_wrapper')\n"
           f"w.baseBag({str(bag)!r}, rate=2.0)\n"
           "w.reuse.publish('/mg/rate', type=UInt32)  # the bag's topic: the wrapper sits on it\n"
           "w.new.subscribe('/mg/rate', double, msgType=UInt32).publish('/mg/out', msgType=UInt32)\n"
           "w.create()")
    recorded = ip.user_ns["rec"].count
    outs = ip.user_ns["outs"]
    wait_for(lambda: len(outs) >= recorded, timeout=20, what="the whole bag through the handler")
    first = list(outs)
    assert len(first) == recorded and all(x % 2 == 0 for x in first), (recorded, first[:5])
    inputs = [x // 2 for x in first]
    assert inputs == sorted(inputs) and inputs == list(range(inputs[0], inputs[0] + recorded)), "in order, none lost"

    ok(ip, "def triple(msg):\n    w.write('/mg/out', UInt32(data=msg.data * 3))\n"
           "w.new.subscribe('/mg/rate', triple, msgType=UInt32)\nouts.clear()\nw.base.restart()")
    wait_for(lambda: len(outs) >= recorded, timeout=20, what="the bag again, through the new handler")
    assert list(outs) == [3 * x for x in inputs], "the same messages, the new behaviour, one for one"
    capsys.readouterr()
    ok(ip, "%status")  # the basenode is the bag, by name (not ipyros's player script)
    assert "bag " in capsys.readouterr().out
    ok(ip, f"w.save({str(tmp_path / 'w.py')!r})")
    assert f"w.baseBag({str(bag)!r}, rate=2.0, loop=False, delay=5.0)" in (tmp_path / "w.py").read_text()
    ok(ip, "w.shutdown(); listener.shutdown()")
    assert "no such file" in str(error_of(ip, "rosNode('mg_b2').baseBag('/nonexistent.bag')"))
    assert "has no topic /nope" in str(error_of(ip, f"rosNode('mg_b3').baseBag({str(bag)!r}, topics=['/nope'])"))


def test_record_an_mcap_file_of_ros1_messages_then_play_it_through_a_handler(ip, capsys, rate_peer, tmp_path):
    """%record run.mcap on ROS 1 writes MCAP (the ros1 profile); %bag info reads it; baseBag plays it, in order."""
    wait_listed(ip, "/mg/rate")
    mcap = tmp_path / "rate.mcap"
    capsys.readouterr()
    ok(ip, f"rec = %record {mcap} /mg/rate --duration 1")
    assert f"ipyros: recording /mg/rate to {mcap} (mcap) for 1 s" in capsys.readouterr().out
    wait_for(lambda: not ip.user_ns["rec"].running, timeout=10, what="the recording to end by itself")
    recorded = ip.user_ns["rec"].count
    assert recorded >= 30 and mcap.read_bytes()[:8] == b"\x89MCAP0\r\n"
    ok(ip, f"info = %bag info {mcap}")
    info = ip.user_ns["info"]
    assert (info.storage, [(r.topic, r.type, r.count) for r in info.rows]) == \
        ("mcap", [("/mg/rate", "std_msgs/UInt32", recorded)])
    ok(ip, "from std_msgs.msg import UInt32\nmc_outs = []\n"
           "mc = rosNode('mg_mcap_wrapper')\n"
           f"mc.baseBag({str(mcap)!r}, rate=4.0)\n"
           "mc.reuse.publish('/mg/rate', type=UInt32)\n"
           "mc.new.subscribe('/mg/rate', lambda m: mc_outs.append(m.data), msgType=UInt32)\n"
           "mc.create()")
    outs = ip.user_ns["mc_outs"]
    wait_for(lambda: len(outs) >= recorded, timeout=20, what="the whole MCAP file through the handler")
    assert outs == list(range(outs[0], outs[0] + recorded)), "in order, none lost"
    ok(ip, "mc.shutdown()")


def test_topics_names_the_sessions_dsl_nodes_not_the_ros_node_they_share(ip, capsys):
    """On ROS 1 the session's DSL nodes share one ROS node: %topics says which of them uses a topic."""
    ok(ip, "owner = rosNode('mg_owner').new.publish('/mg/owned', msgType='std_msgs/String').create()")
    wait_listed(ip, "/mg/owned")
    capsys.readouterr()
    ok(ip, "%topics /mg/owned")
    row = next(line for line in capsys.readouterr().out.splitlines() if "/mg/owned" in line)
    assert "/mg_owner" in row and "/ipyros_test" not in row, row
    ok(ip, "owner.shutdown()")
    ok(ip, "%pub /mg/owned std_msgs/String hi")  # now only ipyros's own publisher has it
    ok(ip, "%topics /mg/owned")
    row = next(line for line in capsys.readouterr().out.splitlines() if "/mg/owned" in line and "│" in line)
    assert "/ipyros_pub_" in row and "/mg_owner" not in row and "/ipyros_test" not in row, row
