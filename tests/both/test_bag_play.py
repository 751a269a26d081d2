"""A bag driven while it plays (pause, resume, step, seek, rate, loop: ``%bag pause nd`` ...), and the bag's time:
``baseBag(..., clock=True)`` publishes /clock from the bag's stamps and ``nd.now()`` reads it; on ROS 2 the node's
timers run on it too. Real players, on either ROS."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from shell import error_of, ok
from std_msgs.msg import UInt32
from support import settled, wait_for

from ipyros.core.errors import IpyrosError, NodeStateError
from ipyros.dsl import engine_of
from ipyros.tools.bagplay import control
from ipyros.tools.record import bag_module

PEERS = Path(__file__).parent / "peers"
S = 1_000_000_000
START = 1000 * S  # the bag was recorded at 1000 s (sim time), 0.1 s between messages


def write_bag(path, count: int = 40) -> None:
    writer = bag_module().BagWriter(path)
    for i in range(1, count + 1):
        writer.write("/bp/count", UInt32(data=i), stamp=START + (i - 1) * S // 10)
    writer.close()


def bag_path(session, tmp_path, name: str):
    return tmp_path / (f"{name}.bag" if session.backend.name == "ROS 1" else name)  # ROS 2: a rosbag2 folder


def playing(make_node, path, name: str, **options):
    heard: list[tuple[int, float]] = []
    nd = make_node(name)
    nd.baseBag(str(path), delay=2.0, **options)
    nd.reuse.publish("/bp/count", type=UInt32)
    nd.new.subscribe("/bp/count", lambda m: heard.append((m.data, nd.now())), msgType=UInt32)
    nd.create()
    return nd, heard


def test_pause_step_seek_rate_and_loop_drive_the_bag_while_it_plays(make_node, session, tmp_path):
    path = bag_path(session, tmp_path, "drive")
    write_bag(path)
    nd, heard = playing(make_node, path, "bp_drive")
    wait_for(lambda: len(heard) >= 3, timeout=30, what="the bag's first messages")
    paused = control(nd, "pause")
    assert paused.paused and 0.0 < paused.at < 3.9 and paused.length == pytest.approx(3.9)
    count = settled(lambda: len(heard), what="what was sent before the pause")
    time.sleep(0.5)  # five messages' time: none comes while paused
    assert len(heard) == count, "a message came while paused"
    stepped = control(nd, "step 3")
    wait_for(lambda: len(heard) == count + 3, what="three messages, stepped")
    assert stepped.paused and [d for d, _ in heard[-3:]] == list(range(heard[count - 1][0] + 1, heard[count - 1][0] + 4))
    time.sleep(0.3)
    assert len(heard) == count + 3, "held after the three steps"
    control(nd, "seek 0")
    assert control(nd, "rate 4").rate == 4.0
    resumed = control(nd, "resume")
    assert not resumed.paused and resumed.at < 0.5
    wait_for(lambda: [d for d, _ in heard[count + 3:]][:1] == [1], what="the bag again from its start, after the seek")
    assert control(nd, "loop on").loop
    wait_for(lambda: [d for d, _ in heard].count(1) >= 3, timeout=20, what="the bag again, looping")
    with pytest.raises(IpyrosError, match=r"^%bag seek: seek 99: the bag lasts 3\.900 s; give seconds from its start"):
        control(nd, "seek 99")
    with pytest.raises(IpyrosError, match="the controls are pause, resume, step N, seek SECONDS, rate R, loop on"):
        control(nd, "rewind")
    nd.shutdown()
    with pytest.raises(NodeStateError, match="bp_drive's bag is not playing"):
        control(nd, "pause")


def test_bag_magic_drives_a_node_and_says_what_is_wrong_in_one_line(ip, session, tmp_path, capsys):
    path = bag_path(session, tmp_path, "magic")
    write_bag(path, 200)
    ok(ip, "from std_msgs.msg import UInt32\nheard = []\n"
           f"bm = rosNode('bp_magic').baseBag({str(path)!r}, delay=2.0, loop=True)\n"
           "bm.reuse.publish('/bp/count', type=UInt32)\n"
           "bm.new.subscribe('/bp/count', lambda m: heard.append(m.data), msgType=UInt32)\nbm.create()\n"
           "plain = rosNode('bp_plain')")
    wait_for(lambda: ip.user_ns["heard"], timeout=30, what="the bag's messages")
    capsys.readouterr()
    ok(ip, "%bag pause bm")
    out = capsys.readouterr().out  # shown once, as the cell's result
    assert out.count("bp_magic's bag: at ") == 1 and out.count("paused") == 1 and "PlayerState(" not in out, out
    ok(ip, "state = %bag pause bm")
    assert ip.user_ns["state"].paused
    assert "needs seconds from the bag's start, e.g. %bag seek bm 12.5" in str(error_of(ip, "%bag seek bm"))
    assert "bp_plain plays no bag; declare one first" in str(error_of(ip, "%bag pause plain"))
    ok(ip, "bm.shutdown()")


def test_a_bags_clock_is_the_nodes_time(make_node, session, tmp_path, notices):
    path = bag_path(session, tmp_path, "clock")
    write_bag(path)
    ticks: list[float] = []
    nd, heard = playing(make_node, path, "bp_clock", clock=True)
    nd.timer(0.1, lambda: ticks.append(nd.now()), name="tick")
    assert any("bag time on /clock" in n for n in notices), notices
    wait_for(lambda: len(heard) >= 10, timeout=30, what="the bag's messages")
    late = heard[5:]
    assert all(START / S - 0.5 <= now <= START / S + 4.5 for _, now in late), late  # the bag's time, not today's
    if session.backend.name == "ROS 2":  # its timers run on the bag's time: still while the bag is paused
        wait_for(lambda: ticks, what="the timer on bag time")
        control(nd, "pause")
        count = settled(lambda: len(ticks), what="the ticks due before the pause")
        time.sleep(0.6)  # six ticks' time: at most one comes while the bag's time stands still
        assert len(ticks) <= count + 1, "the timer ticked on while the bag's time stood still"
        control(nd, "resume")
        wait_for(lambda: len(ticks) > count + 2, what="the timer again, with the bag's time")
        other = make_node("bp_clock_base")  # a basenode started while the bag's time runs runs on it too
        other.baseNode(str(PEERS / "talk.py"), name="bp_talker", args=["/bp/talk", "std_msgs/String", "5"])
        other.reuse.publish("/bp/talk", type="std_msgs/String")
        other.create()
        assert engine_of(nd).session.backend.read_param(f"{other.basenode_name}/use_sim_time") is True
        other.shutdown()
    else:  # one clock a process: the session's timers keep the wall clock, as said
        assert any("this session's timers keep the wall clock" in n for n in notices), notices
        assert engine_of(nd).session.backend.get_param("/use_sim_time") is True
    nd.shutdown()
    assert any("bag time stopped" in n for n in notices), notices
    if session.backend.name == "ROS 1":
        assert not engine_of(nd).session.backend.has_param("/use_sim_time")
    with pytest.raises(NodeStateError, match="bp_clock is not running"):
        nd.now()


def test_a_bag_player_form_pauses_steps_seeks_and_changes_the_rate(make_node, session, tmp_path):
    pytest.importorskip("ipywidgets", reason="the test extra installs ipywidgets")
    from ipyros.ipython.widgets import BagPlayerForm

    path = bag_path(session, tmp_path, "form")
    write_bag(path)
    nd, heard = playing(make_node, path, "bp_form")
    wait_for(lambda: len(heard) >= 3, timeout=30, what="the bag's first messages")
    form = BagPlayerForm(lambda text: control(nd, text))
    assert (form.seek.min, form.seek.max) == (0.0, pytest.approx(3.9))
    form.paused.value = True
    assert "paused at rate 1" in form.status.value
    count = settled(lambda: len(heard), what="what was sent before the pause")
    form.step.click()
    wait_for(lambda: len(heard) == count + 1, what="one message, stepped")
    form.seek.value = 0.0
    form.rate.value = 4.0
    assert "rate 4" in form.status.value
    form.paused.value = False
    wait_for(lambda: [d for d, _ in heard[count + 1:]][:1] == [1], what="the bag again from its start")
    nd.shutdown()
    form.paused.value = True
    assert form.status.value.startswith("pause: bp_form's bag is not playing")
    form.close()
