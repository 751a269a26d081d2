"""Quality of service of a declared topic, as plain data, the same on both ROS.

ROS 2 matches a publisher and a subscription only if their QoS are compatible: a
reliable subscription gets nothing from a best-effort publisher, a transient-local one
nothing from a volatile publisher. So the QoS of a declaration is part of the model:
``new.subscribe("/scan", h, qos="sensor_data")``. What is given is kept; what is left
out is the backend's default (reliable, volatile, deep enough for a burst).

On ROS 1 there is one transport, TCP, reliable: only durability has a meaning there
(transient-local is a latched topic); depth and reliability are kept in the model, so
that a node made on one ROS loads on the other, and otherwise unused.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from typing import Any, Optional

from .errors import DeclarationError

__all__ = ["Qos", "PROFILES", "parse", "from_model"]

RELIABILITY = ("reliable", "best_effort")
DURABILITY = ("volatile", "transient_local")


@dataclass(frozen=True)
class Qos:
    """Depth, reliability and durability; ``None`` leaves a field to the backend's default."""

    depth: Optional[int] = None
    reliability: Optional[str] = None
    durability: Optional[str] = None

    @property
    def latched(self) -> bool:
        return self.durability == "transient_local"

    def to_model(self) -> Optional[dict[str, Any]]:
        """The fields given, for the model file; None when nothing was."""
        given = {k: v for k, v in asdict(self).items() if v is not None}
        return given or None

    def __str__(self) -> str:
        parts = [self.reliability, self.durability, None if self.depth is None else f"depth {self.depth}"]
        return " ".join(p.replace("_", "-") for p in parts if p) or "default"


#: Named profiles, as rclpy's presets (``qos_profile_sensor_data``, ...) and ROS 1's latch.
PROFILES: dict[str, Qos] = {
    "default": Qos(10, "reliable", "volatile"),
    "sensor_data": Qos(5, "best_effort", "volatile"),
    "latched": Qos(1, "reliable", "transient_local"),
    "reliable": Qos(reliability="reliable"),
    "best_effort": Qos(reliability="best_effort"),
    "transient_local": Qos(durability="transient_local"),
}


def parse(value: Any, where: str) -> Qos:
    """``qos=`` as given: a profile name, a depth, a dict of fields, or a :class:`Qos`.

    ``where`` names the declaration in the one-line error for a value that is none of these.
    """
    if value is None or isinstance(value, Qos):
        return value or Qos()
    if isinstance(value, str):
        try:
            return PROFILES[value]
        except KeyError:
            raise DeclarationError(f"{where}: qos={value!r} is not a profile; give one of {', '.join(PROFILES)}, "
                                   "a depth, or a dict of depth, reliability, durability") from None
    if isinstance(value, int) and not isinstance(value, bool):
        return _checked(Qos(depth=value), where)
    if isinstance(value, dict):
        unknown = set(value) - {"depth", "reliability", "durability", "profile"}
        if unknown:
            raise DeclarationError(f"{where}: qos has no field {', '.join(sorted(map(str, unknown)))}; "
                                   "give depth, reliability, durability (and profile, a name to start from)")
        start = parse(value["profile"], where) if "profile" in value else Qos()
        fields = {k: v for k, v in value.items() if k != "profile"}
        return _checked(replace(start, **fields), where)
    raise DeclarationError(f"{where}: qos={value!r:.40} is a {type(value).__name__}; give a profile name "
                           f"({', '.join(PROFILES)}), a depth, or a dict of depth, reliability, durability")


def _checked(qos: Qos, where: str) -> Qos:
    depth = qos.depth
    if depth is not None and (isinstance(depth, bool) or not isinstance(depth, int) or not 1 <= depth <= 100_000):
        raise DeclarationError(f"{where}: qos depth {depth!r} must be a whole number from 1 to 100000")
    if qos.reliability not in (None, *RELIABILITY):
        raise DeclarationError(f"{where}: qos reliability {qos.reliability!r} must be one of {', '.join(RELIABILITY)}")
    if qos.durability not in (None, *DURABILITY):
        raise DeclarationError(f"{where}: qos durability {qos.durability!r} must be one of {', '.join(DURABILITY)}")
    return qos


def from_model(data: Optional[dict[str, Any]]) -> Qos:
    """The :class:`Qos` a model file holds (what :meth:`Qos.to_model` wrote)."""
    return parse(data, "model file") if data else Qos()
