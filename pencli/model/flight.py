r"""The flight from release to contact, in closed form (CONTRACT §2 above the surface).

From release at rest the body moves :math:`u = U(1 - \cos\omega t)` while the springs push
(:math:`U = \text{stroke} + m g/k_d`, :math:`\omega = \sqrt{k_d/m}`), then falls freely under g.
Plain ``math`` on floats, so the scalar simulator calls it as it is and the batch simulator compiles it.
"""

from __future__ import annotations

import math


def reach(u, m, kd, stroke, g, timed=True):
    """(time [s], speed [m/s]) at which the body has moved ``u`` [m] from release; (inf, 0) if never.

    ``m``: effective mass [kg]; ``kd``: drive stiffness η·n·k [N/m]; ``stroke``: travel until the springs
    reach free length [m] (0: a drop); ``g``: gravity along the axis [m/s²].  ``timed=False`` skips the
    time's arcsine (the time is then 0, or inf if never): the sweep needs the speed only.

    While the springs push, u = U(1 − cos ωt) with U = stroke + mg/kd, so with a = u/(2U) = sin²(ωt/2) the
    speed Uω·sin ωt is 2Uω√(a(1 − a)) and the phase ωt is 2·asin √a (stable for small u).
    """
    if u <= 0.0:
        return 0.0, 0.0
    w = math.sqrt(kd / m)
    U = stroke + m * g / kd
    a = min(min(u, stroke) / (2.0 * U), 1.0)  # past the stroke: at release from the springs
    v_rel = 2.0 * U * w * math.sqrt(a * (1.0 - a))
    t_rel = 2.0 * math.asin(math.sqrt(a)) / w if timed else 0.0
    if u <= stroke:
        return t_rel, v_rel
    d = u - stroke
    root = math.sqrt(max(v_rel * v_rel + 2.0 * g * d, 0.0))
    if v_rel + root <= 0.0:
        return math.inf, 0.0
    tau = 2.0 * d / (v_rel + root)  # root of g τ²/2 + v τ − d = 0, cancellation-free
    return t_rel + tau, v_rel + g * tau


__all__ = ["reach"]
