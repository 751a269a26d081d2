"""%services, %call, %params, %param, %nodes, %node in a real shell, against the test master."""

from __future__ import annotations

from ros1_fixtures import wait_for
from shell import error_of, ok

from ipyros.ipython.extension import _loaded

SERVER = """\
from std_srvs.srv import SetBool, SetBoolResponse
asked = []
def check(req):
    asked.append(req.data)
    return SetBoolResponse(success=req.data, message='checked')
srv = rosNode('mi_server', namespace='/mi')
srv.new.service('check', SetBool, check).publish('out', msgType='std_msgs/String')
srv.params['gain'] = 1.5
srv.create()
"""


def test_services_call_params_and_nodes_at_the_prompt(ip, capsys):
    ok(ip, SERVER)
    try:
        graph = _loaded[id(ip)].graph
        wait_for(lambda: "/mi/check" in graph.refresh_now().services, what="/mi/check on the master")
        capsys.readouterr()
        ok(ip, "%services /mi/")
        out = capsys.readouterr().out
        row = next(line for line in out.splitlines() if "/mi/check" in line)
        assert "std_srvs/SetBool" in row and "/ipyros_test" in row, out

        # %call: the type asked of the live service; the request built field by field; the answer as YAML.
        ok(ip, "%call /mi/check {data: true}")
        out = capsys.readouterr().out
        assert "success: True" in out and "message: \"checked\"" in out, out
        assert ip.user_ns["asked"] == [True]
        ok(ip, "%call /mi/check std_srvs/SetBool {'data': False}")
        assert "success: False" in capsys.readouterr().out
        assert "SetBoolRequest: dat: no such field" in str(error_of(ip, "%call /mi/check {dat: 1}"))
        assert "no live service /mi/nothing; %services lists them" in str(error_of(ip, "%call /mi/nothing {}"))
        for timeout in ("-1", "0"):  # rospy's own answer was 96 lines ending in "Timeout value out of range"
            said = str(error_of(ip, f"%call /mi/check std_srvs/SetBool -t {timeout} {{data: true}}"))
            assert said.startswith(f"-t {timeout}: give the seconds to wait") and "\n" not in said, said

        # %params / %param: read, set, read back.
        ok(ip, "%params /mi")
        out = capsys.readouterr().out
        assert "/mi/mi_server/gain" in out and "1.5" in out, out
        ok(ip, "%param /mi/mi_server/gain 2.5")
        assert "ipyros: /mi/mi_server/gain = 2.5" in capsys.readouterr().out
        assert ip.user_ns["srv"].params["gain"] == 2.5
        ok(ip, "%param /mi/mi_server/gain")
        assert "/mi/mi_server/gain: 2.5" in capsys.readouterr().out

        # %nodes / %node: the session's own node, with its pid, what it publishes and serves.
        ok(ip, "%nodes ipyros_test")
        out = capsys.readouterr().out
        assert "/ipyros_test" in out and "this session" in out, out
        ok(ip, "%node /ipyros_test")
        out = capsys.readouterr().out
        import os
        assert f"(pid {os.getpid()})" in out and "/mi/out" in out and "/mi/check" in out, out
        assert "no live node /nobody; %nodes lists them" in str(error_of(ip, "%node /nobody"))
    finally:
        ok(ip, "srv.shutdown()")


def test_a_dynamic_reconfigure_server_is_shown_with_its_ranges_and_set_through(ip, capsys):
    """ROS 1: %params shows a dynamic_reconfigure server's parameters with their ranges, and %param sets them
    through the server, so the running node hears them (the parameter server it reads only at start) (issue 24)."""
    from ros1_fixtures import Peer, wait_for

    with Peer("reconfigurable.py", "dr_node") as server:
        server.wait_line("ready")
        ip.run_line_magic("load_ext", "ipyros")
        wait_for(lambda: ip.run_line_magic("params", "/dr_node") is None and "dynamic_reconfigure" in
                 (out := capsys.readouterr().out) and out, timeout=20, interval=0.3, what="the server's parameters")
        capsys.readouterr()
        ip.run_line_magic("params", "/dr_node")
        table = capsys.readouterr().out
        assert "/dr_node/int_" in table and "int -10..10" in table and "double -2..10" in table, table
        ip.run_line_magic("param", "/dr_node/int_ 5")
        assert "ipyros: /dr_node/int_ = 5" in capsys.readouterr().out
        server.wait_line("reconfigured int_=5")
        ip.run_line_magic("param", "/dr_node/int_ 50")
        assert "ipyros: /dr_node/int_ = 10" in capsys.readouterr().out, "the server keeps it in its range"
        ip.run_line_magic("param", "/dr_node/double_ --describe")
        described = capsys.readouterr().out
        assert described.startswith("/dr_node/double_: type double, min -2.0, max 10.0, default 0.0"), described


def test_the_sessions_own_service_shows_its_type_without_a_probe(ip, capsys, monkeypatch):
    """A service of the session's own nodes is typed from what serves it here: a probe through the session's own
    socket needs its server thread, which a loaded session may not run within the probe's timeout (was "?")."""
    from ipyros.core.errors import IpyrosError
    from ipyros.ros1 import introspect

    def no_probe(uri: str, name: str, timeout: float = 2.0) -> str:
        raise IpyrosError(f"the server of {name} does not answer")

    ok(ip, SERVER)
    try:
        graph = _loaded[id(ip)].graph
        wait_for(lambda: "/mi/check" in graph.refresh_now().services, what="/mi/check on the master")
        monkeypatch.setattr(introspect, "probe_type", no_probe)
        capsys.readouterr()
        ok(ip, "%services /mi/")
        out = capsys.readouterr().out
        assert "std_srvs/SetBool" in next(line for line in out.splitlines() if "/mi/check" in line), out
        ok(ip, "%node /ipyros_test")
        assert "std_srvs/SetBool" in next(line for line in capsys.readouterr().out.splitlines() if "/mi/check" in line)
    finally:
        ok(ip, "srv.shutdown()")
