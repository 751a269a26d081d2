"""The keeper's checks, pure (:mod:`ipyros.processes.keeper`): the token, signed requests and heartbeats, the lease."""

from __future__ import annotations

import json
import stat

import pytest

from ipyros.processes.keeper import Lease, MachineError, Refused, Token, Verifier, beat_text, check_machine_name


def test_the_token_is_made_once_for_its_owner_only_and_read_back(tmp_path):
    path = tmp_path / "machines" / "robot1.token"
    made = Token.made_or_read(path)
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    again = Token.made_or_read(path)
    assert made.sign("x") == again.sign("x") == Token.read(path, "robot1").sign("x")


def test_a_missing_or_open_token_is_one_line_saying_what_to_do(tmp_path):
    path = tmp_path / "robot1.token"
    with pytest.raises(MachineError, match=r"no token for machine robot1 at .*robot1.token: copy it there"):
        Token.read(path, "robot1")
    Token.made_or_read(path)
    path.chmod(0o644)
    with pytest.raises(MachineError, match=r"can be read by others \(mode 0644\): chmod 600"):
        Token.read(path, "robot1")
    path.write_text("not hex\n")
    path.chmod(0o600)
    with pytest.raises(MachineError, match="is not a machine's token"):
        Token.read(path, "robot1")


def test_machine_names_are_words():
    assert check_machine_name("robot_1") == "robot_1"
    for bad in ("", "1robot", "robot/1", "a b", None):
        with pytest.raises(MachineError, match="give a word"):
            check_machine_name(bad)


def _request(token: Token, epoch: str = "e1", n: int = 1, sender: str = "s1") -> str:
    return token.signed({"epoch": epoch, "from": sender, "n": n, "op": "estop"})


def test_a_request_must_be_signed_for_this_start_and_never_heard_before(tmp_path):
    token = Token.made_or_read(tmp_path / "a.token")
    other = Token.made_or_read(tmp_path / "b.token")
    verifier = Verifier(token, "e1")
    assert verifier.open(_request(token, n=5))["op"] == "estop"
    with pytest.raises(Refused, match=r"replayed request \(counter 5, already at 5\)"):
        verifier.open(_request(token, n=5))
    with pytest.raises(Refused, match="replayed"):
        verifier.open(_request(token, n=4))
    assert verifier.open(_request(token, n=6))["n"] == 6
    assert verifier.open(_request(token, n=1, sender="s2"))["from"] == "s2", "each sender counts on its own"
    with pytest.raises(Refused, match="bad signature"):
        verifier.open(_request(other, n=7))
    with pytest.raises(Refused, match="another start of this keeper"):
        verifier.open(_request(token, epoch="e0", n=8))
    body = json.dumps({"epoch": "e1", "from": "s1", "n": 9, "op": "estop"})
    with pytest.raises(Refused, match="unsigned request"):
        verifier.open(json.dumps({"body": body}))
    tampered = json.loads(_request(token, n=10))
    tampered["body"] = tampered["body"].replace('"estop"', '"remove"')
    with pytest.raises(Refused, match="bad signature"):
        verifier.open(json.dumps(tampered))
    with pytest.raises(Refused, match="not a request of ipyros"):
        verifier.open("rm -rf /")


def test_a_heartbeat_keeps_the_lease_only_signed_and_fresh(tmp_path):
    token = Token.made_or_read(tmp_path / "a.token")
    verifier = Verifier(token, "e1")
    assert verifier.beat(beat_text(token, "e1", "s1", 1)) == "s1"
    assert verifier.beat(beat_text(token, "e1", "s1", 1)) is None, "replayed"
    assert verifier.beat(beat_text(token, "e0", "s1", 2)) is None, "for another start"
    assert verifier.beat(beat_text(Token.made_or_read(tmp_path / "b.token"), "e1", "s1", 3)) is None, "forged"
    assert verifier.beat("s1 4") is None and verifier.beat("") is None
    assert verifier.beat(beat_text(token, "e1", "s1", 5)) == "s1"


def test_the_lease_holds_the_stop_once_lost_releases_when_heard_and_ends_past_its_grace():
    lease = Lease(length=0.5, grace=5.0, last=100.0)
    assert lease.held and lease.first, "held until its session is first heard"
    assert lease.look(100.6) == "ok", "not lost: not heard yet"
    assert lease.heard(100.2) == pytest.approx(0.2) and not lease.held and not lease.first
    assert lease.look(100.6) == "ok"
    assert lease.look(100.8) == "lost" and lease.held
    assert lease.look(100.9) == "ok", "said once"
    assert lease.heard(101.2) == pytest.approx(1.0) and not lease.held
    assert lease.heard(101.3) is None
    assert lease.look(106.4) == "gone"
    kept = Lease(length=0.5, grace=None, last=0.0)
    kept.heard(0.0)
    assert kept.look(1e6) == "lost" and kept.look(2e6) == "ok", "grace None: never ended"


