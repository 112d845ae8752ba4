r"""Penetration with damping (C > 0) over arrays of designs, time as the independent variable.

In the material the motion obeys :math:`m\ddot x = F(x) - b\dot x - d\dot x^2` with F piecewise linear
(springs pushing until :math:`x_k`, then not), b = wTC and d = wTKρ.  Two regimes:

1. **RK4**, each design on its own steps: an estimate of its penetration time over :data:`STEPS`, doubled
   after every :data:`STEPS` steps, and never more than ``0.25·m/(b + 2dv)`` so that the damping's time
   scale is resolved (explicit steps beyond it diverge at large damping).
2. **Exact linear flow** once ``d·v ≤ LINEAR_TOL·b`` (the v² term is then a relative perturbation of the
   damping force below LINEAR_TOL, and is kept linearised about the step's starting speed): on each
   spring segment :math:`\ddot\xi = -\omega_0^2\xi + 2\sigma\dot\xi` about the segment's rest depth
   :math:`x^*` has the closed-form flow :math:`e^{Jt} = e^{\sigma t}(C\,I + tS\,(J - \sigma I))`, stable for
   any step, so the steps double freely through a slow creep.  Events (arrest, full depth, springs at free
   length, creep) are located on that flow by bisection.

**Creep.**  When the motion is overdamped at the rest depth x* (where F = 0; possible only with damping),
the tip approaches x* without reaching it in finite time.  pen ends such a run when the tip comes within
:data:`CREEP_DISTANCE_M` of x* at a speed below :math:`\omega_0\,\delta` (so it will not overshoot: it
is on the slow side of the two modes); the penetration time is that moment, the final depth is x* and the
residual energy 0.  :func:`pencli.model.dynamics.simulate` uses the same definition.

Each design is integrated on its own (scalar code compiled by numba): its steps, events and regime
changes are its own, so a slow design costs only its own steps, and the step budgets can be generous.

Units SI; pure functions (no I/O).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from pencli.predict.compiled import JIT as _JIT
from pencli.predict.compiled import creep_point as _creep_point
from pencli.predict.compiled import reduced as _reduced
from pencli.predict.compiled import static_work as _static_work

STEPS = 160
"""RK4 steps over a design's estimated penetration time (doubled after as many steps again)."""
STIFF_STEP = 0.25
"""RK4 step limit in units of the damping time m/(b + 2dv). [–]  At 0.5, a light body with a wide blade in dense
material (λ·depth ≈ 700, C = 5,000 Pa·s/m) ended 1.3e-4 off in time against DOP853 at rtol 1e-12; at 0.25,
5.8e-6 (bench_batch_fuzz), at no cost on damped designs around Appendix C (47,000 a second on one core)."""
LINEAR_TOL = 1e-5
"""Hand a design to the exact linear flow once d·v ≤ LINEAR_TOL·b. [–]"""
LINEARISE_TOL = 1e-9
"""Linear-flow steps are limited so that the linearised v² term errs by at most this fraction of the
damping force: d·Δv² ≤ LINEARISE_TOL·b·v. [–]"""
HANDOVER_STEPS = 20_000
"""RK4 steps after which the exact linear flow takes over even while d·v > LINEAR_TOL·b (its steps are then
capped so that the linearised v² term stays within LINEARISE_TOL): RK4 at a quarter of the damping time
m/b ran out of 2·10⁶ steps 1.8 s into a 50-s creep at C = 42,000 kPa·s/m.  Designs that hand over by
LINEAR_TOL take a few hundred steps."""
MAX_STEPS = 2_000_000
"""Linear-flow steps per design at most; a design still moving after them ends as ``stalled`` (one of 2,000
damped designs of bench_batch_fuzz, seed 7, C up to 10⁸ Pa·s/m, did before RK4 handed over by step count)."""
_BISECT = 60
_G5_NODES, _G5_WEIGHTS = np.polynomial.legendre.leggauss(5)
_G5_NODES = 0.5 * (_G5_NODES + 1.0)
_G5_WEIGHTS = 0.5 * _G5_WEIGHTS
_FACT = np.cumprod(np.array([1.0] + list(range(1, 23)), dtype=float))

