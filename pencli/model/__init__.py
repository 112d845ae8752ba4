"""Pure physics: the Eq. 9 resistance law and the one-degree-of-freedom rig.

No I/O here; SI units throughout (m, s, N, kg, Pa).
"""
