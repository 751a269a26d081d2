"""``%record ... --filter`` keeps only what its expression is true for; ``%bag convert IN OUT`` rewrites a bag across
the two ROS's formats with topic, time and content filters, on either ROS's venv."""

from __future__ import annotations

from shell import error_of, ok
from support import wait_for

from ipyros.tools.record import bag_module


def numbers(path) -> list[int]:
    return [m.data for _, _, m in bag_module().bag_messages(path, {"/bc/n"})]


def test_record_with_a_filter_then_convert_across_formats_and_back(ip, session, tmp_path, capsys):
    ros1 = session.backend.name == "ROS 1"
    ok(ip, "from std_msgs.msg import UInt32\nsrc = rosNode('bc_src').new.publish('/bc/n', msgType=UInt32).create()\n"
           "n = [0]\ndef tick():\n    n[0] += 1\n    src.write('/bc/n', UInt32(data=n[0]))\nsrc.timer(0.01, tick)")
    bag = tmp_path / ("rec.bag" if ros1 else "rec")
    wait_for(lambda: ip.run_cell(f"rec = %record {bag} /bc/n --duration 1 --filter 'm.data % 2 == 0'").success,
             timeout=30, interval=0.2, what="the topic in the graph, to record it")
    wait_for(lambda: not ip.user_ns["rec"].running, timeout=10, what="the recording to end")
    ok(ip, "src.shutdown()")
    recorded = numbers(bag)
    assert len(recorded) >= 20 and all(x % 2 == 0 for x in recorded), recorded
    other = tmp_path / ("other" if ros1 else "other.bag")  # the other ROS's format
    ok(ip, f"c = %bag convert {bag} {other} --filter 'm.data % 4 == 0 and topic == \"/bc/n\" and t >= 0'")
    kept = [x for x in recorded if x % 4 == 0]
    assert (ip.user_ns["c"].kept, ip.user_ns["c"].read) == (len(kept), len(recorded))
    assert repr(ip.user_ns["c"]).startswith(f"<Converted: {other}: {len(kept)} of {len(recorded)} messages of /bc/n")
    ok(ip, "c")  # shown once, as the cell's result: its sentence, not a dataclass's fields
    assert capsys.readouterr().out.count(f"{len(kept)} of {len(recorded)} messages") == 1
    back = tmp_path / ("back.bag" if ros1 else "back")
    ok(ip, f"%bag convert {other} {back} --start 0")
    assert numbers(back) == kept
    assert "give the bag to write: %bag convert" in str(error_of(ip, f"%bag convert {bag}"))
    assert "are for %bag convert IN OUT" in str(error_of(ip, f"%bag info {bag} --start 1"))
    error = str(error_of(ip, f"%bag convert {bag} {tmp_path / 'half'} --filter 'm.nope > 1'"))
    assert "raised AttributeError" in error and "on message 1" in error and not (tmp_path / "half").exists()
    path_filtered = tmp_path / ("pf" if ros1 else "pf.bag")
    ok(ip, f"pf = %bag convert {bag} {path_filtered} --filter '/bc/n{{data>10}}'")  # a message path, Foxglove's way
    assert ip.user_ns["pf"].kept == len([x for x in recorded if x > 10])
