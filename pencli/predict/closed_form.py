r"""Penetration without damping (C = 0, every Table 1 material) in closed form over depth.

With :math:`q = \dot x^2` and depth as the independent variable, CONTRACT §2 with Eq. 9 at C = 0 is

.. math::

    \frac{dq}{dx} = \frac{2}{m}\,F(x) - \lambda q, \qquad
    F(x) = \eta n k\,\max(x_k - x, 0) + m g - a_0 - a_1 x, \qquad \lambda = \frac{2 d}{m}

(:math:`x_k` = depth where the springs reach free length, :math:`d = w T K \rho`).  F is linear on each
side of :math:`x_k`, so on each such segment, from a start :math:`x_s` with :math:`q_s`,

.. math::

    q(x_s + \Delta) = q_s e^{z} + f_s \Delta\,\varphi_1(z) + \beta \Delta^2 \varphi_2(z), \qquad z = -\lambda\Delta

with :math:`f = 2F/m = f_s + \beta\Delta`, :math:`\varphi_1(z) = (e^z - 1)/z`,
:math:`\varphi_2(z) = (e^z - 1 - z)/z^2`.  From it, exactly (to round-off):

- arrest is the root of q on the segment (q rises then falls on a segment: :math:`q'' = \beta - \lambda q'`
  has :math:`q''' = -\lambda q''`, so q' is monotone), found by Halley steps inside a bracket;
- full depth is q(X) > 0, the residual energy :math:`m q(X)/2` exact however close X is to the arrest depth;
- time is :math:`\int dx/\sqrt{q}`, by Gauss–Legendre after the substitution :math:`x = a \pm (x_m - a)s^2`
  about the (real or extrapolated) zeros a of q at either end, which removes the :math:`1/\sqrt{\;}` of an
  arrest, of a start from rest and of a limit just short of the arrest depth;
- the peak of :math:`R = a_0 + a_1 x + d q` is at a segment end or where :math:`R' = a_1 + d q'` (monotone)
  changes sign;
- the inertia energy is the work of F less the gain in kinetic energy.

Each design is worked through on its own (scalar code compiled by numba; the sweep spreads chunks of
designs over threads): the number of Halley steps and which segments a design crosses are its own, and no array
temporaries are made.  Plain numpy with the same arithmetic ran at 0.47 s per 100,000 designs on one
core; see docs/performance.md for the compiled figure.

Units SI; pure functions (no I/O).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from pencli.predict.compiled import JIT as _JIT
from pencli.predict.compiled import reduced as _reduced
from pencli.predict.compiled import static_work as _static_work


GAUSS_NODES = 8
"""Gauss–Legendre nodes on each half of a segment (the integrands are smooth after the substitution).
Against the tight oracle on 40 random designs: 16 nodes give 1.3e-9 in penetration time, 12 give 1.3e-8,
8 give 1.3e-7; on 200,000 random designs 8 nodes stay within 2.6e-7 of 12.  8 cost 26 % less time than
12, well inside the sweep's 1e-4."""

_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(GAUSS_NODES)
_UNIT = 0.5 * (_NODES + 1.0)  # nodes on [0, 1]
_UNIT_W = 0.5 * _WEIGHTS
_TINY = 1e-300
_MAX_NEWTON = 80



_PHI2 = np.array([1.0 / math.factorial(k + 2) for k in range(16)])
"""Taylor coefficients of φ2(z) = Σ z^k/(k + 2)!: on −1 ≤ z ≤ 0 these 16 terms give φ2, φ1 = 1 + zφ2 and
e^z = 1 + zφ1 to 1e-15 (checked against 40-digit arithmetic)."""


@njit(**_JIT)
def _q_series(dx, qs, fs, beta, lam):
    """v² at ``dx`` past the segment's start from the φ2 series (no call to exp); only where
    −1 ≤ −λ·dx ≤ 0.  φ2 by Estrin's scheme (five dependent multiply-adds where Horner takes fifteen).
    [m²/s²]"""
    z = -lam * dx
    c = _PHI2
    z2 = z * z
    z4 = z2 * z2
    p2 = (((c[0] + c[1] * z) + (c[2] + c[3] * z) * z2) + ((c[4] + c[5] * z) + (c[6] + c[7] * z) * z2) * z4
          + (((c[8] + c[9] * z) + (c[10] + c[11] * z) * z2)
             + ((c[12] + c[13] * z) + (c[14] + c[15] * z) * z2) * z4) * (z4 * z4))
    p1 = 1.0 + z * p2
    return qs * (1.0 + z * p1) + dx * (fs * p1 + beta * dx * p2)


# A segment is (xs, qs, fs, beta, lam): it starts at depth xs [m] with q = v² = qs [m²/s²]; there
# 2F/m = fs + beta·(x − xs) [m/s²] and λ = 2d/m [1/m].