@pytest.mark.parametrize("spec, why", [
    ({"package": "other", "executable": "talker"}, "package 'other' is not allowed on this machine (its keeper allows "
                                                   "demo): start the keeper with --allow other"),
    ({"executable": "talker"}, "package None is not allowed"),
    ({"package": "demo", "executable": "/bin/sh"}, "executable '/bin/sh': give its name in package demo, never a path"),
    ({"package": "demo", "executable": "../../bin/sh"}, "never a path or a shell line"),
    ({"package": "demo", "executable": "talker; rm -rf ~"}, "never a path or a shell line"),
    ({"package": "demo", "executable": "talker", "args": "--rate 5"}, "args must be a list of at most 64 strings"),
    ({"package": "demo", "executable": "talker", "args": [5]}, "args must be a list"),
    ({"package": "demo", "executable": "talker", "remaps": {"__log": "/etc/passwd"}}, "is the keeper's to set"),
    ({"package": "demo", "executable": "talker", "remaps": {"in": "a b"}}, "invalid remap"),
    ({"package": "demo", "executable": "talker", "params": {"$(eval)": 1}}, "invalid parameter name"),
    ({"package": "demo", "executable": "talker", "node_name": "a/b"}, "invalid node name"),
])
def test_a_placed_basenode_is_an_allowed_packages_executable_by_name_and_nothing_else(spec, why):
    from ipyros.processes.keeper.bases import _base_of

    with pytest.raises(Refused) as refused:
        _base_of(spec, frozenset({"demo"}))
    assert why in str(refused.value) and "\n" not in str(refused.value)


def test_a_placed_basenode_keeps_its_remaps_params_and_args_as_given():
    from ipyros.processes.keeper.bases import _base_of

    base = _base_of({"package": "demo", "executable": "talker", "node_name": "talker", "namespace": "/robot1",
                     "remaps": {"in": "/robot1/base/in"}, "params": {"rate": 5}, "args": ["--fast"]},
                    frozenset({"demo"}))
    assert (base.package, base.executable, base.node_name, base.namespace) == ("demo", "talker", "talker", "/robot1/")
    assert base.remaps == {"in": "/robot1/base/in"} and base.params == {"rate": 5} and base.args == ["--fast"]
    assert _base_of({"package": "demo", "executable": "talker"}, frozenset({"demo"})).namespace is None


def test_the_keepers_are_read_from_the_graphs_topics_and_shown_one_a_row():
    from ipyros.core.records import Machine, Machines
    from ipyros.tools.machines import keepers_in

    topics = ["/ipyros/machines/robot1/info", "/ipyros/machines/robot1/request", "/ipyros/machines/arm_2/info",
              "/ipyros/machines/bad name/info", "/ipyros/machines/robot1/guards/abc123/state", "/info"]
    assert keepers_in(topics) == ["arm_2", "robot1"]
    table = Machines((Machine("robot1", "nuc", "ROS 1", allows={"drivers": ["base"]}, guards=("/cmd_vel",),
                              rtt_ms=3.25, token=True),
                      Machine("arm_2", heard=False), Machine("cart", "pi", "ROS 1", rtt_ms=None))).table()
    assert table.title == "3 machines"
    assert table.rows[0][:7] == ("robot1", "nuc", "ROS 1", "drivers", "/cmd_vel", "", "3.2")
    assert "no answer" in str(table.rows[1][1]) and str(table.rows[2][6]) == "no answer"
    assert str(table.rows[2][7]).startswith("no: copy it") and str(table.rows[2][3]) == "guards only"
    assert "python -m ipyros.machine" in Machines(()).table().title


def test_a_command_the_keepers_gate_cannot_check_goes_out_as_the_stop_message():
    """Fail closed on the robot: a message the gate fails on (a value its check cannot read) is replaced by the
    stop message, never dropped (the robot would keep the last command) and never sent unchecked."""
    from types import SimpleNamespace

    from ipyros.processes.keeper import KeptGuard

    def fails(msg):
        raise ValueError("a value the check cannot read")

    sent: list = []
    guard = KeptGuard.__new__(KeptGuard)  # its gate and publisher only: no stop process, no ROS
    guard.topic, guard._log, guard._stop, guard._arm_by = "/cmd_vel", lambda text: None, {"linear": 0.0}, 0.0
    guard.gate = SimpleNamespace(check=fails)
    guard._out = SimpleNamespace(write=sent.append)
    guard.command({"linear": 9.0})
    assert sent == [{"linear": 0.0}]
    assert guard.check({"linear": 9.0}).send == {"linear": 0.0}, "what a relay in the keeper passes its messages through"