ARREST, FULL_DEPTH, CREEP, STALLED = 0, 1, 2, 3
"""End codes, in the order of :data:`pencli.predict.batch.ENDS`."""
_KINK = 4



@njit(**_JIT)
def rest_depth(F0, k):
    """x* where F0 − k·x = 0 (inf when k = 0). [m]"""
    return F0 / k if k > 0.0 else math.inf


@njit(**_JIT)
def _accel(x, v, m, kd, xk, mg, a0, a1, b, d):
    spring = kd * (xk - x) if x < xk else 0.0
    return (spring + mg - _reduced(x, max(v, 0.0), a0, a1, b, d)) / m


@njit(**_JIT)
def _linear_ready(x, v, m, kd, xk, mg, a0, a1, b, d):
    """In the linear regime: no v² term, or slowing down (never to speed up again in the material) with
    d·v ≤ LINEAR_TOL·b."""
    if d == 0.0:
        return True
    return _accel(x, v, m, kd, xk, mg, a0, a1, b, d) <= 0.0 and d * max(v, 0.0) <= LINEAR_TOL * b


@njit(**_JIT)
def _step(xs, vs, h, m, kd, xk, mg, a0, a1, b, d):
    """One classical RK4 step of length h: (x, v, damping energy, inertia energy, a at start, a at end)."""
    a_s = _accel(xs, vs, m, kd, xk, mg, a0, a1, b, d)
    k2x, k2v = vs + 0.5 * h * a_s, _accel(xs + 0.5 * h * vs, vs + 0.5 * h * a_s, m, kd, xk, mg, a0, a1, b, d)
    k3x, k3v = vs + 0.5 * h * k2v, _accel(xs + 0.5 * h * k2x, vs + 0.5 * h * k2v, m, kd, xk, mg, a0, a1, b, d)
    k4x, k4v = vs + h * k3v, _accel(xs + h * k3x, vs + h * k3v, m, kd, xk, mg, a0, a1, b, d)
    xn = xs + h * (vs + 2 * k2x + 2 * k3x + k4x) / 6
    vn = vs + h * (a_s + 2 * k2v + 2 * k3v + k4v) / 6
    v1, v2, v3, v4 = max(vs, 0.0), max(k2x, 0.0), max(k3x, 0.0), max(k4x, 0.0)
    ed = h * b * (v1 * v1 + 2 * v2 * v2 + 2 * v3 * v3 + v4 * v4) / 6  # ∫ b v² dt
    ei = h * d * (v1 ** 3 + 2 * v2 ** 3 + 2 * v3 ** 3 + v4 ** 3) / 6  # ∫ d v³ dt
    return xn, vn, ed, ei, a_s, _accel(xn, vn, m, kd, xk, mg, a0, a1, b, d)


@njit(**_JIT)
def _hermite_xv(x0, v0, a0, x1, v1, a1, h, s):
    """Cubic Hermite x(s) (derivative v) and v(s) (derivative a) on a step of length h."""
    s2, s3 = s * s, s * s * s
    h00, h10, h01, h11 = 2 * s3 - 3 * s2 + 1, s3 - 2 * s2 + s, -2 * s3 + 3 * s2, s3 - s2
    return (h00 * x0 + h10 * h * v0 + h01 * x1 + h11 * h * v1,
            h00 * v0 + h10 * h * a0 + h01 * v1 + h11 * h * a1)