@njit(**_JIT)
def q_at(x, xs, qs, fs, beta, lam):
    """v² at depth x on the segment, from the closed form (by the φ2 series where −1 ≤ −λ(x − xs) ≤ 0, as
    nearly everywhere on a segment: no call to exp). [m²/s²]"""
    dx = x - xs
    z = -lam * dx
    if -1.0 <= z <= 0.0:
        return _q_series(dx, qs, fs, beta, lam)
    em1 = math.expm1(z)
    if abs(z) < 1e-3:
        p1 = 1.0 + z * (0.5 + z * (1.0 / 6.0 + z / 24.0))  # φ1
        p2 = 0.5 + z * (1.0 / 6.0 + z * (1.0 / 24.0 + z / 120.0))  # φ2
    else:
        p1 = em1 / z
        p2 = (p1 - 1.0) / z
    return qs * (em1 + 1.0) + dx * (fs * p1 + beta * dx * p2)


@njit(**_JIT)
def slope_at(x, q, xs, fs, beta, lam):
    """dq/dx = 2F/m − λq at depth x where v² = q. [m/s²]"""
    return fs + beta * (x - xs) - lam * q


@njit(**_JIT)
def _q_and_slopes(x, xs, qs, fs, beta, lam):
    """(q, q', q'') at x for the arrest search; q'' = β − λq' on a segment."""
    q = q_at(x, xs, qs, fs, beta, lam)
    s = slope_at(x, q, xs, fs, beta, lam)
    return q, s, beta - lam * s


@njit(**_JIT)
def slope_root(c, xs, qs, fs, beta, lam, lo, hi):
    """Where q' = c on the segment, within [lo, hi] (the caller knows q' − c changes sign there). [m]

    q' obeys q'' = β − λq', so q'(xs + Δ) = q'_s + (β − λq'_s)(1 − e^{−λΔ})/λ: the root is
    Δ = −log1p(−λr)/λ with r = (c − q'_s)/(β − λq'_s), or Δ = r where λ = 0 (one log instead of a Halley
    search).
    """
    slope_s = fs - lam * qs
    rate = beta - lam * slope_s
    r = (c - slope_s) / rate if rate != 0.0 else 0.0
    z = lam * r
    step = r if abs(z) < 1e-300 else (-math.log1p(-z) / lam if z < 1.0 else hi - xs)
    return min(max(xs + step, lo), hi)


@njit(**_JIT)
def arrest_root(xs, qs, fs, beta, lam, lo, hi):
    """Where q = v² reaches 0 in [lo, hi] on the segment, q of opposite signs at the ends (or zero at one). [m]

    Halley steps (f'' costs nothing more here), the first taken at ``lo``, with bisection whenever a step
    leaves the bracket.  Halley converges cubically, so once a step is below 1e-7 of the scale the point it
    lands on is the root to round-off (the next step would be of order 1e-21 of it) -- provided Newton's
    step f/f' is that small too: where f' nearly vanishes (near the top of q) Halley's step is tiny far from
    the root, and the search bisects instead.
    """
    f_lo, d_lo, c_lo = _q_and_slopes(lo, xs, qs, fs, beta, lam)
    if f_lo == 0.0:
        return lo
    up = f_lo > 0.0
    den = 2.0 * d_lo * d_lo - f_lo * c_lo
    x = lo - 2.0 * f_lo * d_lo / den if den != 0.0 else math.nan
    if not (lo < x < hi):  # the secant across the bracket, else its middle
        f_hi = _q_and_slopes(hi, xs, qs, fs, beta, lam)[0]
        if f_hi == 0.0:
            return hi
        x = lo - f_lo * (hi - lo) / (f_hi - f_lo) if f_hi != f_lo else math.nan
        if not (lo < x < hi):
            x = 0.5 * (lo + hi)
    for _ in range(_MAX_NEWTON):
        fx, dfx, cfx = _q_and_slopes(x, xs, qs, fs, beta, lam)
        if fx == 0.0:
            return x
        if (fx > 0.0) == up:
            lo = x
        else:
            hi = x
        den = 2.0 * dfx * dfx - fx * cfx
        step = 2.0 * fx * dfx / den if den != 0.0 else math.nan
        x_new = x - step
        tol = 1e-7 * max(abs(x), hi - lo)
        if lo < x_new < hi and abs(step) <= tol and not abs(fx) <= 2.0 * tol * abs(dfx):
            x_new = 0.5 * (lo + hi)  # a tiny step where f' is nearly 0 is a flat spot, not the root: bisect
        elif lo < x_new < hi:
            if abs(step) <= tol:
                return x_new
        else:
            x_new = 0.5 * (lo + hi)
            if hi - lo <= 4e-16 * max(abs(lo), abs(hi)):
                return x_new
        x = x_new
    return x


