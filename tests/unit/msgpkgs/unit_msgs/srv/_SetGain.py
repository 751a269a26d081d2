from ..msg._base import Message


class SetGainRequest(Message):
    _type, _md5sum = "unit_msgs/SetGainRequest", "00000000000000000000000000000002"
    __slots__ = ["gain"]
    _slot_types = ["float64"]
    _defaults = {"gain": 0.0}


class SetGainResponse(Message):
    _type, _md5sum = "unit_msgs/SetGainResponse", "00000000000000000000000000000003"
    __slots__ = ["ok"]
    _slot_types = ["bool"]
    _defaults = {"ok": False}


class SetGain:
    _type = "unit_msgs/SetGain"
    _request_class, _response_class = SetGainRequest, SetGainResponse
