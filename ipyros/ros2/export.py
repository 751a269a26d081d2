"""How a node is exported on ROS 2: one rclpy script that needs no ipyros.

The flavour that :func:`ipyros.files.export.export` writes with (``backend.export_flavour()``):
an rclpy node (``#!`` this Python, which has rclpy), its endpoints with the QoS they were
declared with, byte relays (``raw=True``), service relays that call out from a caller node
of their own, and the basenode started with ``--ros-args``; or the same node as the module of an
ament_python package (:mod:`.package`). No ROS package is imported here.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any, Iterable

from ..core import plan as planning
from ..core.errors import IpyrosError
from . import package as ament
from .nodes import command
from .endpoints import RESULT_SETTLE

__all__ = ["RclpyScript"]

_HANDLE_ROS2 = '''
class NodeHandle:
    """Stands in for the ipyros node the handlers were written for: write(topic, msg) publishes."""

    def __init__(self):
        self.node = None  # the rclpy node, made by main()
        self.publishers = {}  # resolved topic name -> rclpy publisher, filled in by main()

    def write(self, topic, msg):
        self.publishers[self.node.resolve_topic_name(topic)].publish(msg)

    @property
    def params(self):
        """The node's parameters by name, as nd.params gave them (read-only here)."""
        return {name: p.value for name, p in self.node.get_parameters_by_prefix("").items()}
'''

_RELAY_ROS2 = '''
def relay(node, source, target, msg_class):
    """Forward source to target unchanged: serialized bytes, never parsed (reliable, volatile)."""
    pub = node.create_publisher(msg_class, target, qos())  # made now: nothing lost at start
    return node.create_subscription(msg_class, source, pub.publish, qos(), raw=True)
'''

_SERVICE_RELAY_ROS2 = '''
def service_relay(node, caller, source, target, srv_class):
    """Serve target by calling source, from the caller node (spun on a thread of its own, so the
    answer is taken while this callback waits for it); a caller gets the empty response after 10 s."""
    client = caller.create_client(srv_class, source)

    def answer(request, response):
        done = threading.Event()
        future = client.call_async(request)
        future.add_done_callback(lambda _: done.set())
        return future.result() if done.wait(10.0) and future.result() is not None else response

    return node.create_service(srv_class, target, answer)
'''

_QOS_ROS2 = '''
def qos(depth=1000, best_effort=False, transient_local=False):
    """As ipyros declares endpoints: reliable, volatile, 1000 deep, unless the node said otherwise."""
    return QoSProfile(depth=depth,
                      reliability=ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL if transient_local else DurabilityPolicy.VOLATILE)
'''


_ACTIONS_ROS2 = '''
class ActionCall:
    """What an action handler gets beside the goal, as ipyros gave it: feedback(msg), cancelled, forward(goal)."""

    def __init__(self, handle, feedback_class, forward_client):
        self._handle, self._feedback_class, self._client = handle, feedback_class, forward_client
        self.forwarded = None  # the final status of a forwarded goal

    def feedback(self, msg):
        self._handle.publish_feedback(self._feedback_class(**msg) if isinstance(msg, dict) else msg)

    @property
    def cancelled(self):
        return self._handle.is_cancel_requested

    def forward(self, goal):
        """Send goal to the basenode's own server; its feedback goes on to the client; its result comes back."""
        if not getattr(self._client, "settled", False):  # its first goal
            self._client.wait_for_server()
            time.sleep(0.5)  # we see the server; give it its moment to see us, or its answer could be lost
            self._client.settled = True
        tries = []
        for attempt in range(5):  # right after discovery the server's reply can be lost: sent again, as ROS 2
            # clients do; only the latest attempt's feedback goes on (an earlier goal may run all the same)
            tries.append(attempt)
            accepted, ended = threading.Event(), threading.Event()
            sent = self._client.send_goal_async(
                goal, feedback_callback=lambda m, k=attempt: self.feedback(m.feedback) if tries[-1] == k else None)
            sent.add_done_callback(lambda _: accepted.set())
            if accepted.wait(10.0):
                break
        else:
            raise RuntimeError("the basenode's action server did not answer the goal")  # aborted, not hung
        result = sent.result().get_result_async()
        result.add_done_callback(lambda _: ended.set())
        asked = False
        while not ended.wait(0.05):
            if self.cancelled and not asked:
                asked = True
                sent.result().cancel_goal_async()
        self.forwarded = result.result().status
        return result.result().result