@njit(**dict(_JIT, fastmath={"reassoc", "contract", "arcp"}))
def _halves_sum(anchor_l, span_l, s_lo_l, anchor_r, span_r, s_lo_r, xs, qs, fs, beta, lam):
    """Σ wᵢ sᵢ/√q(xᵢ) over each half's Gauss nodes (left half from ``anchor_l`` up, right half from
    ``anchor_r`` down), q from the φ2 series: the two halves' nodes side by side in one loop, so their
    independent chains of arithmetic overlap.  Only where −1 ≤ −λ(x − xs) ≤ 0 at every node."""
    acc_l = 0.0
    acc_r = 0.0
    for i in range(GAUSS_NODES):
        s_l = s_lo_l + (1.0 - s_lo_l) * _UNIT[i]
        s_r = s_lo_r + (1.0 - s_lo_r) * _UNIT[i]
        q_l = _q_series(anchor_l + span_l * s_l * s_l - xs, qs, fs, beta, lam)
        q_r = _q_series(anchor_r - span_r * s_r * s_r - xs, qs, fs, beta, lam)
        acc_l += _UNIT_W[i] * s_l / math.sqrt(max(q_l, _TINY))
        acc_r += _UNIT_W[i] * s_r / math.sqrt(max(q_r, _TINY))
    return acc_l, acc_r


@njit(**_JIT)
def _piece_time(xs, qs, fs, beta, lam, xe, qe, at_root):
    """∫ dx/√q from xs to xe along the segment, by one substituted Gauss rule. [s]

    ``at_root``: q(xe) = 0 (an arrest at xe).  Each half of [xs, xe] is substituted about a zero of q: the
    end's own when q vanishes there, else the zero that q's tangent reaches beyond the end (at most half
    the segment away), so that the integrand is smooth for Gauss–Legendre however small q is at an end.
    The nodes lie in [xs, xe], so where λ(xe − xs) ≤ 1 (nearly every design) q comes from the φ2 series.
    """
    length = xe - xs
    if not length > 0.0:
        return 0.0
    half = 0.5 * length
    # each half as x = anchor ± span·s², s from s_lo to 1, anchored g beyond its end: g = q/q' where the
    # tangent's zero lies within half a segment (q < q'·half), else half; span = half + g and
    # s_lo² = g/span = q/(q'·half + q), one division each
    reach_s = slope_at(xs, qs, xs, fs, beta, lam) * half
    if reach_s > qs:
        g_left, s_left = qs * half / reach_s, math.sqrt(qs / (reach_s + qs))
    else:
        g_left, s_left = half, math.sqrt(0.5)
    reach_e = -slope_at(xe, qe, xs, fs, beta, lam) * half
    if at_root:
        g_right, s_right = 0.0, 0.0
    elif reach_e > qe:
        g_right, s_right = qe * half / reach_e, math.sqrt(qe / (reach_e + qe))
    else:
        g_right, s_right = half, math.sqrt(0.5)
    span_left, span_right = half + g_left, half + g_right
    if lam * length <= 1.0:
        acc = _halves_sum(xs - g_left, span_left, s_left, xe + g_right, span_right, s_right, xs, qs, fs, beta, lam)
    else:  # q from its exponential form
        acc = (0.0, 0.0)
        for side in range(2):
            sign = 1.0 if side == 0 else -1.0
            anchor, span, s_lo = (xs - g_left, span_left, s_left) if side == 0 else (xe + g_right, span_right, s_right)
            part = 0.0
            for i in range(GAUSS_NODES):
                s = s_lo + (1.0 - s_lo) * _UNIT[i]
                q = max(q_at(anchor + sign * span * s * s, xs, qs, fs, beta, lam), _TINY)
                part += _UNIT_W[i] * s / math.sqrt(q)
            acc = (part, acc[1]) if side == 0 else (acc[0], part)
    return (1.0 - s_left) * 2.0 * span_left * acc[0] + (1.0 - s_right) * 2.0 * span_right * acc[1]


