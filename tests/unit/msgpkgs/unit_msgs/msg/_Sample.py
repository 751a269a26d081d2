from ._base import Message
from ._Vector3 import Vector3


class Sample(Message):
    """A field of each kind ipyros builds and checks."""

    _type, _md5sum = "unit_msgs/Sample", "00000000000000000000000000000001"
    __slots__ = ["label", "on", "count", "small", "level", "gains", "fixed", "raw", "points", "names"]
    _slot_types = ["string", "bool", "int32", "int8", "float32", "float64[]", "float64[3]", "uint8[]",
                   "unit_msgs/Vector3[]", "string[]"]
    _defaults = {"label": "", "on": False, "count": 0, "small": 0, "level": 0.0, "gains": list,
                 "fixed": lambda: [0.0, 0.0, 0.0], "raw": bytes, "points": list, "names": list}
    LIMIT = 10