def test_a_placed_guards_rules_are_judged_on_the_robot_as_a_sensor_comes_and_said_once():
    """The keeper's side of rules: an input heard there judges at once; while the rules hold the stop message it
    goes out on the robot at the guard's rate, said once, and what it reports says why and which rule acts."""
    import time
    from types import SimpleNamespace

    from unit_msgs.msg import Sample, Twist, Vector3

    from ipyros.core.errors import DeclarationError
    from ipyros.core.guard import Gate, RuleWatch
    from ipyros.core.rules import rule
    from ipyros.processes.keeper import KeptGuard

    spec = {"topic": "/cmd_vel", "rules": [rule("min(/scan.gains) < 0.5", stop=True).as_data()],
            "stale": {"/scan": 0.5}}
    with pytest.raises(DeclarationError, match="the types of /scan were not sent: place it again"):
        KeptGuard._ruleset(spec, Twist, "guard /cmd_vel")
    sent: list = []
    logged: list[str] = []
    guard = KeptGuard.__new__(KeptGuard)  # its gate, rules and publisher only: no stop process, no ROS
    guard.topic, guard._log, guard._stop, guard.repeat = "/cmd_vel", logged.append, Twist(), 10.0
    guard.rules = KeptGuard._ruleset({**spec, "inputs": {"/scan": "unit_msgs/Sample"}}, Twist, "guard /cmd_vel")
    guard.heard, guard.watch, guard._arm_by = {}, RuleWatch(guard.repeat), 0.0
    guard.gate = Gate("/cmd_vel", Twist, {}, {}, "clamp", guard.stop_message, lambda: False, lambda: None,
                      lambda text: None, rules=guard.rules, heard=lambda: guard.heard)
    guard._out = SimpleNamespace(write=sent.append)
    hear = guard._hearing("/scan")
    hear(Sample(gains=[2.0, 3.0]))
    guard.command(Twist(linear=Vector3(x=0.4)))
    assert [m.linear.x for m in sent] == [0.4] and guard.watch.ruling == ""
    hear(Sample(gains=[0.3, 3.0]))  # an obstacle: judged as it comes, no command needed
    assert [m.linear.x for m in sent] == [0.4, 0.0] and guard.watch.ruling.startswith("rule 1")
    assert logged == ["guard /cmd_vel: rule 1: min(/scan.gains) < 0.5: the stop message goes out until its rules "
                      "let a command pass"], logged
    assert guard._judge(time.monotonic()) is None and len(logged) == 1, "said once"
    assert guard.rules.described((1,)) == ("1. when min(/scan.gains) < 0.5: stop (in force)",)


def test_a_placed_guards_limit_rule_sends_the_stop_through_its_gate_once_as_a_sessions_guard_does():
    """An obstacle under a limit rule with no command coming: the last command would now be limited, so the stop
    message goes out, through the keeper's gate; then it is the last command, which the rules pass: not sent again
    while the obstacle stays, and nothing said when it goes."""
    import time
    from types import SimpleNamespace

    from unit_msgs.msg import Sample, Twist, Vector3

    from ipyros.core.guard import Gate, RuleWatch
    from ipyros.core.rules import rule
    from ipyros.processes.keeper import KeptGuard

    spec = {"topic": "/cmd_vel", "rules": [rule("min(/scan.gains) < 0.5", limit={"linear.x": (-0.2, 0.2)}).as_data()],
            "inputs": {"/scan": "unit_msgs/Sample"}}
    sent: list = []
    logged: list[str] = []
    guard = KeptGuard.__new__(KeptGuard)  # its gate, rules and publisher only: no stop process, no ROS
    guard.topic, guard._log, guard._stop, guard.repeat = "/cmd_vel", logged.append, Twist(), 100.0
    guard.rules = KeptGuard._ruleset(spec, Twist, "guard /cmd_vel")
    guard.heard, guard.watch, guard._arm_by = {}, RuleWatch(guard.repeat), 0.0
    guard.gate = Gate("/cmd_vel", Twist, {}, {}, "clamp", guard.stop_message, lambda: False, lambda: None,
                      lambda text: None, rules=guard.rules, heard=lambda: guard.heard)
    guard._out = SimpleNamespace(write=sent.append)
    hear = guard._hearing("/scan")
    hear(Sample(gains=[2.0]))
    guard.command(Twist(linear=Vector3(x=0.4)))
    hear(Sample(gains=[0.3]))
    assert [m.linear.x for m in sent] == [0.4, 0.0] and len(logged) == 1
    for later in (1.0, 2.0, 3.0):  # looks a second and more apart: each would send it, if the rules still held it
        hear(Sample(gains=[0.3]))
        assert guard._judge(time.monotonic() + later) is None
    assert [m.linear.x for m in sent] == [0.4, 0.0], "the stop message passed its gate: it is the last command now"
    hear(Sample(gains=[2.0]))
    assert len(logged) == 1 and guard.watch.ruling == ""


