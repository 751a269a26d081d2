"""ROS 1 services in the session: a DSL node's service, a relay of a basenode's service, a client of one; and
whether a service is served in this process."""

from __future__ import annotations

import io
from typing import Any, Optional

import rospy

from ..core.errors import HandlerError
from ..core.msgbuild import explain_unsendable
from ..core.slots import HandlerSlot
from . import rospy_inside

__all__ = ["ServiceRelay", "ServiceServer", "served_here", "service_proxy"]


class ServiceServer:
    """A service whose handler is a :class:`HandlerSlot` (it returns the response)."""

    def __init__(self, name: str, cls: type, slot: HandlerSlot) -> None:
        self.name, self.cls, self.slot = name, cls, slot
        self._service = rospy.Service(name, cls, self._serve)

    def _serve(self, request: Any) -> Any:
        # A wrong answer is checked here, where the session can be told and %status count it;
        # rospy would only log it and send the caller an error.
        ok, result = self.slot.run(request)
        if not ok:
            raise rospy.ServiceException(f"the handler of {self.name} raised an exception (the ipyros session shows it)")
        response_class = self.cls._response_class  # type: ignore[attr-defined]
        try:
            response = rospy_inside.response_of(result, response_class)
            response.serialize(io.BytesIO())
        except Exception as error:  # noqa: BLE001 - whatever the value, the caller gets one line
            detail = str(error).splitlines()[0][:120] if str(error) else type(error).__name__
            if isinstance(result, response_class):
                detail = explain_unsendable(result) or detail
            problem = HandlerError(f"the handler of service {self.name} returned {_short(result)}, which is not a "
                                   f"{response_class.__name__} ({detail}); return {response_class.__name__}(...) "
                                   "with its fields filled")
            self.slot.fail(problem)
            raise rospy.ServiceException(str(problem)) from None
        return response

    def close(self) -> None:
        self._service.shutdown("removed")


def served_here(name: str, uri: str) -> Optional[str]:
    """The type of ``name`` if this process serves it at ``uri``: no probe through our own socket (under load
    the server's thread, the session's own, could miss the probe's timeout and the type show as "?")."""
    service = rospy_inside.service_manager().get_service(name)
    return service.service_class._type if service is not None and service.uri == uri else None


class ServiceRelay:
    """Serve ``target`` by calling ``source`` (a basenode's service) and returning its answer."""

    def __init__(self, source: str, target: str, cls: type) -> None:
        self.source, self.target, self.cls = source, target, cls
        self._proxy = rospy.ServiceProxy(source, cls)
        self._service = rospy.Service(target, cls, self._proxy.call)

    def close(self) -> None:
        self._service.shutdown("removed")
        self._proxy.close()


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def service_proxy(name: str, cls: type) -> rospy.ServiceProxy:
    """A client for ``name``; call it like a function."""
    return rospy.ServiceProxy(name, cls)
