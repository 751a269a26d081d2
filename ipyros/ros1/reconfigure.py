"""dynamic_reconfigure servers (ROS 1): their parameters' types and ranges for ``%params``, and setting through them.

A node tuned at run time serves ``<node>/set_parameters`` and publishes its parameters'
descriptions, latched, on ``<node>/parameter_descriptions``. It mirrors their values on the
parameter server, but reads that only at start: a value must be set through the server
(as ``rosrun dynamic_reconfigure dynparam set`` does) to reach the running node.
"""

from __future__ import annotations

from typing import Any, Mapping, Optional

from ..core.errors import IpyrosError

__all__ = ["DESCRIPTIONS_TYPE", "describe", "is_server", "range_text", "servers", "set_value"]

DESCRIPTIONS_TYPE = "dynamic_reconfigure/ConfigDescription"
_SUFFIX = "/parameter_descriptions"


def servers(topics: Mapping[str, str], namespace: str = "/") -> list[str]:
    """The dynamic_reconfigure servers under ``namespace``, by the descriptions topic each publishes
    (``topics``: the graph's ``{topic: type}``)."""
    prefix = namespace.rstrip("/") + "/"
    return sorted(topic[: -len(_SUFFIX)] for topic, type_name in topics.items()
                  if type_name == DESCRIPTIONS_TYPE and topic.endswith(_SUFFIX) and topic.startswith(prefix))


def is_server(topics: Mapping[str, str], node: str) -> bool:
    """Whether ``node`` is a dynamic_reconfigure server (it publishes its descriptions)."""
    return topics.get(node + _SUFFIX) == DESCRIPTIONS_TYPE


def _client(server: str, timeout: float) -> Any:
    from dynamic_reconfigure.client import Client

    try:
        return Client(server, timeout=timeout)
    except Exception as error:  # noqa: BLE001 - rospy's ROSException, a timeout: one line either way
        raise IpyrosError(f"the dynamic_reconfigure server {server} did not answer in {timeout:g} s ({error}); "
                          "is it running?") from None


def describe(server: str, timeout: float = 5.0) -> dict[str, dict[str, Any]]:
    """``{global parameter name: {type, min, max, default, description}}`` of a server's parameters."""
    client = _client(server, timeout)
    try:
        found = client.get_parameter_descriptions(timeout=timeout) or []
    finally:
        client.close()
    return {f"{server}/{p['name']}": {key: p.get(key) for key in ("type", "min", "max", "default", "description")}
            for p in found}


def set_value(server: str, key: str, value: Any, timeout: float = 5.0) -> Optional[Any]:
    """Set ``key`` through ``server`` (it checks and clamps the value, and the node's callback runs);
    the value the server keeps, or None when ``key`` is not one of its parameters."""
    client = _client(server, timeout)
    try:
        if key not in {p["name"] for p in client.get_parameter_descriptions(timeout=timeout) or []}:
            return None
        config = client.update_configuration({key: value})
    except Exception as error:  # noqa: BLE001 - dynamic_reconfigure's own words, made one line
        raise IpyrosError(f"{server} refused {key}={value!r}: {str(error).strip().splitlines()[0]}") from None
    finally:
        client.close()
    return config[key] if config and key in config else value


def range_text(description: Mapping[str, Any]) -> str:
    """``int -10..10`` / ``double 0.0..`` / ``str``: a parameter's type and range, as %params shows them."""
    kind, low, high = description.get("type"), description.get("min"), description.get("max")
    if kind in ("int", "double") and low is not None and high is not None:
        low_text = "" if low in (float("-inf"), -2 ** 31) else f"{low:g}"
        high_text = "" if high in (float("inf"), 2 ** 31 - 1) else f"{high:g}"
        return f"{kind} {low_text}..{high_text}" if low_text or high_text else str(kind)
    return str(kind or "")
