"""What genpy's generated classes have in common, as far as ipyros looks: slots with defaults, keyword init."""


class Message:
    __slots__: list[str] = []
    _slot_types: list[str] = []
    _defaults: dict = {}

    def __init__(self, *args, **kwargs):
        for name in self.__slots__:
            default = self._defaults.get(name)
            setattr(self, name, default() if callable(default) else default)
        for name, value in zip(self.__slots__, args):
            setattr(self, name, value)
        for name, value in kwargs.items():
            if name not in self.__slots__:
                raise AttributeError(f"{type(self).__name__} has no field {name}")
            setattr(self, name, value)

    def __eq__(self, other):
        return type(self) is type(other) and all(getattr(self, n) == getattr(other, n) for n in self.__slots__)

    def __repr__(self):
        return f"{type(self).__name__}({', '.join(f'{n}={getattr(self, n)!r}' for n in self.__slots__)})"
