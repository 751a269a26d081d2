"""``%export NODE PATH [--cpp]`` at the prompt: nd.export(PATH) (language="cpp" with --cpp), said in one line."""

from __future__ import annotations

from shell import error_of, ok


def test_export_at_the_prompt_writes_the_script_or_the_package(ip, session, tmp_path, capsys):
    ok(ip, "from std_msgs.msg import String\n"
           "xn = rosNode('xn')\n"
           "xn.new.subscribe('/xn/in', lambda m: xn.write('/xn/out', m), msgType=String).publish('/xn/out', msgType=String)")
    capsys.readouterr()
    ok(ip, f"%export xn {tmp_path / 'xn.py'}")
    assert f"ipyros: exported /xn to {tmp_path / 'xn.py'}" in capsys.readouterr().out
    assert "def main():" in (tmp_path / "xn.py").read_text()
    if session.backend.name == "ROS 1":
        ok(ip, f"%export xn {tmp_path / 'xn_cpp'} --cpp")
        assert "void" in (tmp_path / "xn_cpp" / "src" / "xn.cpp").read_text()
    else:
        error = error_of(ip, f"%export xn {tmp_path / 'xn_cpp'} --cpp")
        assert "C++ export is made for ROS 1 (roscpp)" in str(error) and not (tmp_path / "xn_cpp").exists()
    assert "no rosNode called 'nobody'" in str(error_of(ip, f"%export nobody {tmp_path / 'n.py'}"))


def test_a_handler_global_named_like_a_module_of_the_script_is_refused_not_silently_read_as_it(ip, session,
                                                                                                  tmp_path):
    """``rospy = 5`` (ROS 1), ``rclpy = 5`` (ROS 2), ``time = 5`` beside a guard (whose code imports time): the
    exported handler would read the module instead of the user's value. Refused in one line, nothing written."""
    library = "rospy" if session.backend.name == "ROS 1" else "rclpy"
    ok(ip, "from std_msgs.msg import Float64\n"
           f"{library} = 5\n"
           "time = 5\n"
           "gn = rosNode('gn')\n"
           f"def scale(m):\n    m.data *= {library}\n    gn.write('/gn/out', m)\n"
           "def stamp(m):\n    m.data = time\n    gn.write('/gn/out', m)\n"
           "gn.new.subscribe('/gn/in', scale, msgType=Float64).publish('/gn/out', msgType=Float64)")
    error = error_of(ip, f"gn.export({str(tmp_path / 'gn.py')!r})")
    assert f"handler scale uses the global {library}, a name the exported script needs for itself; rename it" \
        in str(error) and "\n" not in str(error), str(error)
    ok(ip, f"{library} = __import__({library!r})\n"
           "gn.new.subscribe('/gn/in', stamp, msgType=Float64)\n"
           "gn.guard('/gn/out', limits={'data': (-1, 1)})")
    error = error_of(ip, f"gn.export({str(tmp_path / 'gn.py')!r})")
    assert "handler stamp uses the global time, a name the exported script needs for itself" in str(error)
    assert not (tmp_path / "gn.py").exists()