@njit(**_JIT)
def _resistance_slope(x0, v0, a0, x1, v1, a1, h, s, fa1, b, d):
    """dR/ds of R = a0 + a1·x + b·v + d·v² along the Hermite interpolant of a step (its sign matters)."""
    _, v = _hermite_xv(x0, v0, a0, x1, v1, a1, h, s)
    s2 = s * s
    d00, d10, d01, d11 = 6 * s2 - 6 * s, 3 * s2 - 4 * s + 1, -6 * s2 + 6 * s, 3 * s2 - 2 * s
    dx = d00 * x0 + d10 * h * v0 + d01 * x1 + d11 * h * v1
    dv = d00 * v0 + d10 * h * a0 + d01 * v1 + d11 * h * a1
    return fa1 * dx + (b + 2.0 * d * max(v, 0.0)) * dv


@njit(**_JIT)
def _flow(t, xi0, v0, sigma, mu2, w2):
    """Exact (ξ, v) after t of ξ' = v, v' = −w2·ξ + 2σ·v (σ ≤ 0), with μ² = σ² − w2."""
    z = mu2 * t * t
    if abs(z) >= 1.0:
        if z > 0.0:
            mu = math.sqrt(mu2)
            e1, e2 = math.exp((sigma + mu) * t), math.exp((sigma - mu) * t)
            E1, E2 = 0.5 * (e1 + e2), (e1 - e2) / (2.0 * mu)
        else:
            mu = math.sqrt(-mu2)
            decay = math.exp(sigma * t)
            E1, E2 = decay * math.cos(mu * t), decay * math.sin(mu * t) / mu
    else:
        c_series = 0.0
        s_series = 0.0
        for n in range(10, -1, -1):
            c_series = 1.0 / _FACT[2 * n] + z * c_series
            s_series = 1.0 / _FACT[2 * n + 1] + z * s_series
        decay = math.exp(sigma * t)
        E1, E2 = decay * c_series, decay * t * s_series
    return E1 * xi0 + E2 * (v0 - sigma * xi0), E1 * v0 + E2 * (sigma * v0 - w2 * xi0)


@njit(**_JIT)
def _phi1(z):
    return 1.0 if z == 0.0 else math.expm1(z) / z


@njit(**_JIT)
def _lin_state(s, h, xi0, v, sigma, mu2, w2, x_star, shifted, x0, v_term):
    """(x, v) at the fraction s of a linear-flow step."""
    tt = s * h
    if shifted:
        xi_t, v_t = _flow(tt, xi0, v, sigma, mu2, w2)
        return x_star + xi_t, v_t
    # k = 0 (or a rest depth out of float reach): v relaxes to F/b
    return x0 + v_term * tt + (v - v_term) * tt * _phi1(2.0 * sigma * tt), \
        v_term + (v - v_term) * math.exp(2.0 * sigma * tt)


@njit(**_JIT)
def _at(on_flow, s, p):
    """(x, v) at the fraction s of a step: the cubic Hermite interpolant of an RK4 step (``p`` = x0, v0, a0,
    x1, v1, a1, h, …) or the linear flow (``p`` = h, ξ0, v, σ, μ², ω², x*, shifted, x0, v_term, …)."""
    if on_flow:
        return _lin_state(s, p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7] > 0.0, p[8], p[9])
    return _hermite_xv(p[0], p[1], p[2], p[3], p[4], p[5], p[6], s)


@njit(**_JIT)
def _rise(on_flow, s, p):
    """A quantity with the sign of dR/dt at the fraction s of a step (R = a0 + a1·x + b·v + d·v²); ``p[10:13]``
    = a1, b, d, and for the flow ``p[13:17]`` = F, k, b of the linearised force and m."""
    fa1, b, d = p[10], p[11], p[12]
    if on_flow:
        x, v = _at(on_flow, s, p)
        return fa1 * v + (b + 2.0 * d * v) * (p[13] - p[14] * x - p[15] * v) / p[16]
    return _resistance_slope(p[0], p[1], p[2], p[3], p[4], p[5], p[6], s, fa1, b, d)


