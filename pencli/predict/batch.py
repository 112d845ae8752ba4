r"""The CONTRACT §2 model over arrays of designs (the engine of ``pen sweep``).

Same physics as :func:`pencli.model.dynamics.simulate`, organised for
throughput instead of one trajectory:

- the flight is the same closed form (harmonic while the springs push, then a
  parabola), evaluated for every design at once;
- the penetration is integrated with classical RK4 on a fixed number of steps
  per design, each design's step scaled to an estimate of its own
  penetration time, all designs advancing together as numpy arrays;
- arrest (v = 0) and full depth are located inside the step where they occur
  by cubic Hermite interpolation of x and v (fourth order, like the steps),
  and a design that has stopped leaves the active set.

Inputs are SI arrays named like the fields of :class:`pencli.model.design.Design`
(broadcast against each other); outputs are the CONTRACT §5 figures per design.
Pure numpy.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from pencli.model.design import Design
from pencli.model.resistance import eq9_coefficients

STEPS = 160
"""RK4 steps over a design's estimated penetration time.  A design still moving after that many steps
doubles its step (the motion left is at least as long as the motion done), so a short estimate costs
a few more steps, never accuracy."""

FIGURES = ("contact_speed_m_s", "penetration_time_s", "final_depth_mm", "full_penetration", "peak_resistance_n",
           "peak_resistance_depth_mm", "residual_ke_j", "spring_energy_j", "energy_strength_j", "energy_friction_j",
           "energy_damping_j", "energy_inertia_j")
"""The CONTRACT §5 record, in order."""


@dataclass(frozen=True)
class BatchResult:
    """CONTRACT §5 figures per design (arrays of equal length), plus how each ended."""

    figures: dict[str, np.ndarray]
    end: np.ndarray
    """``arrest``, ``full_depth``, ``no_contact`` or ``invalid`` (a CONTRACT §1 rule broken) per design."""

    def __len__(self) -> int:
        return int(self.end.size)

    def to_dict(self) -> dict[str, np.ndarray]:
        return {**self.figures, "end": self.end}


def designs_from(arrays: dict[str, np.ndarray | float]) -> dict[str, np.ndarray]:
    """Broadcast per-field values (SI, :class:`Design` field names) to equal-length float arrays."""
    names = [f.name for f in fields(Design)]
    missing = [n for n in names if n not in arrays]
    if missing:
        raise KeyError(f"missing design field {missing[0]!r}")
    shaped = np.broadcast_arrays(*[np.asarray(arrays[n], dtype=float) for n in names])
    return {n: np.ravel(a).copy() for n, a in zip(names, shaped)}


def simulate_batch(d: dict[str, np.ndarray], *, speed_at_contact_m_s: np.ndarray | float | None = None,
                   steps: int = STEPS) -> BatchResult:
    """Simulate every design of ``d`` (see :func:`designs_from`); all four Eq. 9 terms on."""
    n = d["blade_width_m"].size
    design = Design(**d)  # one design per element: the design rules and Eq. 9 come from the model core
    m, kd, stroke = design.effective_mass_kg, design.drive_stiffness_n_m, design.stroke_m  # stroke 0: a drop
    s0, g = design.surface_offset_m, design.gravity_m_s2
    w, T = design.blade_width_m, design.blade_thickness_m
    a0, a1, b, dd = eq9_coefficients(design)  # R = a0 + a1·x + b·v + dd·v² in contact
    depth = design.penetration_depth_m

    # ---- flight, closed form (as pencli.model.dynamics.Flight)
    U = stroke + m * g / kd
    omega = np.sqrt(kd / m)
    if speed_at_contact_m_s is None:
        t_rel = 2.0 * np.arcsin(np.sqrt(np.clip(stroke / (2.0 * U), 0.0, 1.0))) / omega
        v_rel = U * omega * np.sin(omega * t_rel)
        in_spring = s0 <= stroke
        t_a = 2.0 * np.arcsin(np.sqrt(np.clip(s0 / (2.0 * U), 0.0, 1.0))) / omega
        v_a = U * omega * np.sin(omega * t_a)
        rest = np.maximum(s0 - stroke, 0.0)
        disc = np.sqrt(v_rel * v_rel + 2.0 * g * rest)
        reach = (v_rel + disc) > 0
        tau = np.where(reach, 2.0 * rest / np.where(reach, v_rel + disc, 1.0), np.inf)
        v_b = v_rel + g * tau
        v0 = np.where(in_spring, v_a, v_b)
        no_contact = ~in_spring & ~reach
        u_start = np.zeros(n)
    else:
        v0 = np.broadcast_to(np.asarray(speed_at_contact_m_s, dtype=float), (n,)).copy()
        no_contact = np.zeros(n, dtype=bool)
        u_start = s0.copy()
    v0 = np.where(no_contact, 0.0, v0)

    x = np.zeros(n)
    v = v0.copy()
    t = np.zeros(n)
    e_damp = np.zeros(n)
    e_inert = np.zeros(n)
    peak = a0 + b * np.maximum(v0, 0) + dd * np.maximum(v0, 0) ** 2  # R just inside the surface
    peak_x = np.zeros(n)
    end = np.where(no_contact, "no_contact", "").astype(object)
    # designs the parameter rules forbid (CONTRACT §1 cross-checks) are not simulated
    invalid = (T >= w) | (d["load_cell_mass_kg"] > d["sprung_mass_kg"])
    end[invalid] = "invalid"
    no_contact = no_contact | invalid
    v0 = np.where(invalid, 0.0, v0)

    params = {"stroke_s0": stroke - s0, "kd": kd, "mg": m * g, "a0": a0, "a1": a1, "b": b, "dd": dd, "m": m,
              "depth": depth}

    def accel(x_, v_, P):
        vp = np.maximum(v_, 0.0)
        compression = P["stroke_s0"] - x_
        spring = np.where(compression > 0.0, P["kd"] * compression, 0.0)
        return (spring + P["mg"] - P["a0"] - P["a1"] * x_ - (P["b"] + P["dd"] * vp) * vp) / P["m"]

    # a design that cannot get in (no speed, drive below the static strength) stops at the surface
    weak = (~no_contact) & (v0 <= 0.0) & (accel(np.zeros(n), np.zeros(n), params) <= 0.0)
    end[weak] = "arrest"

    # ---- step size from a rough estimate of the penetration time (constant net acceleration)
    drive0 = np.where(stroke - s0 > 0, kd * (stroke - s0), 0.0) + m * g
    decel = (a0 + 0.5 * a1 * depth + 0.5 * dd * v0 * v0 - drive0) / m  # > 0: slows down on average
    t_stop = np.where(decel > 0, v0 / np.maximum(decel, 1e-12), np.inf)
    push = np.maximum(-decel, 0.0)  # speeding up: time to full depth under that push
    t_full = np.where(push > 0, (np.sqrt(v0 * v0 + 2 * push * depth) - v0) / np.maximum(push, 1e-12),
                      depth / np.maximum(v0, 1e-6))
    t_est = np.clip(np.minimum(t_stop, t_full), 1e-6, 10.0)

    # working set: parameters gathered once, re-gathered only when a quarter of it has stopped
    W = np.flatnonzero(end == "")
    P = {key: val[W] for key, val in params.items()}
    h = t_est[W] / steps
    xs, vs, ts = x[W], v[W], t[W]
    eds, eis, pk, pkx = np.zeros(W.size), np.zeros(W.size), peak[W], peak_x[W]
    live = np.ones(W.size, dtype=bool)
    for count in range(1, 60 * steps + 1):
        if W.size == 0:
            break
        a_s = accel(xs, vs, P)
        k2x, k2v = vs + 0.5 * h * a_s, accel(xs + 0.5 * h * vs, vs + 0.5 * h * a_s, P)
        k3x, k3v = vs + 0.5 * h * k2v, accel(xs + 0.5 * h * k2x, vs + 0.5 * h * k2v, P)
        k4x, k4v = vs + h * k3v, accel(xs + h * k3x, vs + h * k3v, P)
        xn = xs + h * (vs + 2 * k2x + 2 * k3x + k4x) / 6
        vn = vs + h * (a_s + 2 * k2v + 2 * k3v + k4v) / 6
        v1, v2, v3, v4 = (np.maximum(q, 0.0) for q in (vs, k2x, k3x, k4x))
        ed = h * P["b"] * (v1 * v1 + 2 * v2 * v2 + 2 * v3 * v3 + v4 * v4) / 6  # damping energy, ∫ b v² dt
        ei = h * P["dd"] * (v1 ** 3 + 2 * v2 ** 3 + 2 * v3 ** 3 + v4 ** 3) / 6  # inertia energy, ∫ d v³ dt
        an = accel(xn, vn, P)
        stop_v = live & (vn <= 0.0)
        stop_x = live & (xn >= P["depth"])
        stopping = stop_v | stop_x
        s = np.ones(W.size)
        hits_depth = np.zeros(W.size, dtype=bool)
        if stopping.any():
            j = np.flatnonzero(stopping)
            sv, sx = _hermite_roots(xs[j], vs[j], a_s[j], xn[j], vn[j], an[j], h[j], P["depth"][j])
            sv = np.where(stop_v[j], sv, np.inf)
            sx = np.where(stop_x[j], sx, np.inf)
            hits_depth[j] = sx <= sv
            s[j] = np.minimum(sv, sx)
        x_end, v_end = _hermite_xv(xs, vs, a_s, xn, vn, an, h, s)
        vpos = np.maximum(v_end, 0.0)
        r_end = P["a0"] + P["a1"] * x_end + (P["b"] + P["dd"] * vpos) * vpos
        better = live & (r_end > pk)
        pk = np.where(better, r_end, pk)
        pkx = np.where(better, x_end, pkx)
        # a maximum of R inside the step (R rises at its start and falls at its end): located on the Hermite
        # interpolant, not read at a step end, so its depth is as accurate as the steps
        rise0 = P["a1"] * vs + (P["b"] + 2.0 * P["dd"] * np.maximum(vs, 0.0)) * a_s
        rise1 = P["a1"] * vn + (P["b"] + 2.0 * P["dd"] * np.maximum(vn, 0.0)) * an  # at a full step's end
        if stopping.any():  # a step cut short ends inside: the slope there, on the interpolant
            j = np.flatnonzero(stopping)
            rise1[j] = _resistance_slope(xs[j], vs[j], a_s[j], xn[j], vn[j], an[j], h[j], s[j],
                                         {key: val[j] for key, val in P.items()})
        inner = np.flatnonzero(live & (rise0 > 0.0) & (rise1 < 0.0))
        if inner.size:
            q = {key: val[inner] for key, val in P.items()}
            args = (xs[inner], vs[inner], a_s[inner], xn[inner], vn[inner], an[inner], h[inner])
            lo, hi = np.zeros(inner.size), s[inner].copy()
            for _ in range(40):
                mid = 0.5 * (lo + hi)
                up = _resistance_slope(*args, mid, q) > 0.0
                lo, hi = np.where(up, mid, lo), np.where(up, hi, mid)
            xm, vm = _hermite_xv(*args, 0.5 * (lo + hi))
            vm = np.maximum(vm, 0.0)
            rm = q["a0"] + q["a1"] * xm + (q["b"] + q["dd"] * vm) * vm
            top = rm > pk[inner]
            pk[inner] = np.where(top, rm, pk[inner])
            pkx[inner] = np.where(top, xm, pkx[inner])
        ts = np.where(live, ts + s * h, ts)
        eds = np.where(live, eds + s * ed, eds)  # a partial step's energy: its power is ~0 at arrest
        eis = np.where(live, eis + s * ei, eis)
        xs = np.where(live, np.where(stopping, np.where(hits_depth, P["depth"], x_end), xn), xs)
        vs = np.where(live, np.where(stopping, np.where(hits_depth, vpos, 0.0), vn), vs)
        if stopping.any():
            j = np.flatnonzero(stopping)
            end[W[j]] = np.where(hits_depth[j], "full_depth", "arrest")
            live[j] = False
        if count % steps == 0:
            h = h * 2.0  # still moving after the planned steps: the estimate was short; longer steps from here
        if live.sum() <= 0.75 * W.size:  # write back the finished ones and compact the working set
            gone = ~live
            x[W[gone]], v[W[gone]], t[W[gone]] = xs[gone], vs[gone], ts[gone]
            e_damp[W[gone]], e_inert[W[gone]] = eds[gone], eis[gone]
            peak[W[gone]], peak_x[W[gone]] = pk[gone], pkx[gone]
            keep = live
            W, h, xs, vs, ts = W[keep], h[keep], xs[keep], vs[keep], ts[keep]
            eds, eis, pk, pkx = eds[keep], eis[keep], pk[keep], pkx[keep]
            P = {key: val[keep] for key, val in P.items()}
            live = np.ones(W.size, dtype=bool)
    x[W], v[W], t[W], e_damp[W], e_inert[W], peak[W], peak_x[W] = xs, vs, ts, eds, eis, pk, pkx
    end[np.flatnonzero(end == "")] = "stalled"

    x_final = np.where(no_contact, 0.0, x)
    v_final = np.where(end == "full_depth", v, 0.0)
    u_end = x_final + s0
    spring_j = 0.5 * kd * (np.maximum(stroke - u_start, 0.0) ** 2 - np.maximum(stroke - u_end, 0.0) ** 2)
    figures = {
        "contact_speed_m_s": v0,
        "penetration_time_s": np.where(no_contact, 0.0, t),
        "final_depth_mm": x_final * 1e3,
        "full_penetration": end == "full_depth",
        "peak_resistance_n": np.where(no_contact, 0.0, peak),
        "peak_resistance_depth_mm": peak_x * 1e3,
        "residual_ke_j": 0.5 * m * v_final ** 2,
        "spring_energy_j": spring_j,
        "energy_strength_j": a0 * x_final,
        "energy_friction_j": 0.5 * a1 * x_final ** 2,
        "energy_damping_j": e_damp,
        "energy_inertia_j": e_inert,
    }
    return BatchResult(figures, end.astype(str))


def _hermite_xv(x0, v0, a0, x1, v1, a1, h, s):
    """Cubic Hermite x(s) (derivative v) and v(s) (derivative a) on a step of length h."""
    s2, s3 = s * s, s * s * s
    h00, h10, h01, h11 = 2 * s3 - 3 * s2 + 1, s3 - 2 * s2 + s, -2 * s3 + 3 * s2, s3 - s2
    x = h00 * x0 + h10 * h * v0 + h01 * x1 + h11 * h * v1
    v = h00 * v0 + h10 * h * a0 + h01 * v1 + h11 * h * a1
    return x, v


def _hermite_slopes(x0, v0, a0, x1, v1, a1, h, s):
    """d/ds of the Hermite x(s) and v(s) on a step of length h."""
    s2 = s * s
    d00, d10, d01, d11 = 6 * s2 - 6 * s, 3 * s2 - 4 * s + 1, -6 * s2 + 6 * s, 3 * s2 - 2 * s
    return d00 * x0 + d10 * h * v0 + d01 * x1 + d11 * h * v1, d00 * v0 + d10 * h * a0 + d01 * v1 + d11 * h * a1


def _resistance_slope(x0, v0, a0, x1, v1, a1, h, s, P):
    """dR/ds of R = a0 + a1·x + b·v + dd·v² along the Hermite interpolant of a step (sign is what matters)."""
    _, v = _hermite_xv(x0, v0, a0, x1, v1, a1, h, s)
    dx, dv = _hermite_slopes(x0, v0, a0, x1, v1, a1, h, s)
    return P["a1"] * dx + (P["b"] + 2.0 * P["dd"] * np.maximum(v, 0.0)) * dv


def _newton(f, df, s):
    for _ in range(8):
        slope = df(s)
        s = np.clip(s - f(s) / np.where(np.abs(slope) > 1e-300, slope, 1e-300), 0.0, 1.0)
    return s


def _hermite_roots(x0, v0, a0, x1, v1, a1, h, depth):
    """Fractions s of the step where the Hermite v(s) = 0 and where x(s) = depth (Newton from linear guesses)."""
    def dx(s):
        return _hermite_slopes(x0, v0, a0, x1, v1, a1, h, s)[0]

    def dv(s):
        return _hermite_slopes(x0, v0, a0, x1, v1, a1, h, s)[1]

    guess_v = np.clip(v0 / np.where(v0 > v1, v0 - v1, 1.0), 0.0, 1.0)
    guess_x = np.clip((depth - x0) / np.where(x1 > x0, x1 - x0, 1.0), 0.0, 1.0)
    sv = _newton(lambda s: _hermite_xv(x0, v0, a0, x1, v1, a1, h, s)[1], dv, guess_v)
    sx = _newton(lambda s: _hermite_xv(x0, v0, a0, x1, v1, a1, h, s)[0] - depth, dx, guess_x)
    return sv, sx


def design_arrays(design: Design, count: int = 1) -> dict[str, np.ndarray]:
    """One :class:`Design` repeated ``count`` times, as batch input."""
    return designs_from({f.name: np.full(count, float(getattr(design, f.name))) for f in fields(Design)})


__all__ = ["BatchResult", "FIGURES", "STEPS", "design_arrays", "designs_from", "simulate_batch"]
