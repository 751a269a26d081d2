from ._base import Message


class Gain(Message):
    _type, _md5sum = "unit_msgs/Gain", "00000000000000000000000000000004"
    __slots__ = ["gain"]
    _slot_types = ["float64"]
    _defaults = {"gain": 0.0}
