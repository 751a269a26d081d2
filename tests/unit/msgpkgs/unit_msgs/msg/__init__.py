from ._Gain import Gain
from ._Sample import Sample
from ._Twist import Twist
from ._Vector3 import Vector3
