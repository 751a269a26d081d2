from ._base import Message
from ._Vector3 import Vector3


class Twist(Message):
    _type, _md5sum = "unit_msgs/Twist", "9f195f881246fdfa2798d1d3eebca84a"
    __slots__ = ["linear", "angular"]
    _slot_types = ["unit_msgs/Vector3", "unit_msgs/Vector3"]
    _defaults = {"linear": Vector3, "angular": Vector3}
