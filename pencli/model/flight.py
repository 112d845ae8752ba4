r"""The flight from release to contact, in closed form (CONTRACT §2 above the surface).

From release at rest the body moves :math:`u = U(1 - \cos\omega t)` while the springs push
(:math:`U = \text{stroke} + m g/k_d`, :math:`\omega = \sqrt{k_d/m}`), then falls freely under g.
Plain ``math`` on floats, so the scalar simulator calls it as it is and the batch simulator compiles it.
"""

from __future__ import annotations

import math


def reach(u, m, kd, stroke, g):
    """(time [s], speed [m/s]) at which the body has moved ``u`` [m] from release; (inf, 0) if never.

    ``m``: effective mass [kg]; ``kd``: drive stiffness η·n·k [N/m]; ``stroke``: travel until the springs
    reach free length [m] (0: a drop); ``g``: gravity along the axis [m/s²].
    """
    if u <= 0.0:
        return 0.0, 0.0
    w = math.sqrt(kd / m)
    U = stroke + m * g / kd
    # 1 − cos θ = 2 sin²(θ/2): the phase at u, stable for small u; past the stroke, the phase at release
    phase = 2.0 * math.asin(math.sqrt(min(min(u, stroke) / (2.0 * U), 1.0)))
    if u <= stroke:
        return phase / w, U * w * math.sin(phase)
    t_rel, v_rel = phase / w, U * w * math.sin(phase)
    d = u - stroke
    root = math.sqrt(max(v_rel * v_rel + 2.0 * g * d, 0.0))
    if v_rel + root <= 0.0:
        return math.inf, 0.0
    tau = 2.0 * d / (v_rel + root)  # root of g τ²/2 + v τ − d = 0, cancellation-free
    return t_rel + tau, v_rel + g * tau


__all__ = ["reach"]