def serve_action(node, caller, name, action_class, handler, takes_action, forward_to=None):
    """Serve action name: each goal runs handler on a thread of its own (the executor only awaits it)."""
    client = ActionClient(caller, action_class, forward_to) if forward_to else None

    def work(handle, done):
        call = ActionCall(handle, action_class.Feedback, client)
        try:
            result = handler(handle.request, call) if takes_action else handler(handle.request)
            result = action_class.Result(**result) if isinstance(result, dict) else result or action_class.Result()
        except Exception as error:  # as ipyros does: the goal is aborted, the node goes on
            node.get_logger().error(f"the handler of action {name} failed: {error!r}")
            handle.abort()
            done.set_result(action_class.Result())
            return
        if handle.is_cancel_requested:
            handle.canceled()
        elif call.forwarded in (GoalStatus.STATUS_ABORTED, GoalStatus.STATUS_CANCELED):
            handle.abort()
        else:
            handle.succeed()
        done.set_result(result)

    async def execute(handle):
        done = Future(executor=node.executor)
        threading.Thread(target=work, args=(handle, done), daemon=True).start()
        return await done

    return ActionServer(node, action_class, name, execute_callback=execute,
                        cancel_callback=lambda handle: CancelResponse.ACCEPT)


def action_relay(node, caller, source, target, action_class):
    """Relay action source as target: its services answered by calling source's from the caller node (each
    call on a thread of the executor's: a result comes when its goal ends), its two topics as bytes."""
    group = ReentrantCallbackGroup()
    for part, srv_class, patience in (("send_goal", action_class.Impl.SendGoalService, 10.0),
                                      ("cancel_goal", CancelGoal, 10.0),
                                      ("get_result", action_class.Impl.GetResultService, None)):
        client = caller.create_client(srv_class, f"{source}/_action/{part}")
        settle = RESULT_SETTLE if part == "get_result" else 0.0

        def answer(request, response, client=client, patience=patience, settle=settle):
            done = threading.Event()
            future = client.call_async(request)
            future.add_done_callback(lambda _: done.set())
            if not done.wait(patience) or future.result() is None:
                return response
            # The goal's last feedback may still be on its way (two DDS topics keep no order between them),
            # and a client drops feedback that comes after the result: it passes first.
            time.sleep(settle)
            return future.result()

        node.create_service(srv_class, f"{target}/_action/{part}", answer, callback_group=group)
    # Feedback and status are read by the caller, whose one thread also takes the results: a goal's
    # last feedback goes on before its result (an rclpy client drops feedback that comes after it).
    feedback = node.create_publisher(action_class.Impl.FeedbackMessage, f"{target}/_action/feedback", qos())
    caller.create_subscription(action_class.Impl.FeedbackMessage, f"{source}/_action/feedback", feedback.publish,
                               qos(), raw=True)
    status = node.create_publisher(GoalStatusArray, f"{target}/_action/status", qos_profile_action_status_default)
    caller.create_subscription(GoalStatusArray, f"{source}/_action/status", status.publish,
                               qos_profile_action_status_default, raw=True)
