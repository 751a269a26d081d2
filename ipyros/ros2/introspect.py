"""What ``ros2 service`` and ``ros2 param`` ask of ROS 2, for ``%services``, ``%call``, ``%params`` and ``%param``.

Everything goes out from the process's caller node (:meth:`ProcessNode.caller`), whose
executor spins on a thread of its own, and the prompt waits on the answer with a timeout:
a node that does not answer is said so in one line, never a hung prompt. A node's
parameters are read and set through its parameter services, as ``ros2 param`` does; their
global names here are ``/ns/node/key``, as ROS 1 spells a private parameter.
"""

from __future__ import annotations

import re
import threading
from typing import Any, Optional

from ..core import msgtypes
from ..core.errors import IpyrosError
from ..core.msgbuild import conform
from .runtime import ProcessNode

__all__ = ["call", "node_params", "service_type", "set_node_param"]


def _wait(future: Any, timeout: float, what: str) -> Any:
    done = threading.Event()
    future.add_done_callback(lambda _: done.set())
    if not done.wait(timeout):
        future.cancel()
        raise IpyrosError(f"{what} did not answer within {timeout:g} s; is it alive? (%nodes lists the live ones)")
    if future.exception() is not None:
        raise IpyrosError(f"{what} failed: {future.exception()}")
    return future.result()


def service_type(process: ProcessNode, name: str) -> str:
    """The type (``pkg/Service``, the session's one spelling) of the live service ``name``, from discovery."""
    for found, types in process.graph().get_service_names_and_types():
        if found == name:
            return msgtypes.short_name(types[0])
    raise IpyrosError(f"no live service {name}; %services lists them")


def call(process: ProcessNode, name: str, cls: type, request: Any, timeout: float) -> Any:
    """Call the service ``name`` with ``request``; its response."""
    return _call_once(process, name, cls, conform(request), timeout,
                      f"service {name} did not come up within {timeout:g} s; %services lists the live ones")


def _call_once(process: ProcessNode, name: str, cls: type, request: Any, timeout: float, absent: str) -> Any:
    """One call of ``name`` from the caller node, through a client made for it; ``absent``: what to say when no
    server comes up within ``timeout``."""
    caller = process.caller()
    client = caller.create_client(cls, name)
    try:
        if not client.wait_for_service(timeout_sec=timeout):
            raise IpyrosError(absent)
        return _wait(client.call_async(request), timeout, f"service {name}")
    finally:
        caller.destroy_client(client)


def _request(process: ProcessNode, node: str, kind: str, timeout: float, **fields: Any) -> Any:
    """One call to the parameter service ``kind`` (ListParameters, ...) of ``node``; its response."""
    import rcl_interfaces.srv

    cls = getattr(rcl_interfaces.srv, kind)
    service = node.rstrip("/") + "/" + "_".join(w.lower() for w in re.findall("[A-Z][a-z]*", kind))
    return _call_once(process, service, cls, cls.Request(**fields), timeout,
                      f"{node} has no parameter services answering; is it a ROS 2 node, and alive? (%nodes lists them)")


def ping(process: ProcessNode, node: str, timeout: float = 2.0) -> None:
    """One call that every rclpy node answers: its parameter services' list, else its type description service (a
    node may run without parameter services, as the session's own nodes do until they have a parameter)."""
    base = node.rstrip("/")
    namespace, name = base.rsplit("/", 1)
    try:
        services = {found for found, _ in process.graph().get_service_names_and_types_by_node(name, namespace or "/")}
    except Exception:  # noqa: BLE001 - not in the graph (rclpy raises its own NodeNameNonExistentError): said below
        services = set()
    if f"{base}/list_parameters" in services or f"{base}/get_type_description" not in services:
        _request(process, node, "ListParameters", timeout)
        return
    from type_description_interfaces.srv import GetTypeDescription

    _call_once(process, f"{base}/get_type_description", GetTypeDescription, GetTypeDescription.Request(), timeout,
               f"{node} has no services answering; is it a ROS 2 node, and alive? (%nodes lists them)")