@njit(**_JIT)
def _bisect(on_flow, mode, target, hi, p):
    """Largest s in [0, hi] where (mode 0) v(s) > 0, (1) x(s) < target, (2) dR/dt > 0 on a step (see
    :func:`_at`); the condition holds at 0 and fails at hi."""
    lo = 0.0
    for _ in range(_BISECT):
        mid = 0.5 * (lo + hi)
        if mode == 2:
            up = _rise(on_flow, mid, p) > 0.0
        else:
            x, v = _at(on_flow, mid, p)
            up = v > 0.0 if mode == 0 else target - x > 0.0
        if up:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


@njit(**_JIT)
def run_one(v0, m, kd, xk, mg, a0, a1, b, d, depth, t_est):
    """One damped design from contact at speed ``v0`` (SI): (time [s], final depth [m], final speed [m/s],
    damping energy [J], inertia energy [J], peak R [N], its depth [m], end code)."""
    t, x, v = 0.0, 0.0, v0
    e_damp, e_inert = 0.0, 0.0
    peak, peak_x = _reduced(0.0, max(v0, 0.0), a0, a1, b, d), 0.0  # R just inside the surface
    start = mg - a0 + (kd * xk if xk > 0.0 else 0.0)
    if v <= 0.0 and start <= 0.0:
        return t, x, v, e_damp, e_inert, peak, peak_x, ARREST
    h = min(max(t_est, 1e-9), 10.0) / STEPS
    creep_at, creep_speed, creep_rest, _ = _creep_point(m, kd, xk, mg, a0, a1, b, depth)  # nan: cannot creep

    # ---- 1. RK4 until the design ends or reaches the linear regime
    linear = _linear_ready(x, v, m, kd, xk, mg, a0, a1, b, d)
    count = 0
    h_plan = h
    while not linear:
        count += 1
        if count > HANDOVER_STEPS:  # stiff: the linear flow, whose steps bound the linearisation's error
            break
        h = min(h_plan, STIFF_STEP * m / (b + 2.0 * d * max(v, 0.0)))
        xs, vs = x, v
        xn, vn, ed, ei, a_s, an = _step(xs, vs, h, m, kd, xk, mg, a0, a1, b, d)
        # where the step ends: arrest (v = 0) on the cubic Hermite interpolant; full depth, or the springs'
        # free length (the force's slope jumps there), by a step redone to end there
        stop_v = vn <= 0.0
        s = 1.0
        if stop_v:
            s = _bisect(False, 0, 0.0, 1.0, (xs, vs, a_s, xn, vn, an, h, 0.0, 0.0, 0.0, a1, b, d, 0.0, 0.0, 0.0, 0.0))
        x_reach = _hermite_xv(xs, vs, a_s, xn, vn, an, h, s)[0] if stop_v else xn
        kink = xs < xk < depth and x_reach >= xk
        # creep (the rule pen predict uses): the tip passes x* − δ, before any other event of the step, slowly
        if xs < creep_at <= x_reach and not (kink and xk <= creep_at):
            s_c = _bisect(False, 1, creep_at, s, (xs, vs, a_s, xn, vn, an, h, 0.0, 0.0, 0.0, a1, b, d, 0.0, 0.0, 0.0,
                                                   0.0))
            if _hermite_xv(xs, vs, a_s, xn, vn, an, h, s_c)[1] <= creep_speed:
                x_c, v_c, ed, ei, _, _ = _step(xs, vs, s_c * h, m, kd, xk, mg, a0, a1, b, d)
                r_c = _reduced(x_c, max(v_c, 0.0), a0, a1, b, d)
                if r_c > peak:
                    peak, peak_x = r_c, x_c
                e_damp += ed + _static_work(x_c, creep_rest, xk, kd, mg, a0, a1) + 0.5 * m * v_c * v_c
                return t + s_c * h, creep_rest, 0.0, e_damp, e_inert + ei, peak, peak_x, CREEP
        stop_x = not kink and x_reach >= depth  # maybe passed before v = 0 in the same step
        cut = kink or stop_x
        if cut:
            target = xk if kink else depth
            s = _bisect(False, 1, target, s, (xs, vs, a_s, xn, vn, an, h, 0.0, 0.0, 0.0, a1, b, d, 0.0, 0.0, 0.0, 0.0))
            x_cut, v_cut, ed, ei, _, a_cut = _step(xs, vs, s * h, m, kd, xk, mg, a0, a1, b, d)
            # land exactly on the target: move the remaining round-off of x with the energy it costs
            xn = target
            vn = math.sqrt(max(v_cut * v_cut + 2.0 * a_cut * (target - x_cut), 0.0))
            an = _accel(xn, vn, m, kd, xk, mg, a0, a1, b, d)
            stop_v = False
        if stop_v:  # an arrest's energies: Gauss on the interpolant (v³ is degree 9: exact)
            ed, ei = 0.0, 0.0
            for i in range(5):
                vq = max(_hermite_xv(xs, vs, a_s, xn, vn, an, h, s * _G5_NODES[i])[1], 0.0)
                ed += _G5_WEIGHTS[i] * s * h * b * vq * vq
                ei += _G5_WEIGHTS[i] * s * h * d * vq ** 3
        if cut:
            x_end, v_end, h_used, s_used = xn, vn, s * h, 1.0  # a cut step was redone to its end
        else:
            x_end, v_end = _hermite_xv(xs, vs, a_s, xn, vn, an, h, s if stop_v else 1.0)
            if stop_v:
                v_end = 0.0
            h_used, s_used = h, s
        # peak of R: at the step's end, or inside where dR/ds changes sign
        r_end = _reduced(x_end, max(v_end, 0.0), a0, a1, b, d)
        if r_end > peak:
            peak, peak_x = r_end, x_end
        rise0 = a1 * vs + (b + 2.0 * d * max(vs, 0.0)) * a_s
        rise1 = _resistance_slope(xs, vs, a_s, xn, vn, an, h_used, s_used, a1, b, d)
        if rise0 > 0.0 and rise1 < 0.0:
            s_top = _bisect(False, 2, 0.0, s_used,
                            (xs, vs, a_s, xn, vn, an, h_used, 0.0, 0.0, 0.0, a1, b, d, 0.0, 0.0, 0.0, 0.0))
            xm, vm = _hermite_xv(xs, vs, a_s, xn, vn, an, h_used, s_top)
            rm = _reduced(xm, max(vm, 0.0), a0, a1, b, d)
            if rm > peak:
                peak, peak_x = rm, xm
        t += s * h
        e_damp += ed
        e_inert += ei
        x, v = x_end, v_end
        if stop_v or stop_x:
            return t, x, v, e_damp, e_inert, peak, peak_x, FULL_DEPTH if stop_x else ARREST
        if count % STEPS == 0:
            h_plan *= 2.0
        if count % 8 == 0 or count == 1:  # regime check: hand over to the exact linear flow
            linear = _linear_ready(x, v, m, kd, xk, mg, a0, a1, b, d)

    # ---- 2. the exact linear flow, events located on it
    v = max(v, 0.0)
    for _ in range(MAX_STEPS):
        in_spring = x < xk
        F0 = (kd * xk if in_spring else 0.0) + mg - a0
        k = (kd if in_spring else 0.0) + a1
        vr = v
        b_lin = b + 2.0 * d * vr  # d·v² ≈ d·(2·vr·v − vr²) about this step's start
        F_lin = F0 + d * vr * vr
        x_star = rest_depth(F_lin, k)
        sigma, w2 = -0.5 * b_lin / m, k / m
        mu2 = sigma * sigma - w2
        acc = abs(F_lin - k * x - b_lin * v) / m
        cap = math.inf
        if d > 0.0:
            dv_max = max(math.sqrt(LINEARISE_TOL * b * v / d), LINEARISE_TOL * b / d)
            cap = dv_max / max(acc, 1e-300)
        if mu2 < 0.0:
            cap = min(cap, 0.5 * math.pi / math.sqrt(-mu2))
        h = min(2.0 * h, cap)
        shifted = k * depth > 1e-9 * abs(F_lin)  # a rest depth within reach of float64
        xi0 = x - x_star if shifted else 0.0
        v_term = F_lin / b_lin  # k = 0: v tends to F/b
        flow = (h, xi0, v, sigma, mu2, w2, x_star, 1.0 if shifted else 0.0, x, v_term, a1, b, d, F_lin, k, b_lin, m)
        x1, v1 = _at(True, 1.0, flow)
        s_end = 1.0
        kind = -1
        # arrest: v changes sign at most once in a step (overdamped always; underdamped by the cap)
        if v1 <= 0.0:
            s_end = _bisect(True, 0, 0.0, 1.0, flow)
            kind = ARREST
        x_far = _at(True, s_end, flow)[0]  # x rises while v > 0
        # the first of: full depth, springs at free length, creep — each before s_end
        for event in range(3):
            if event == 0:
                name, target, applies = FULL_DEPTH, depth, True
            elif event == 1:
                name, target, applies = _KINK, xk, in_spring and xk < depth
            else:
                name, target, applies = CREEP, creep_at, creep_at == creep_at  # not nan: the design can creep
            if not (applies and target > x and x_far >= target):
                continue
            s_hit = _bisect(True, 1, target, s_end, flow)
            if name == CREEP:  # only a slow approach creeps; a fast one overshoots and arrests
                if not _at(True, s_hit, flow)[1] <= creep_speed:
                    continue
            if s_hit <= s_end:
                s_end, kind, x_far = s_hit, name, target
        x_new, v_new = _at(True, s_end, flow)
        if kind == FULL_DEPTH or kind == _KINK or kind == CREEP:
            x_new = x_far  # on the target
        v_new = 0.0 if kind == ARREST else max(v_new, 0.0)
        # peak of R inside the step (R' = a1·v + (b + 2dv)·a changes sign) and at its end
        r1 = _reduced(x_new, v_new, a0, a1, b, d)
        if r1 > peak:
            peak, peak_x = r1, x_new
        if _rise(True, 0.0, flow) > 0.0 and _rise(True, s_end, flow) < 0.0:
            s_top = _bisect(True, 2, 0.0, s_end, flow)
            xt, vt = _at(True, s_top, flow)
            rt = _reduced(xt, max(vt, 0.0), a0, a1, b, d)
            if rt > peak:
                peak, peak_x = rt, xt
        # energies: the rate terms dissipate the work of F less the gain in kinetic energy
        work = _static_work(x, x_new, xk, kd, mg, a0, a1)
        dissipated = work - 0.5 * m * (v_new * v_new - v * v)
        v_mid = 0.5 * (v + v_new)
        share = d * v_mid / (b + d * v_mid) if b + d * v_mid > 0.0 else 0.0
        e_inert += share * dissipated
        e_damp += (1.0 - share) * dissipated
        t += s_end * h
        x = xk if kind == _KINK else x_new
        v = v_new
        if kind == CREEP:  # the run is booked at its rest depth, where the motion tends
            e_damp += _static_work(x, creep_rest, xk, kd, mg, a0, a1) + 0.5 * m * v * v
            return t, creep_rest, 0.0, e_damp, e_inert, peak, peak_x, CREEP
        if kind == ARREST or kind == FULL_DEPTH:
            return t, x, v, e_damp, e_inert, peak, peak_x, kind
    return t, x, v, e_damp, e_inert, peak, peak_x, STALLED


__all__ = ["ARREST", "CREEP", "FULL_DEPTH", "HANDOVER_STEPS", "LINEAR_TOL", "MAX_STEPS", "STALLED", "STEPS",
           "rest_depth", "run_one"]