'''


def _has(script: Any, *kinds: type) -> bool:
    return any(isinstance(s, kinds) for s in script.plan())


class RclpyScript:
    """The rclpy flavour of an exported script (see :class:`ipyros.files.export.Script`, which asks it)."""

    LIBRARY = "rclpy"
    #: How a guard's rules subscribe their inputs (best effort: it hears a sensor's publisher of either QoS).
    LISTEN = "lambda topic, cls, hear: node.create_subscription(cls, topic, hear, qos(10, best_effort=True))"
    SCRIPT_NAMES = {"rclpy", "os", "signal", "subprocess", "sys", "threading", "NodeHandle", "relay", "qos",
                    "service_relay", "main", "BASENODE", "BASENODE_ENV", "start_basenode", "stop_basenode",
                    "QoSProfile", "ReliabilityPolicy", "DurabilityPolicy", "SingleThreadedExecutor",
                    "MultiThreadedExecutor", "ActionCall", "serve_action", "action_relay", "ActionClient",
                    "ActionServer", "CancelResponse", "Future", "GoalStatus", "GoalStatusArray", "CancelGoal",
                    "ReentrantCallbackGroup", "qos_profile_action_status_default", "time"}
    #: What a wrapped action is remapped by: its name (ROS 2 remaps an action as a whole).
    action_parts = ("",)

    #: The basenode's command line, as the backend runs it (rosrun's lookup, or ros2 run's).
    base_command = staticmethod(command)

    @staticmethod
    def shebang() -> str:
        return f"#!{sys.executable}"

    @staticmethod
    def about(script: Any) -> str:
        model = script.model
        lines = [f"{model.name}: an rclpy node exported by ipyros from the DSL node {planning.node_fullname(model)}.",
                 ""]
        if script.package:
            return "\n".join(lines + [f"It needs no ipyros: ros2 run {script.package} {model.name}, or ros2 launch "
                                       f"{script.package} {model.name}.launch.xml"
                                       + (" (which starts its basenode too)." if model.base is not None else ".")])
        lines.append(f"It needs no ipyros: ./{Path(script.path).name} [--ros-args -r from:=to -p param:=value ...]")
        if model.base is not None:
            lines.append(f"It runs its basenode {model.base.package or model.base.executable} itself, remapped as "
                         "ipyros ran it, and stops it on exit.")
        return "\n".join(lines)

    @staticmethod
    def stdlib(script: Any, starts_base: bool) -> list[str]:
        found = ["os", "signal", "subprocess", "sys", "threading"] if starts_base else ["sys", "threading"]
        return found + (["time"] if _has(script, planning.ActionServerSpec, planning.ActionRelaySpec) else [])

    @staticmethod
    def before_imports(script: Any) -> list[str]:
        return []

    @staticmethod
    def imports(script: Any) -> list[str]:
        executors = "MultiThreadedExecutor, SingleThreadedExecutor" if _has(script, planning.ActionRelaySpec) \
            else "SingleThreadedExecutor"
        found = [f"from rclpy.executors import ExternalShutdownException, {executors}",
                 "from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy"]
        if _has(script, planning.ActionServerSpec, planning.ActionRelaySpec):
            found += ["from action_msgs.msg import GoalStatus, GoalStatusArray",
                      "from action_msgs.srv import CancelGoal",
                      "from rclpy.action import ActionClient, ActionServer, CancelResponse",
                      "from rclpy.callback_groups import ReentrantCallbackGroup",
                      "from rclpy.qos import qos_profile_action_status_default",
                      "from rclpy.task import Future"]
        return found

    @staticmethod
    def handle(script: Any) -> list[str]:
        return [_QOS_ROS2.strip("\n"), _HANDLE_ROS2.strip("\n")]

    @staticmethod
    def helpers(script: Any) -> list[str]:
        found = [_RELAY_ROS2] if _has(script, planning.RelaySpec) else []
        if _has(script, planning.ServiceRelaySpec):
            found.append(_SERVICE_RELAY_ROS2)
        if _has(script, planning.ActionServerSpec, planning.ActionRelaySpec):
            found.append(f"# s an action's result waits: its last feedback goes first (two DDS topics keep no order)\n"
                         f"RESULT_SETTLE = {RESULT_SETTLE!r}\n{_ACTIONS_ROS2}")
        return [h.strip("\n") for h in found]

    @staticmethod
    def main(script: Any) -> list[str]:
        model, handle = script.model, script.writers[0]
        specs = script.plan()
        relays_services = any(isinstance(s, (planning.ServiceRelaySpec, planning.ActionRelaySpec)) or
                              isinstance(s, planning.ActionServerSpec) and s.forward for s in specs)
        # an action's result is answered when its goal ends: its relay waits on a thread of the executor's
        executor = "MultiThreadedExecutor" if _has(script, planning.ActionRelaySpec) else "SingleThreadedExecutor"
        lines = ["rclpy.init(args=sys.argv)  # --ros-args: remaps, -p key:=value",
                 f"node = {handle}.node = rclpy.create_node({model.name!r}, "
                 f"namespace={model.namespace.rstrip('/') or '/'!r})"]
        lines += [f"node.declare_parameter({key!r}, {value!r})  # -p {key}:=... on the command line wins"
                  for key, value in model.params.items()]
        writes_to = script.writes_to()
        if relays_services:
            lines += ["caller = rclpy.create_node(f'_{node.get_name()}_caller', namespace=node.get_namespace())",
                      "calls = SingleThreadedExecutor()", "calls.add_node(caller)",
                      "threading.Thread(target=calls.spin, daemon=True).start()"]
        for spec in specs:
            if isinstance(spec, planning.PublishSpec):
                publisher = (f"node.create_publisher({script.cls(spec.type)}, {spec.topic!r}, "
                             f"{_qos_call(spec.qos, spec.latch)})")
                guarded = script.guard(spec.topic, f"{publisher}.publish")
                lines.append(f"{handle}.publishers[node.resolve_topic_name({writes_to[spec.topic]!r})] = "
                             f"{guarded or publisher}")
            elif isinstance(spec, planning.RelaySpec) and script.model.guard(spec.target) is not None:
                cls = script.cls(spec.type)  # a guarded relay reads the values it must check
                guarded = script.guard(spec.target, f"node.create_publisher({cls}, {spec.target!r}, qos()).publish")
                lines.append(f"node.create_subscription({cls}, {spec.source!r}, {guarded}.publish, qos())")
            elif isinstance(spec, planning.SubscribeSpec):
                lines.append(f"node.create_subscription({script.cls(spec.type)}, {spec.topic!r}, "
                             f"{script.names[spec.slot]}, {_qos_call(spec.qos)})")
            elif isinstance(spec, planning.RelaySpec):
                lines.append(f"relay(node, {spec.source!r}, {spec.target!r}, {script.cls(spec.type)})")
            elif isinstance(spec, planning.TimerSpec):
                name = script.names[spec.slot]
                call = f"lambda: {name}(None)" if script.takes_event(spec.slot) else name
                if spec.oneshot:
                    lines += [f"once = node.create_timer({spec.period!r}, lambda: (once.cancel(), ({call})()))"]
                else:
                    lines.append(f"node.create_timer({spec.period!r}, {call})")
            elif isinstance(spec, planning.ServiceSpec):
                lines.append(f"node.create_service({script.cls(spec.type, 'srv')}, {spec.name!r}, "
                             f"lambda request, response: {script.names[spec.slot]}(request))")
            elif isinstance(spec, planning.ActionServerSpec):
                lines.append(f"serve_action(node, {'caller' if spec.forward else 'None'}, {spec.name!r}, "
                             f"{script.cls(spec.type, 'action')}, {script.names[spec.slot]}, "
                             f"{script.takes_action(spec.slot)!r}, {spec.forward!r})")
            elif isinstance(spec, planning.ActionRelaySpec):
                lines.append(f"action_relay(node, caller, {spec.source!r}, {spec.target!r}, "
                             f"{script.cls(spec.type, 'action')})")
            else:  # ServiceRelaySpec
                lines.append(f"service_relay(node, caller, {spec.source!r}, {spec.target!r}, "
                             f"{script.cls(spec.type, 'srv')})")
        lines += [f"executor = {executor}()", "executor.add_node(node)"]
        if script.starts_base:
            lines.append("basenode = start_basenode()")
        lines += ["try:", "    executor.spin()", "except (KeyboardInterrupt, ExternalShutdownException):",
                  "    pass", "finally:"]
        if script.starts_base:
            lines.append("    stop_basenode(basenode)")
        return lines + ["    rclpy.try_shutdown()"]

    # -- the package form: an ament_python package (:mod:`.package`) ------------------------------------
    @staticmethod
    def script_file(package: str, node: str) -> tuple[str, int]:
        """Where the package holds the node: a module of the package's Python package, its ``main()`` the
        console script's entry point."""
        return f"{package}/{node}.py", 0o644

    @staticmethod
    def package_files(script: Any, package: str) -> dict[str, tuple[str, int]]:
        return ament.package_files(script, package)

    @staticmethod
    def manifest(script: Any, package: str, files: Iterable[str], mark: str) -> str:
        return ament.manifest(script, package, files, mark)

    @staticmethod
    def cpp_package(script: Any, package: str) -> Any:
        raise IpyrosError("C++ export is made for ROS 1 (roscpp); on ROS 2 export Python: nd.export('my_pkg') "
                          "writes an ament_python package (rclcpp is not installable here to build and test it)")

    cpp_said = cpp_package


def _qos_call(qos: Any, latch: bool = False) -> str:
    """The script's ``qos(...)`` call for a declaration's QoS (see :mod:`ipyros.core.qos`)."""
    words = []
    if qos.depth is not None or latch or qos.latched:
        words.append(f"depth={qos.depth or (1 if latch or qos.latched else 1000)}")
    if qos.reliability == "best_effort":
        words.append("best_effort=True")
    if latch or qos.latched:
        words.append("transient_local=True")
    return f"qos({', '.join(words)})"


