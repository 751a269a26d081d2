from ._SetGain import SetGain
