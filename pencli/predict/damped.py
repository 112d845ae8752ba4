r"""Penetration with damping (C > 0) over arrays of designs, time as the independent variable.

In the material the motion obeys :math:`m\ddot x = F(x) - b\dot x - d\dot x^2` with F piecewise linear
(springs pushing until :math:`x_k`, then not), b = wTC and d = wTKρ.  Two regimes:

1. **Taylor series** of order :data:`ORDER`, each design on its own steps.  The right-hand side is a
   polynomial in (x, v), so the series' coefficients follow one from another by a recurrence (the v² term
   is a Cauchy product), and so do those of the damping's and the inertia term's work.  A step is as long
   as the series' last two terms allow within :data:`TAYLOR_TOL` of the design's depth and speed scales
   (Jorba & Zou's rule), so it is set by the motion's own scale (the nearest complex singularity of the
   v² term's Riccati motion, or a few damping times m/b when the damping is heavy), not by a fraction of
   the damping time: around Appendix C a run is one to three steps.  Events (arrest, full depth, springs at
   free length, creep) and the peak of R are found on the step's polynomials.
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

ORDER = 12
"""Degree of the Taylor polynomials of the first regime. [–]"""
TAYLOR_TOL = 1e-10
"""Each Taylor step's last two terms stay within this share of the design's depth (for x) and speed scale
(for v, the larger of the contact speed and √(|F|·depth/m)). [–]"""
WORK_ROWS = 4
"""Rows of the work array :func:`run_one` takes: (WORK_ROWS, ORDER + 1) floats."""
STEPS = 160
"""A design that is linear from contact starts the linear flow on a step of its estimated penetration time
over STEPS (the flow is exact; the steps double from there)."""
_PEAK_SAMPLES = 8
"""The slope of R is sampled at this many points of a Taylor step to find where it turns (a peak), four at a time
(a multiple of 4). [–]"""
assert _PEAK_SAMPLES % 4 == 0
LINEAR_TOL = 1e-5
"""Hand a design to the exact linear flow once d·v ≤ LINEAR_TOL·b. [–]"""
LINEARISE_TOL = 1e-9
"""Linear-flow steps are limited so that the linearised v² term errs by at most this fraction of the
damping force: d·Δv² ≤ LINEARISE_TOL·b·v. [–]"""
HANDOVER_STEPS = 2_500
"""Taylor steps after which the exact linear flow takes over even while d·v > LINEAR_TOL·b (its steps are then
capped so that the linearised v² term stays within LINEARISE_TOL): a heavily damped design creeps for
thousands of damping times (a 50-s creep at C = 42,000 kPa·s/m), which explicit steps of a few damping times
each cannot afford."""
MAX_STEPS = 2_000_000
"""Linear-flow steps per design at most; a design still moving after them ends as ``stalled`` (one of 2,000
damped designs of bench_batch_fuzz, seed 7, C up to 10⁸ Pa·s/m, did before the first regime handed over by
step count)."""
_BISECT = 60
_ROOT_TOL = 1e-6
"""Newton on a step's polynomial stops once its correction is below this share of the bracket: the point it
moved to is then off by about the square of it (10⁻¹²). [–]"""
_INVERSE = 1.0 / np.arange(1.0, 65.0)
_INVERSE = np.concatenate((np.array([np.inf]), _INVERSE))  # _INVERSE[i] = 1/i
_G4_NODES, _G4_WEIGHTS = np.polynomial.legendre.leggauss(4)
_G4_NODES, _G4_WEIGHTS = 0.5 * (_G4_NODES + 1.0), 0.5 * _G4_WEIGHTS  # on [0, 1]
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
def _at(s, p):
    """(x, v) at the fraction s of a linear-flow step (``p`` = h, ξ0, v, σ, μ², ω², x*, shifted, x0, v_term, …)."""
    return _lin_state(s, p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7] > 0.0, p[8], p[9])


@njit(**_JIT)
def _rise(s, p):
    """A quantity with the sign of dR/dt at the fraction s of a linear-flow step (R = a0 + a1·x + b·v + d·v²);
    ``p[10:13]`` = a1, b, d and ``p[13:17]`` = F, k, b of the linearised force and m."""
    fa1, b, d = p[10], p[11], p[12]
    x, v = _at(s, p)
    return fa1 * v + (b + 2.0 * d * v) * (p[13] - p[14] * x - p[15] * v) / p[16]


@njit(**_JIT)
def _bisect(mode, target, hi, p):
    """Largest s in [0, hi] where (mode 0) v(s) > 0, (1) x(s) < target, (2) dR/dt > 0 on a linear-flow step;
    the condition holds at 0 and fails at hi."""
    lo = 0.0
    for _ in range(_BISECT):
        mid = 0.5 * (lo + hi)
        if mode == 2:
            up = _rise(mid, p) > 0.0
        else:
            x, v = _at(mid, p)
            up = v > 0.0 if mode == 0 else target - x > 0.0
        if up:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


@njit(**_JIT)
def _series(wk, n, x, v, F0, k, m, b, d):
    """Taylor coefficients to degree n of the motion m·x'' = F0 − k·x − b·x' − d·x'² from (x, v) into the rows
    of ``wk``: x, v and v² (to degree n − 1).  The v² term is a Cauchy product, so each coefficient follows
    from the ones before (automatic differentiation of a polynomial field)."""
    X, V, Q = wk[0], wk[1], wk[2]
    X[0], V[0] = x, v
    for i in range(n):
        q = 0.0
        for j in range((i + 1) // 2):  # the product is symmetric: each pair twice, the middle term once
            q += V[j] * V[i - j]
        q *= 2.0
        if i % 2 == 0:
            q += V[i // 2] * V[i // 2]
        Q[i] = q
        X[i + 1] = V[i] * _INVERSE[i + 1]
        V[i + 1] = ((F0 if i == 0 else 0.0) - k * X[i] - b * V[i] - d * q) * (_INVERSE[i + 1] / m)


@njit(**_JIT)
def _event(event, depth, xk, in_spring, creep_at):
    """(end code, depth it happens at [m], whether it can happen) of a step's events, in the order they are
    looked for: full depth, the springs at free length, creep (``creep_at`` NaN: the design cannot creep)."""
    if event == 0:
        return FULL_DEPTH, depth, True
    if event == 1:
        return _KINK, xk, in_spring and xk < depth
    return CREEP, creep_at, creep_at == creep_at


@njit(**_JIT)
def _step_length(X, V, n, x_tol, v_tol):
    """The step whose last two terms of the series of degree n stay within x_tol and v_tol (Jorba & Zou's
    rule); inf when they vanish. [s]"""
    h = math.inf
    for p in (n - 1, n):
        ratio = min(x_tol / abs(X[p]) if X[p] != 0.0 else math.inf, v_tol / abs(V[p]) if V[p] != 0.0 else math.inf)
        if ratio < math.inf:
            h = min(h, ratio ** (1.0 / p))
    return h


@njit(**_JIT)
def _poly(c, n, s):
    """Σ c[i]·s^i for i ≤ n (Horner)."""
    y = c[n]
    for i in range(n - 1, -1, -1):
        y = y * s + c[i]
    return y


@njit(**_JIT)
def _poly_pair(c, e, n, s):
    """(Σ c[i]·s^i, Σ e[i]·s^i) for i ≤ n: two Horner chains in one loop (they run side by side)."""
    y, z = c[n], e[n]
    for i in range(n - 1, -1, -1):
        y = y * s + c[i]
        z = z * s + e[i]
    return y, z


@njit(**_JIT)
def _poly_and_slope(c, n, s):
    """(Σ c[i]·s^i, its derivative) for i ≤ n, in one loop."""
    y, dy = c[n], 0.0
    for i in range(n - 1, -1, -1):
        dy = dy * s + y
        y = y * s + c[i]
    return y, dy


@njit(**_JIT)
def _poly4(c, n, s0, s1, s2, s3):
    """Σ c[i]·s^i at four points, the four chains side by side."""
    y0 = y1 = y2 = y3 = c[n]
    for i in range(n - 1, -1, -1):
        y0 = y0 * s0 + c[i]
        y1 = y1 * s1 + c[i]
        y2 = y2 * s2 + c[i]
        y3 = y3 * s3 + c[i]
    return y0, y1, y2, y3


@njit(**_JIT)
def _rate_integrals(V, n, s):
    """(∫₀^s v², ∫₀^s v³) for v(u) = Σ V[i]·u^i (i ≤ n): Gauss–Legendre on four nodes.  A Taylor step is a
    small share of the series' radius of convergence ρ (about TAYLOR_TOL^(1/ORDER)·ρ = 0.15·ρ at the defaults),
    so the rule errs by about (step/4ρ)⁸ of the integral, 10⁻¹¹."""
    v4 = _poly4(V, n, s * _G4_NODES[0], s * _G4_NODES[1], s * _G4_NODES[2], s * _G4_NODES[3])
    v2 = v3 = 0.0
    for j in range(4):
        w_sq = _G4_WEIGHTS[j] * v4[j] * v4[j]
        v2 += w_sq
        v3 += w_sq * v4[j]
    return v2 * s, v3 * s


@njit(**_JIT)
def _root(c, n, target, lo, hi, f_lo, f_hi):
    """s in (lo, hi] where the polynomial ``c`` of degree n crosses ``target`` (f_lo = c(lo) − target on one side
    of 0, f_hi = c(hi) − target on the other or 0): Newton kept inside the bracket by bisection, to
    round-off."""
    below = f_lo < 0.0
    s = lo + (hi - lo) * f_lo / (f_lo - f_hi) if f_lo != f_hi else 0.5 * (lo + hi)  # the secant's guess
    width = hi - lo
    for _ in range(_BISECT):
        f, slope = _poly_and_slope(c, n, s)
        f -= target
        if f == 0.0:
            return s
        if (f < 0.0) == below:
            lo = s
        else:
            hi = s
        step = s - f / slope if slope != 0.0 else 0.5 * (lo + hi)
        s_new = step if lo < step < hi else 0.5 * (lo + hi)
        if abs(s_new - s) <= _ROOT_TOL * width:  # s_new is then off by about the square of this correction
            return s_new
        s = s_new
    return s


@njit(**_JIT)
def run_one(v0, m, kd, xk, mg, a0, a1, b, d, depth, t_est, wk):
    """One damped design from contact at speed ``v0`` (SI; ``wk`` a work array of :data:`WORK_ROWS` ×
    ``ORDER + 1`` floats, ``t_est`` a rough penetration time): (time [s], final depth [m], final speed [m/s],
    damping energy [J], inertia energy [J], peak R [N], its depth [m], end code)."""
    t, x, v = 0.0, 0.0, v0
    e_damp, e_inert = 0.0, 0.0
    peak, peak_x = _reduced(0.0, max(v0, 0.0), a0, a1, b, d), 0.0  # R just inside the surface
    start = mg - a0 + (kd * xk if xk > 0.0 else 0.0)
    if v <= 0.0 and start <= 0.0:
        return t, x, v, e_damp, e_inert, peak, peak_x, ARREST
    creep_at, creep_speed, creep_rest, _ = _creep_point(m, kd, xk, mg, a0, a1, b, depth)  # nan: cannot creep

    # ---- 1. Taylor steps until the design ends or reaches the linear regime
    X, V, Q, R = wk[0], wk[1], wk[2], wk[3]
    x_tol = TAYLOR_TOL * depth
    v_tol = TAYLOR_TOL * max(v0, math.sqrt(abs(start) * depth / m))
    n = ORDER
    h = math.inf
    count = 0
    while not _linear_ready(x, v, m, kd, xk, mg, a0, a1, b, d):
        count += 1
        if count > HANDOVER_STEPS:  # stiff: the linear flow, whose steps bound the linearisation's error
            break
        in_spring = x < xk
        F0 = (kd * xk if in_spring else 0.0) + mg - a0
        k = (kd if in_spring else 0.0) + a1
        _series(wk, n, x, v, F0, k, m, b, d)
        h = _step_length(X, V, n, x_tol, v_tol)
        x_far, v_far = _poly_pair(X, V, n, h)
        if not h < math.inf:  # at rest in equilibrium: nothing moves
            return t, x, 0.0, e_damp, e_inert, peak, peak_x, ARREST
        s_end, kind = h, -1
        if v_far <= 0.0:  # arrest: v changes sign once (it cannot rise again from 0 in the material)
            s_end, kind = _root(V, n, 0.0, 0.0, h, v, v_far), ARREST
            x_far = _poly(X, n, s_end)
        for event in range(3):  # the first of: full depth, springs at free length, creep — before s_end
            name, target, applies = _event(event, depth, xk, in_spring, creep_at)
            if not (applies and target > x and x_far >= target):
                continue
            s_hit = _root(X, n, target, 0.0, s_end, x - target, x_far - target)
            if name == CREEP and not _poly(V, n, s_hit) <= creep_speed:
                continue  # only a slow approach creeps; a fast one overshoots and arrests
            if s_hit <= s_end:
                s_end, kind, x_far = s_hit, name, target
        x_new, v_new = _poly_pair(X, V, n, s_end)
        x_new = x_far if kind != -1 else x_new
        v_new = 0.0 if kind == ARREST else max(v_new, 0.0)
        # peak of R = a0 + a1·x + b·v + d·v²: at the step's end, or inside where dR/ds turns from + to −
        for i in range(n - 1):  # the slope of R as a polynomial of degree n − 2
            R[i] = (i + 1) * (a1 * X[i + 1] + b * V[i + 1] + d * Q[i + 1])
        r_end = _reduced(x_new, v_new, a0, a1, b, d)
        if r_end > peak:
            peak, peak_x = r_end, x_new
        bound = R[0]  # an upper bound of the slope on the step: if it stays negative, R only falls
        span = 1.0
        for i in range(1, n - 1):
            span *= s_end
            bound += max(R[i] * span, 0.0)
        rising = R[0] > 0.0
        q = s_end / _PEAK_SAMPLES
        for j0 in range(0, _PEAK_SAMPLES if bound > 0.0 else 0, 4):  # the slope's sign at the samples, 4 at a time
            slopes = _poly4(R, n - 2, (j0 + 1) * q, (j0 + 2) * q, (j0 + 3) * q, (j0 + 4) * q)
            for j in range(4):
                now = slopes[j] > 0.0
                if rising and not now:
                    lo = (j0 + j) * q
                    s_top = _root(R, n - 2, 0.0, lo, lo + q, _poly(R, n - 2, lo), slopes[j])
                    x_top, v_top = _poly_pair(X, V, n, s_top)
                    r_top = _reduced(x_top, max(v_top, 0.0), a0, a1, b, d)
                    if r_top > peak:
                        peak, peak_x = r_top, x_top
                rising = now
        work_v2, work_v3 = _rate_integrals(V, n, s_end)
        e_damp += b * work_v2
        e_inert += d * work_v3
        t += s_end
        x, v = (xk if kind == _KINK else x_new), v_new
        if kind == CREEP:  # the run is booked at its rest depth, where the motion tends
            e_damp += _static_work(x, creep_rest, xk, kd, mg, a0, a1) + 0.5 * m * v * v
            return t, creep_rest, 0.0, e_damp, e_inert, peak, peak_x, CREEP
        if kind == ARREST or kind == FULL_DEPTH:
            return t, x, v, e_damp, e_inert, peak, peak_x, kind
    if count == 0:  # linear from contact: the flow's first step (it doubles from there)
        h = min(max(t_est, 1e-9), 10.0) / STEPS

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
        x1, v1 = _at(1.0, flow)
        s_end = 1.0
        kind = -1
        # arrest: v changes sign at most once in a step (overdamped always; underdamped by the cap)
        if v1 <= 0.0:
            s_end = _bisect(0, 0.0, 1.0, flow)
            kind = ARREST
        x_far = _at(s_end, flow)[0]  # x rises while v > 0
        # the first of: full depth, springs at free length, creep — each before s_end
        for event in range(3):
            name, target, applies = _event(event, depth, xk, in_spring, creep_at)
            if not (applies and target > x and x_far >= target):
                continue
            s_hit = _bisect(1, target, s_end, flow)
            if name == CREEP:  # only a slow approach creeps; a fast one overshoots and arrests
                if not _at(s_hit, flow)[1] <= creep_speed:
                    continue
            if s_hit <= s_end:
                s_end, kind, x_far = s_hit, name, target
        x_new, v_new = _at(s_end, flow)
        if kind == FULL_DEPTH or kind == _KINK or kind == CREEP:
            x_new = x_far  # on the target
        v_new = 0.0 if kind == ARREST else max(v_new, 0.0)
        # peak of R inside the step (R' = a1·v + (b + 2dv)·a changes sign) and at its end
        r1 = _reduced(x_new, v_new, a0, a1, b, d)
        if r1 > peak:
            peak, peak_x = r1, x_new
        if _rise(0.0, flow) > 0.0 and _rise(s_end, flow) < 0.0:
            s_top = _bisect(2, 0.0, s_end, flow)
            xt, vt = _at(s_top, flow)
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


__all__ = ["ARREST", "CREEP", "FULL_DEPTH", "HANDOVER_STEPS", "LINEAR_TOL", "MAX_STEPS", "ORDER", "STALLED", "STEPS",
           "TAYLOR_TOL", "WORK_ROWS", "rest_depth", "run_one"]