@njit(**_JIT)
def travel_time(xs, qs, fs, beta, lam, xe, qe, at_root):
    """∫ dx/√q from xs to xe along the segment. [s]

    ``at_root``: q(xe) = 0 (an arrest at xe).  Where λ(xe − xs) ≤ 1 (nearly every design) one substituted
    Gauss rule (:func:`_piece_time`) takes the whole segment.  Beyond, q holds a transient e^{−λ(x − xs)}
    that 1/√q turns into a growth as steep as e^{λ(x − xs)/2}, which one rule cannot follow (1.7e-3 off
    in time at λ·130 mm = 813, a light body with a wide blade in dense material): the segment is cut into
    pieces over each of which q changes by about a factor e (length q/|q'|, at least 1/λ), and the
    last piece, from where q/|q'| covers half of what is left, takes the rest.  At most
    :data:`_MAX_PIECES` pieces.
    """
    if not lam * (xe - xs) > 1.0:
        return _piece_time(xs, qs, fs, beta, lam, xe, qe, at_root)
    total = 0.0
    x, q, f = xs, qs, fs
    for _ in range(_MAX_PIECES):
        rest = xe - x
        scale = q / abs(f - lam * q) if f - lam * q != 0.0 else rest  # q/|q'|
        if scale >= 0.5 * rest:
            break
        step = max(scale, 1.0 / lam)
        if step >= rest:
            break
        x_next = x + step
        q_next = q_at(x_next, xs, qs, fs, beta, lam)
        total += _piece_time(x, q, f, beta, lam, x_next, q_next, False)
        x, q, f = x_next, q_next, fs + beta * (x_next - xs)
    return total + _piece_time(x, q, f, beta, lam, xe, qe, at_root)


_MAX_PIECES = 400
"""Pieces of one segment's time integral at most (the transient of q needs about ln(q_start/q_steady))."""


@njit(**_JIT)
def peak_on(xs, qs, fs, beta, lam, xe, qe, a0, a1, d):
    """Largest R = a0 + a1·x + d·q on [xs, xe] of the segment, and its depth. [N, m]"""
    r_s = _reduced(xs, math.sqrt(qs), a0, a1, 0.0, d)
    r_e = _reduced(xe, math.sqrt(qe), a0, a1, 0.0, d)
    best, where = (r_e, xe) if r_e > r_s else (r_s, xs)
    rise_s = a1 + d * slope_at(xs, qs, xs, fs, beta, lam)  # R' = a1 + d·q', monotone on the segment
    rise_e = a1 + d * slope_at(xe, qe, xs, fs, beta, lam)
    if rise_s > 0.0 and rise_e < 0.0 and xe > xs:
        x_top = slope_root(-a1 / d, xs, qs, fs, beta, lam, xs, xe)
        r_top = _reduced(x_top, math.sqrt(max(q_at(x_top, xs, qs, fs, beta, lam), 0.0)), a0, a1, 0.0, d)
        if r_top > best:
            best, where = r_top, x_top
    return best, where


@njit(**_JIT)
def penetrate_one(v0, m, kd, xk, mg, a0, a1, d, depth):
    """One design entering the material at speed ``v0`` (SI): time [s], final depth [m], final speed [m/s],
    full depth reached, peak R [N] and its depth [m], inertia energy [J].  ``xk``: depth at which the springs
    reach free length (≤ 0: already spent at contact)."""
    lam = 2.0 * d / m
    t = 0.0
    peak, peak_x = _reduced(0.0, v0, a0, a1, 0.0, d), 0.0
    xs, qs = 0.0, v0 * v0
    x_end, q_end, full = 0.0, 0.0, False
    for segment in range(2):  # springs pushing on [0, min(xk, X)], then free on [max(xk, 0), X]
        if segment == 0:
            if not xk > 0.0:
                continue
            xe = min(xk, depth)
            fs = 2.0 / m * (kd * xk + mg - a0)
            beta = -2.0 / m * (kd + a1)
        else:
            xe = depth
            fs = 2.0 / m * (mg - a0 - a1 * xs)
            beta = -2.0 / m * a1
        blocked = qs <= 0.0 and fs <= 0.0  # at rest and pushed back: stops where it is
        qe = q_at(xe, xs, qs, fs, beta, lam)
        stops = not blocked and qe <= 0.0
        x_stop = xs if blocked else xe
        if stops:
            lo = xs
            if qs <= 0.0:  # from rest: the zero sought is past the maximum of q
                lo = slope_root(0.0, xs, qs, fs, beta, lam, xs, xe)
            x_stop = arrest_root(xs, qs, fs, beta, lam, lo, xe)
        ended = blocked or stops
        q_stop = 0.0 if ended else qe
        if not blocked:
            t += travel_time(xs, qs, fs, beta, lam, x_stop, q_stop, ended)
        pk, pkx = peak_on(xs, qs, fs, beta, lam, x_stop, q_stop, a0, a1, d)
        if pk > peak:
            peak, peak_x = pk, pkx
        full = not ended and xe >= depth
        x_end, q_end = x_stop, q_stop
        xs, qs = x_stop, q_stop
        if ended or full:
            break
    work = _static_work(0.0, x_end, xk, kd, mg, a0, a1)  # ∫F dx over the penetration
    return t, x_end, math.sqrt(max(q_end, 0.0)), full, peak, peak_x, work - 0.5 * m * (q_end - v0 * v0)


__all__ = ["GAUSS_NODES", "arrest_root", "penetrate_one", "peak_on", "q_at", "slope_at", "slope_root",
           "travel_time"]
