from ._base import Message


class Vector3(Message):
    _type, _md5sum = "unit_msgs/Vector3", "4a842b65f413084dc2b10fb484ea7f17"
    __slots__ = ["x", "y", "z"]
    _slot_types = ["float64", "float64", "float64"]
    _defaults = {"x": 0.0, "y": 0.0, "z": 0.0}
