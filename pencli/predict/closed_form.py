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
  has :math:`q''' = -\lambda q''`, so q' is monotone), found by Newton inside a bracket;
- full depth is q(X) > 0, the residual energy :math:`m q(X)/2` exact however close X is to the arrest depth;
- time is :math:`\int dx/\sqrt{q}`, by Gauss–Legendre after the substitution :math:`x = a \pm (x_m - a)s^2`
  about the (real or extrapolated) zeros a of q at either end, which removes the :math:`1/\sqrt{\;}` of an
  arrest, of a start from rest and of a limit just short of the arrest depth;
- the peak of :math:`R = a_0 + a_1 x + d q` is at a segment end or where :math:`R' = a_1 + d q'` (monotone)
  changes sign;
- the inertia energy is the work of F less the gain in kinetic energy.

Units SI; arrays of designs throughout; pure numpy.
"""

from __future__ import annotations

import numpy as np

from pencli.model.design import static_work
from pencli.model.resistance import reduced

GAUSS_NODES = 12
"""Gauss–Legendre nodes on each half of a segment (the integrands are smooth after the substitution):
12 give 1.3e-8 in penetration time on 40 random designs, 16 give 1.3e-9, 8 give 1.3e-7."""

_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(GAUSS_NODES)
_UNIT = 0.5 * (_NODES + 1.0)  # nodes on [0, 1]
_UNIT_W = 0.5 * _WEIGHTS
_TINY = 1e-300


def phi1(z):
    """(e^z − 1)/z, 1 at z = 0; accurate for every z."""
    z = np.asarray(z, dtype=float)
    safe = np.where(z == 0.0, 1.0, z)
    return np.where(z == 0.0, 1.0, np.expm1(safe) / safe)


def phi2(z):
    """(e^z − 1 − z)/z², 1/2 at z = 0; a series where the difference would cancel."""
    z = np.asarray(z, dtype=float)
    small = np.abs(z) < 0.1
    series = 0.0
    for n in range(9, -1, -1):  # Σ z^n/(n+2)!, Horner
        series = 1.0 / _FACT[n + 2] + z * series
    safe = np.where(small, 1.0, z)
    return np.where(small, series, (np.expm1(safe) - safe) / (safe * safe))


_FACT = np.cumprod([1.0] + list(range(1, 13)))


class Segment:
    """Depth range [xs, ...) on which F is linear: q and its slope from the closed form (arrays)."""

    def __init__(self, xs, qs, fs, beta, lam):
        self.xs, self.qs, self.fs, self.beta, self.lam = xs, qs, fs, beta, lam

    def q(self, x):
        """v² at depth x (x may have one more axis than the segment's arrays). [m²/s²]"""
        shape = (slice(None),) + (None,) * (np.ndim(x) - np.ndim(self.xs))
        xs, qs, fs, beta, lam = (a[shape] for a in (self.xs, self.qs, self.fs, self.beta, self.lam))
        dx = x - xs
        z = -lam * dx
        em1 = np.expm1(z)
        small = np.abs(z) < 1e-3
        safe = np.where(small, 1.0, z)
        p1 = np.where(small, 1.0 + z * (0.5 + z * (1.0 / 6.0 + z / 24.0)), em1 / safe)  # φ1
        p2 = np.where(small, 0.5 + z * (1.0 / 6.0 + z * (1.0 / 24.0 + z / 120.0)), (p1 - 1.0) / safe)  # φ2
        return qs * (em1 + 1.0) + dx * (fs * p1 + beta * dx * p2)

    def f(self, x):
        """2F(x)/m. [m/s²]"""
        return self.fs + self.beta * (x - self.xs)

    def slope(self, x, q=None):
        """dq/dx = f − λq. [m/s²]"""
        return self.f(x) - self.lam * (self.q(x) if q is None else q)


def bracketed_root(fun, dfun, lo, hi, *, max_iterations: int = 80):
    """Root of ``fun`` in [lo, hi] per element, fun(lo) and fun(hi) of opposite sign (or zero at hi).

    Newton steps, replaced by bisection when they leave the bracket; stops when every root is located to
    round-off.
    """
    lo, hi = lo.astype(float).copy(), hi.astype(float).copy()
    f_lo = fun(lo)
    f_hi = fun(hi)
    x = np.where(f_hi == 0.0, hi, np.where(f_lo == 0.0, lo, lo - f_lo * (hi - lo) / np.where(
        f_hi != f_lo, f_hi - f_lo, 1.0)))
    x = np.where((x > lo) & (x < hi), x, 0.5 * (lo + hi))
    sign_lo = np.sign(f_lo)
    active = np.ones(x.shape, dtype=bool)  # each element stops on its own, so results do not depend on
    for _ in range(max_iterations):        # which other designs share the batch
        fx = fun(x)
        same = np.sign(fx) == sign_lo
        lo, hi = np.where(same, x, lo), np.where(same, hi, x)
        dfx = dfun(x)
        step = fx / np.where(dfx != 0.0, dfx, np.inf)
        newton = x - step
        inside = (newton > lo) & (newton < hi) & np.isfinite(newton)
        x_new = np.where(fx == 0.0, x, np.where(inside, newton, 0.5 * (lo + hi)))
        x_new = np.where(active, x_new, x)
        active &= (np.abs(x_new - x) > 4e-16 * np.maximum(np.abs(x), np.abs(hi - lo))) \
            & (hi - lo > 4e-16 * np.maximum(np.abs(lo), np.abs(hi)))
        x = x_new
        if not active.any():
            break
    return x


def travel_time(seg: Segment, xs, xe, qe, at_root):
    """∫ dx/√q from xs to xe along ``seg``. [s]

    ``at_root``: q(xe) = 0 (an arrest at xe).  Each half of [xs, xe] is substituted about a zero of q: the
    end's own when q vanishes there, else the zero that q's tangent reaches beyond the end (at most half
    the segment away), so that the integrand is smooth for Gauss–Legendre however small q is at an end.
    """
    length = xe - xs
    half = 0.5 * length
    xm = xs + half
    qs = seg.qs
    slope_s = seg.slope(xs, qs)
    slope_e = seg.slope(xe, qe)
    reach_s = np.where(slope_s > 0.0, qs / np.where(slope_s > 0.0, slope_s, 1.0), np.inf)
    a_left = xs - np.minimum(reach_s, half)
    reach_e = np.where(slope_e < 0.0, qe / np.where(slope_e < 0.0, -slope_e, 1.0), np.inf)
    a_right = np.where(at_root, xe, xe + np.minimum(reach_e, half))
    total = np.zeros_like(xs)
    for anchor, sign in ((a_left, 1.0), (a_right, -1.0)):
        span = sign * (xm - anchor)  # > 0
        end = xs if sign > 0 else xe
        with np.errstate(invalid="ignore", divide="ignore"):
            s_lo = np.sqrt(np.clip(sign * (end - anchor) / np.where(span > 0, span, 1.0), 0.0, 1.0))
        s = s_lo[:, None] + (1.0 - s_lo)[:, None] * _UNIT[None, :]
        x = anchor[:, None] + sign * span[:, None] * s * s
        q = np.maximum(seg.q(x), _TINY)
        part = ((1.0 - s_lo) * 2.0 * span) * ((s / np.sqrt(q)) @ _UNIT_W)
        total += np.where(span > 0, part, 0.0)
    return np.where(length > 0, total, 0.0)


def peak_on(seg: Segment, xs, xe, qe, a0, a1, d):
    """Largest R = a0 + a1·x + d·q on [xs, xe] and its depth. [N, m]"""
    r_s = reduced(xs, np.sqrt(seg.qs), a0, a1, 0.0, d)
    r_e = reduced(xe, np.sqrt(qe), a0, a1, 0.0, d)
    best = np.where(r_e > r_s, r_e, r_s)
    where = np.where(r_e > r_s, xe, xs)
    rise_s = a1 + d * seg.slope(xs, seg.qs)
    rise_e = a1 + d * seg.slope(xe, qe)
    inner = np.flatnonzero((rise_s > 0.0) & (rise_e < 0.0) & (xe > xs))
    if inner.size:
        sub = Segment(*(a[inner] for a in (seg.xs, seg.qs, seg.fs, seg.beta, seg.lam)))
        a1i, di = a1[inner], d[inner]

        def rise(x):
            return a1i + di * sub.slope(x)

        def bend(x):  # dR'/dx = d·q'' = d·(β − λq')
            return di * (sub.beta - sub.lam * sub.slope(x))

        x_top = bracketed_root(rise, bend, xs[inner], xe[inner])
        r_top = reduced(x_top, np.sqrt(np.maximum(sub.q(x_top), 0.0)), a0[inner], a1i, 0.0, di)
        top = r_top > best[inner]
        best[inner] = np.where(top, r_top, best[inner])
        where[inner] = np.where(top, x_top, where[inner])
    return best, where


def penetrate(v0, m, kd, xk, mg, a0, a1, d, depth):
    """Penetration at C = 0 of designs entering at speed ``v0`` (arrays, SI).

    ``xk``: depth at which the springs reach free length (≤ 0: already spent at contact).
    Returns (time [s], final depth [m], final speed [m/s], full depth reached, peak R [N], its depth [m],
    inertia energy [J]).
    """
    n = v0.size
    lam = 2.0 * d / m
    t = np.zeros(n)
    x_end = np.zeros(n)
    q_end = np.zeros(n)
    full = np.zeros(n, dtype=bool)
    peak = a0 + d * v0 * v0
    peak_x = np.zeros(n)
    going = np.ones(n, dtype=bool)
    xs, qs = np.zeros(n), v0 * v0
    for spring in (True, False):
        # segment: springs pushing on [0, min(xk, X)], then free on [max(xk, 0), X]
        if spring:
            on = going & (xk > 0.0)
            xe_all = np.minimum(xk, depth)
            fs_all = 2.0 / m * (kd * xk + mg - a0)
            beta_all = -2.0 / m * (kd + a1)
        else:
            on = going.copy()
            xe_all = depth
            fs_all = 2.0 / m * (mg - a0 - a1 * xs)
            beta_all = -2.0 / m * a1
        j = np.flatnonzero(on)
        if j.size == 0:
            continue
        seg = Segment(xs[j], qs[j], fs_all[j], beta_all[j], lam[j])
        xe = xe_all[j]
        blocked = (seg.qs <= 0.0) & (seg.fs <= 0.0)  # at rest and pushed back: stops where it is
        qe = seg.q(xe)
        stops = ~blocked & (qe <= 0.0)
        x_stop = np.where(blocked, seg.xs, xe)
        if stops.any():
            k = np.flatnonzero(stops)
            sub = Segment(*(a[k] for a in (seg.xs, seg.qs, seg.fs, seg.beta, seg.lam)))
            lo = sub.xs.copy()
            rest = np.flatnonzero(sub.qs <= 0.0)  # from rest: the zero sought is past the maximum of q
            if rest.size:
                top = Segment(*(a[rest] for a in (sub.xs, sub.qs, sub.fs, sub.beta, sub.lam)))
                lo[rest] = bracketed_root(top.slope, lambda x: top.beta - top.lam * top.slope(x),
                                          top.xs, xe[k][rest])
            x_stop[k] = bracketed_root(sub.q, sub.slope, lo, xe[k])
        ended = blocked | stops
        q_stop = np.where(ended, 0.0, qe)
        dt = travel_time(seg, seg.xs, x_stop, q_stop, ended)
        pk, pkx = peak_on(seg, seg.xs, x_stop, q_stop, a0[j], a1[j], d[j])
        better = pk > peak[j]
        peak[j] = np.where(better, pk, peak[j])
        peak_x[j] = np.where(better, pkx, peak_x[j])
        t[j] += np.where(blocked, 0.0, dt)
        reached = ~ended & (xe >= depth[j])
        x_end[j] = x_stop
        q_end[j] = q_stop
        full[j] = reached
        going[j] = ~ended & ~reached
        xs[j], qs[j] = x_stop, q_stop
    v_end = np.sqrt(np.maximum(q_end, 0.0))
    work = static_work(0.0, x_end, xk, kd, mg, a0, a1)  # ∫F dx over the penetration
    e_inertia = work - 0.5 * m * (q_end - v0 * v0)
    return t, x_end, v_end, full, peak, peak_x, e_inertia


__all__ = ["GAUSS_NODES", "Segment", "bracketed_root", "penetrate", "peak_on", "phi1", "phi2", "travel_time"]
