"""An independent integration of CONTRACT §2, written from the contract text.

Used only as an oracle in tests and benchmarks; it shares no code with
pencli.model.  One ODE from release (x = -s0, at rest), Radau at rtol 1e-12,
split at the surface because R jumps there.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp


def reference_run(p: dict, m: dict, e: dict, speed_at_contact: float | None = None, rtol: float = 1e-12) -> dict:
    """p, m, e: parameter mappings in CONTRACT §1 units (coefficients nested)."""
    w = p["blade_width_mm"] / 1000
    T = p["blade_thickness_mm"] / 1000
    theta = math.radians(p["tip_angle_deg"])
    depth = p["penetration_depth_mm"] / 1000
    c = m["coefficients"]
    S = m["microstructure_strength_kpa"] * 1000
    mu = m["friction_coefficient"]
    rho = m["density_kg_m3"]
    g = m.get("gravity_m_s2", 9.81)
    Cs, P = c["strength_factor"], c["sidewall_pressure_kpa"] * 1000
    C, K = c["damping_kpa_s_m"] * 1000, c["inertia_coefficient"]
    n = e["spring_count"]
    k = e["spring_stiffness_kn_m"] * 1000
    eta = e["propulsion_efficiency_pct"] / 100
    L0 = e["spring_nominal_length_mm"] / 1000
    s0 = e["surface_offset_mm"] / 1000
    if "spring_length_at_contact_mm" in e:  # BAM's spring length at contact = compressed length + stand-off
        Lc = e["spring_length_at_contact_mm"] / 1000 - s0
    else:
        Lc = e["spring_compressed_length_mm"] / 1000
    mass = p["sprung_mass_kg"] + n * e["spring_mass_kg"] / 3

    def resistance(x, v):
        if x <= 0:
            return 0.0
        vp = max(v, 0.0)
        return w * T * (Cs * S * (math.sin(theta) + mu * math.cos(theta)) + mu * P * 2 * x / T
                        + C * vp + K * rho * vp * vp)

    def accel(x, v, in_material):
        L = Lc + (x + s0)
        spring = eta * n * k * (L0 - L) if L < L0 else 0.0
        R = resistance(max(x, 1e-300), v) if in_material else 0.0
        return (spring + mass * g - R) / mass

    if speed_at_contact is None:
        surface = lambda t, y: y[0]  # noqa: E731
        surface.terminal, surface.direction = True, 1
        fl = solve_ivp(lambda t, y: [y[1], accel(y[0], y[1], False)], (0, 10), [-s0, 0.0], method="Radau",
                       rtol=rtol, atol=1e-14, events=surface)
        t_c, v_c = float(fl.t_events[0][0]), float(fl.y_events[0][0][1])
    else:
        t_c, v_c = 0.0, speed_at_contact

    full = lambda t, y: y[0] - depth  # noqa: E731
    full.terminal, full.direction = True, 1
    arrest = lambda t, y: y[1]  # noqa: E731
    arrest.terminal, arrest.direction = True, -1
    pen = solve_ivp(lambda t, y: [y[1], accel(y[0], y[1], True)], (t_c, t_c + 10), [0.0, v_c], method="Radau",
                    rtol=rtol, atol=1e-14, events=[full, arrest], dense_output=True)
    if len(pen.t_events[0]):
        t_end, x_end, reached = float(pen.t_events[0][0]), depth, True
    else:
        t_end, x_end, reached = float(pen.t_events[1][0]), float(pen.y_events[1][0][0]), False
    tt = np.linspace(t_c, t_end, 400_001)
    xs, vs = pen.sol(tt)
    vp = np.maximum(vs, 0.0)
    rs = w * T * (Cs * S * (math.sin(theta) + mu * math.cos(theta)) + mu * P * 2 * xs / T + C * vp + K * rho * vp ** 2)
    i = int(np.argmax(rs))
    return {
        "contact_speed_m_s": v_c,
        "penetration_time_s": t_end - t_c,
        "final_depth_mm": x_end * 1000,
        "full_penetration": reached,
        "peak_resistance_n": float(rs[i]),
    }
