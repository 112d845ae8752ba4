"""An independent integration of CONTRACT §2, written from the contract text.

Used only as an oracle in tests and benchmarks; it shares no code with
pencli.model.  One ODE from release (x = -s0, at rest), Radau at rtol 1e-12,
split at the surface because R jumps there.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp


def reference_run(p: dict, m: dict, e: dict, speed_at_contact: float | None = None, rtol: float = 1e-12,
                  creep_distance_m: float = 1e-6) -> dict:
    """p, m, e: parameter mappings in CONTRACT §1 units (coefficients nested); a creep ends within
    ``creep_distance_m`` of the rest depth (pen's convention: 1 µm)."""
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
    events = [full, arrest]
    creep = _creep(lambda x: accel(x, 0.0, True), depth, w * T * C, mass, creep_distance_m) if C > 0 else None
    if creep is not None:  # docs "Creep": within 1 µm of the rest depth, on the slow mode
        near = lambda t, y: y[0] - (creep[0] - creep_distance_m)  # noqa: E731
        near.terminal, near.direction = True, 1
        events.append(near)
    rhs = lambda t, y: [y[1], accel(y[0], y[1], True)]  # noqa: E731
    t0, y0, pieces = t_c, [0.0, v_c], []
    while True:
        pen = solve_ivp(rhs, (t0, t_c + 100), y0, method="Radau", rtol=rtol, atol=1e-14, events=events,
                        dense_output=True)
        pieces.append(pen)
        if len(pen.t_events[0]):
            t_end, x_end, reached, end = float(pen.t_events[0][0]), depth, True, "full_depth"
        elif len(pen.t_events[1]):
            t_end, x_end, reached, end = float(pen.t_events[1][0]), float(pen.y_events[1][0][0]), False, "arrest"
        else:
            t0, y0 = float(pen.t_events[2][0]), list(pen.y_events[2][0])
            events = events[:2]
            if y0[1] <= creep[1]:
                t_end, x_end, reached, end = t0, creep[0], False, "creep"
            else:
                continue
        break
    best_r, best_x = -math.inf, 0.0
    for piece in pieces:
        tt = np.linspace(piece.t[0], min(piece.t[-1], t_end), 400_001)
        xs, vs = piece.sol(tt)
        vp = np.maximum(vs, 0.0)
        rs = w * T * (Cs * S * (math.sin(theta) + mu * math.cos(theta)) + mu * P * 2 * xs / T + C * vp
                      + K * rho * vp ** 2)
        i = int(np.argmax(rs))
        if rs[i] > best_r:
            best_r, best_x = float(rs[i]), float(xs[i])
    v_end = float(pieces[-1].sol(t_end)[1]) if reached else 0.0
    return {
        "contact_speed_m_s": v_c,
        "penetration_time_s": t_end - t_c,
        "final_depth_mm": x_end * 1000,
        "full_penetration": reached,
        "peak_resistance_n": best_r,
        "peak_resistance_depth_mm": best_x * 1000,
        "residual_ke_j": 0.5 * mass * v_end ** 2,
        "end": end,
    }


def _creep(force_at_rest, depth: float, b: float, mass: float, distance: float):
    """(rest depth, speed limit) when the motion is overdamped where the net force at rest vanishes, else None."""
    from scipy.optimize import brentq

    if not (force_at_rest(1e-12) > 0 > force_at_rest(depth)):
        return None
    rest = brentq(force_at_rest, 1e-12, depth, xtol=1e-15, rtol=1e-15)
    h = 1e-7
    k = -mass * (force_at_rest(rest + h) - force_at_rest(rest - h)) / (2 * h)  # slope of the net force there
    if k <= 0 or b * b < 4 * mass * k:
        return None
    return rest, math.sqrt(k / mass) * distance * (1 + 1e-9)
