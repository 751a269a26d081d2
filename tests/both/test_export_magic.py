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