@pytest.mark.parametrize("ros, argv, why", [
    ("1", ["--discovery-server", "11811"], "--discovery-server is ROS 2's; ROS 1 finds nodes through its master"),
    ("2", ["--discovery-server", "0"], "--discovery-server 0: give a UDP port"),
    ("2", ["--discovery-server", "70000"], "give a UDP port (1 to 65535"),
])
def test_a_discovery_server_asked_wrong_is_one_line(monkeypatch, capsys, ros, argv, why):
    from ipyros.machine import main

    monkeypatch.setenv("IPYROS_ROS", ros)
    assert main(["--name", "robot1", *argv]) == 2
    err = capsys.readouterr().err
    assert why in err and err.count("\n") == 1, err


def test_a_guard_placed_with_rules_acts_only_once_its_sensors_are_heard():
    """Placed again on a running robot, a guard with rules sends nothing, not even "not heard yet"'s stop message,
    until each input has been heard or INPUTS_FIRST_WAIT has passed; then it judges (one never heard: the stop)."""
    import time
    from types import SimpleNamespace

    from unit_msgs.msg import Sample, Twist, Vector3

    from ipyros.core.guard import Gate, RuleWatch
    from ipyros.core.rules import rule
    from ipyros.processes.keeper import KeptGuard

    spec = {"topic": "/cmd_vel", "rules": [rule("min(/scan.gains) < 0.5", stop=True).as_data()],
            "inputs": {"/scan": "unit_msgs/Sample", "/bump": "unit_msgs/Sample"}, "stale": {"/bump": 1.0}}

    def placed() -> tuple[KeptGuard, list]:
        sent: list = []
        guard = KeptGuard.__new__(KeptGuard)  # its gate, rules and publisher only: no stop process, no ROS
        guard.topic, guard._log, guard._stop, guard.repeat = "/cmd_vel", lambda text: None, Twist(), 10.0
        guard.rules = KeptGuard._ruleset(spec, Twist, "guard /cmd_vel")
        guard.heard, guard.watch, guard._arm_by = {}, RuleWatch(guard.repeat), time.monotonic() + 60.0
        guard.gate = Gate("/cmd_vel", Twist, {}, {}, "clamp", guard.stop_message, guard.holding, lambda: None,
                          lambda text: None, rules=guard.rules, heard=lambda: guard.heard)
        guard._out = SimpleNamespace(write=sent.append)
        guard.shared, guard.lost, guard.lease = SimpleNamespace(estopped=False), None, SimpleNamespace(first=False)
        guard._replacing, guard.sentinel, guard._stopped_at = None, None, -float("inf")
        return guard, sent

    guard, sent = placed()
    closed: list[bool] = []
    tended: list[float] = []
    guard.replace(SimpleNamespace(close=lambda hold: closed.append(hold), tend=lambda now: tended.append(now) or
                                  "guard /cmd_vel: the old one's word"))  # placed again: the old one keeps it
    guard._hearing("/scan")(Sample(gains=[2.0]))  # one input heard, the other not yet: no stop message for it
    said = guard.tend(time.monotonic())
    assert closed == [], "not armed yet: the guard it replaces keeps the robot"
    assert len(tended) == 1 and said == "guard /cmd_vel: the old one's word", "and it is tended as before, its rules"
    guard.command(Twist(linear=Vector3(x=0.4)))
    assert sent == [] and not guard.armed and guard.watch.ruling == "", "nothing judged, nothing said"
    assert guard.check(Twist(linear=Vector3(x=0.4))).send is None, "a relay in the keeper sends nothing either"
    guard.shared.estopped = True
    guard.command(Twist(linear=Vector3(x=0.4)))
    assert [m.linear.x for m in sent] == [0.0], "e-stopped: the stop message, armed or not"
    guard.shared.estopped, sent[:] = False, []
    guard._hearing("/bump")(Sample(gains=[2.0]))
    assert guard.armed, "armed as soon as both were heard"
    guard.tend(time.monotonic())
    assert closed == [False] and len(tended) == 1, "armed: it takes over, the old one quits"
    guard.command(Twist(linear=Vector3(x=0.4)))
    assert [m.linear.x for m in sent] == [0.4]
    quiet, sent = placed()
    quiet._arm_by = time.monotonic() - 0.01  # its wait is over, a sensor never heard: it acts, and stops the robot
    quiet.command(Twist(linear=Vector3(x=0.4)))
    assert quiet.armed and [m.linear.x for m in sent] == [0.0]
