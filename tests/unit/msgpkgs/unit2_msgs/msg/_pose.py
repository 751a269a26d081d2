"""The shape of rosidl's generated ROS 2 classes, as far as ipyros looks: a metaclass with _TYPE_SUPPORT, the
fields and their IDL types, slots with defaults."""


class Metaclass_Point(type):
    _TYPE_SUPPORT = None


class Point(metaclass=Metaclass_Point):
    __slots__ = ["_x", "_y"]
    _fields_and_field_types = {"x": "double", "y": "double"}

    @classmethod
    def get_fields_and_field_types(cls):
        return dict(cls._fields_and_field_types)

    def __init__(self, x=0.0, y=0.0):
        self.x, self.y = x, y

    x = property(lambda self: self._x, lambda self, v: setattr(self, "_x", v))
    y = property(lambda self: self._y, lambda self, v: setattr(self, "_y", v))

    def __eq__(self, other):
        return type(self) is type(other) and (self.x, self.y) == (other.x, other.y)


class Metaclass_Pose(type):
    _TYPE_SUPPORT = None


class Pose(metaclass=Metaclass_Pose):
    __slots__ = ["_position", "_weights", "_name"]
    _fields_and_field_types = {"position": "unit2_msgs/Point", "weights": "sequence<double>",
                               "name": "string<=20"}

    @classmethod
    def get_fields_and_field_types(cls):
        return dict(cls._fields_and_field_types)

    def __init__(self, position=None, weights=None, name=""):
        self.position, self.weights, self.name = position or Point(), list(weights or []), name

    position = property(lambda self: self._position, lambda self, v: setattr(self, "_position", v))
    weights = property(lambda self: self._weights, lambda self, v: setattr(self, "_weights", v))
    name = property(lambda self: self._name, lambda self, v: setattr(self, "_name", v))

    def __eq__(self, other):
        return type(self) is type(other) and (self.position, self.weights, self.name) == \
            (other.position, other.weights, other.name)