def node_params(process: ProcessNode, node: str, timeout: float = 3.0) -> dict[str, Any]:
    """The parameters of the live node ``node`` (``/ns/name``) and their values, by key."""
    from rclpy.parameter import parameter_value_to_python

    names = list(_request(process, node, "ListParameters", timeout).result.names)
    values = _request(process, node, "GetParameters", timeout, names=names).values if names else []
    return {name: parameter_value_to_python(value) for name, value in zip(names, values)}


def set_node_param(process: ProcessNode, node: str, key: str, value: Any, timeout: float = 3.0) -> None:
    """Set ``key`` of the live node ``node`` to ``value``; its refusal as a one-line error."""
    from rclpy.parameter import Parameter

    parameter = Parameter(key, value=list(value) if isinstance(value, tuple) else value).to_parameter_msg()
    (result,) = _request(process, node, "SetParameters", timeout, parameters=[parameter]).results
    if not result.successful:
        raise IpyrosError(f"{node} refused {key} = {value!r}: {result.reason or 'no reason given'}")


#: rcl_interfaces/ParameterType codes by the names ros2 param describe prints.
_PARAMETER_TYPES = {1: "bool", 2: "integer", 3: "double", 4: "string", 5: "byte array", 6: "bool array",
                    7: "integer array", 8: "double array", 9: "string array"}


def describe_node_param(process: ProcessNode, node: str, key: str, timeout: float = 3.0) -> dict[str, Any]:
    """What ``ros2 param describe`` says of ``key``: its type, description, whether read-only, its range."""
    (found,) = _request(process, node, "DescribeParameters", timeout, names=[key]).descriptors
    described: dict[str, Any] = {"type": _PARAMETER_TYPES.get(found.type, "not set")}
    if found.description:
        described["description"] = found.description
    if found.read_only:
        described["read only"] = True
    for kind in ("floating_point_range", "integer_range"):
        for span in getattr(found, kind):
            described["range"] = f"{span.from_value} to {span.to_value}" + (f" by {span.step}" if span.step else "")
    if found.additional_constraints:
        described["constraints"] = found.additional_constraints
    return described


#: The transitions a lifecycle manager asks for, by the labels ``ros2 lifecycle set`` takes.
LIFECYCLE_TRANSITIONS = ("configure", "cleanup", "activate", "deactivate", "shutdown")


def lifecycle(process: ProcessNode, node: str, transition: Optional[str] = None,
              timeout: float = 5.0) -> tuple[str, list[str]]:
    """A lifecycle node's state and the transitions it offers now, after ``transition`` if one is given (as
    ``ros2 lifecycle get``/``set``): through its ``~/get_state``, ``~/get_available_transitions`` and
    ``~/change_state`` services."""
    from lifecycle_msgs.msg import Transition
    from lifecycle_msgs.srv import ChangeState, GetAvailableTransitions, GetState

    base = node.rstrip("/")
    if not any(name == f"{base}/get_state" for name, _ in process.graph().get_service_names_and_types()):
        raise IpyrosError(f"{node} is not a lifecycle node (it has no {base}/get_state service); %nodes lists "
                          "the nodes")
    if transition is not None:
        offered = _lifecycle_call(process, f"{base}/get_available_transitions", GetAvailableTransitions,
                                  GetAvailableTransitions.Request(), timeout).available_transitions
        labels = [t.transition.label for t in offered]
        if transition not in labels:
            raise IpyrosError(f"{node} cannot {transition} now; it offers {', '.join(labels) or 'nothing'}")
        changed = _lifecycle_call(process, f"{base}/change_state", ChangeState,
                                  ChangeState.Request(transition=Transition(label=transition)), timeout)
        if not changed.success:
            raise IpyrosError(f"{node} refused to {transition} (its on_{transition} callback failed)")
    state = _lifecycle_call(process, f"{base}/get_state", GetState, GetState.Request(), timeout).current_state
    offered = _lifecycle_call(process, f"{base}/get_available_transitions", GetAvailableTransitions,
                              GetAvailableTransitions.Request(), timeout).available_transitions
    return state.label, [t.transition.label for t in offered]


def _lifecycle_call(process: ProcessNode, service: str, cls: type, request: Any, timeout: float) -> Any:
    return _call_once(process, service, cls, request, timeout,
                      f"{service} does not answer; is the node alive? (%nodes lists them)")
