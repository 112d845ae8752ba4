r"""Penetration with damping (C > 0) over arrays of designs, time as the independent variable.

In the material the motion obeys :math:`m\ddot x = F(x) - b\dot x - d\dot x^2` with F piecewise linear
(springs pushing until :math:`x_k`, then not), b = wTC and d = wTKρ.  Two regimes:

1. **RK4**, each design on its own step: an estimate of its penetration time over :data:`STEPS`, doubled
   after every :data:`STEPS` steps, and never more than ``0.5·m/(b + 2dv)`` so that the damping's time
   scale is resolved (explicit steps beyond it diverge: the large-damping defect of issue 12).
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

Units SI; arrays; pure numpy.
"""

from __future__ import annotations

import numpy as np

from pencli.model.design import CREEP_DISTANCE_M, static_work
from pencli.model.resistance import reduced
from pencli.predict.closed_form import phi1

STEPS = 160
"""RK4 steps over a design's estimated penetration time (doubled after as many steps again)."""
STIFF_STEP = 0.5
"""RK4 step limit in units of the damping time m/(b + 2dv). [–]"""
LINEAR_TOL = 1e-5
"""Hand a design to the exact linear flow once d·v ≤ LINEAR_TOL·b. [–]"""
LINEARISE_TOL = 1e-9
"""Linear-flow steps are limited so that the linearised v² term errs by at most this fraction of the
damping force: d·Δv² ≤ LINEARISE_TOL·b·v. [–]"""
MAX_STEPS = 40 * STEPS
"""RK4 steps per design at most; a design still moving after them (and after the linear flow's own
limit) ends as ``stalled``."""
_BISECT = 60
_GAUSS5 = (0.5 * (np.polynomial.legendre.leggauss(5)[0] + 1.0), 0.5 * np.polynomial.legendre.leggauss(5)[1])


def rest_depth(F0, k):
    """x* where F0 − k·x = 0 (inf when k = 0). [m]"""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(k > 0.0, F0 / np.where(k > 0.0, k, 1.0), np.inf)


def _segment(x, xk, kd, mg, a0, a1):
    """(F0, k) of the linear force F = F0 − k·x on the spring segment that holds x."""
    pushing = x < xk
    return np.where(pushing, kd * xk, 0.0) + mg - a0, np.where(pushing, kd, 0.0) + a1


def _flow(t, xi0, v0, sigma, mu2, w2):
    """Exact (ξ, v) after t of ξ' = v, v' = −w2·ξ + 2σ·v (σ ≤ 0), with μ² = σ² − w2."""
    z = mu2 * t * t
    mu = np.sqrt(np.abs(mu2))
    with np.errstate(over="ignore", invalid="ignore", under="ignore"):
        r1, r2 = sigma + mu, sigma - mu
        e1, e2 = np.exp(r1 * t), np.exp(r2 * t)
        over_c, over_s = 0.5 * (e1 + e2), (e1 - e2) / np.where(mu > 0, 2.0 * mu, 1.0)
        decay = np.exp(sigma * t)
        under_c, under_s = decay * np.cos(mu * t), decay * np.sin(mu * t) / np.where(mu > 0, mu, 1.0)
        c_series = s_series = 0.0
        for n in range(10, -1, -1):
            c_series = 1.0 / _FACT[2 * n] + z * c_series
            s_series = 1.0 / _FACT[2 * n + 1] + z * s_series
        small_c, small_s = decay * c_series, decay * t * s_series
    big = np.abs(z) >= 1.0
    E1 = np.where(big, np.where(z > 0, over_c, under_c), small_c)
    E2 = np.where(big, np.where(z > 0, over_s, under_s), small_s)
    return E1 * xi0 + E2 * (v0 - sigma * xi0), E1 * v0 + E2 * (sigma * v0 - w2 * xi0)


_FACT = np.cumprod([1.0] + list(range(1, 23)))


def _bisect(fun, hi):
    """Largest s in [0, hi] with fun(s) > 0, fun(0) > 0 ≥ fun(hi) (per element)."""
    lo = np.zeros_like(hi)
    for _ in range(_BISECT):
        mid = 0.5 * (lo + hi)
        up = fun(mid) > 0.0
        lo, hi = np.where(up, mid, lo), np.where(up, hi, mid)
    return 0.5 * (lo + hi)


class Damped:
    """The damped designs of one batch: parameters (arrays, SI) and their running state."""

    def __init__(self, v0, m, kd, xk, mg, a0, a1, b, d, depth, t_est):
        self.p = {"m": m, "kd": kd, "xk": xk, "mg": mg, "a0": a0, "a1": a1, "b": b, "d": d, "depth": depth}
        n = v0.size
        self.t, self.x, self.v = np.zeros(n), np.zeros(n), v0.astype(float).copy()
        self.e_damp, self.e_inert = np.zeros(n), np.zeros(n)
        self.peak = reduced(0.0, np.maximum(v0, 0.0), a0, a1, b, d)  # R just inside the surface
        self.peak_x = np.zeros(n)
        self.end = np.full(n, "", dtype=object)
        self.h = np.clip(t_est, 1e-9, 10.0) / STEPS

    # ------------------------------------------------------------------ RK4
    def accel(self, x, v, P):
        vp = np.maximum(v, 0.0)
        spring = np.where(x < P["xk"], P["kd"] * (P["xk"] - x), 0.0)
        return (spring + P["mg"] - _resistance(x, vp, P)) / P["m"]

    def _linear_ready(self, idx):
        P = {k: v[idx] for k, v in self.p.items()}
        x, v = self.x[idx], self.v[idx]
        slowing = self.accel(x, v, P) <= 0.0  # once slowing down, a design never speeds up again in the
        return (P["d"] == 0.0) | (slowing & (P["d"] * np.maximum(v, 0.0) <= LINEAR_TOL * P["b"]))  # material

    def run(self):
        """Integrate every design to its end."""
        n = self.x.size
        start = self.p["mg"] - self.p["a0"] + np.where(self.p["xk"] > 0, self.p["kd"] * self.p["xk"], 0.0)
        blocked = (self.v <= 0.0) & (start <= 0.0)
        self.end[blocked] = "arrest"
        todo = np.flatnonzero(~blocked)
        linear = np.zeros(n, dtype=bool)
        linear[todo] = self._linear_ready(todo)
        self.end[todo[linear[todo]]] = "linear"  # already in the linear regime at contact
        self._rk4(todo[~linear[todo]])
        handed = np.flatnonzero(self.end == "linear")
        self.end[handed] = ""
        self._linear(handed)
        self.end[self.end == ""] = "stalled"

    def _rk4(self, W):
        if W.size == 0:
            return
        P = {k: v[W] for k, v in self.p.items()}
        xs, vs, ts = self.x[W], self.v[W], self.t[W]
        eds, eis, pk, pkx = self.e_damp[W], self.e_inert[W], self.peak[W], self.peak_x[W]
        h_plan = self.h[W]
        live = np.ones(W.size, dtype=bool)
        for count in range(1, MAX_STEPS + 1):
            if not live.any():
                break
            h = np.minimum(h_plan, STIFF_STEP * P["m"] / (P["b"] + 2.0 * P["d"] * np.maximum(vs, 0.0)))
            xn, vn, ed, ei, a_s, an = self._step(xs, vs, h, P)
            # where the step ends: arrest (v = 0) on the cubic Hermite interpolant; full depth, or the springs'
            # free length (the force's slope jumps there), by a step redone to end there
            stop_v = live & (vn <= 0.0)
            s = np.ones(W.size)
            if stop_v.any():
                j = np.flatnonzero(stop_v)
                args = (xs[j], vs[j], a_s[j], xn[j], vn[j], an[j], h[j])
                s[j] = _bisect(lambda q: _hermite_xv(*args, q)[1], np.ones(j.size))
            x_reach = np.where(stop_v, _hermite_xv(xs, vs, a_s, xn, vn, an, h, s)[0], xn)
            kink = live & (xs < P["xk"]) & (P["xk"] < P["depth"]) & (x_reach >= P["xk"])
            stop_x = live & ~kink & (x_reach >= P["depth"])  # maybe passed before v = 0 in the same step
            cut = kink | stop_x
            target = np.where(kink, P["xk"], P["depth"])
            if cut.any():
                j = np.flatnonzero(cut)
                args = (xs[j], vs[j], a_s[j], xn[j], vn[j], an[j], h[j])
                tj = target[j]
                s[j] = _bisect(lambda q: tj - _hermite_xv(*args, q)[0], s[j])
                Pj = {key: val[j] for key, val in P.items()}
                x_cut, v_cut, ed[j], ei[j], _, a_cut = self._step(xs[j], vs[j], s[j] * h[j], Pj)
                # land exactly on the target: move the remaining round-off of x with the energy it costs
                xn[j] = tj
                vn[j] = np.sqrt(np.maximum(v_cut * v_cut + 2.0 * a_cut * (tj - x_cut), 0.0))
                an[j] = self.accel(xn[j], vn[j], Pj)
            stop_v &= ~cut
            stopping = stop_v | stop_x
            if stop_v.any():  # an arrest's energies: Gauss on the interpolant (v³ is degree 9: exact)
                j = np.flatnonzero(stop_v)
                args = (xs[j], vs[j], a_s[j], xn[j], vn[j], an[j], h[j])
                ed[j], ei[j] = 0.0, 0.0
                for node, weight in zip(*_GAUSS5):
                    vq = np.maximum(_hermite_xv(*args, s[j] * node)[1], 0.0)
                    ed[j] += weight * s[j] * h[j] * P["b"][j] * vq * vq
                    ei[j] += weight * s[j] * h[j] * P["d"][j] * vq ** 3
            x_end, v_end = _hermite_xv(xs, vs, a_s, xn, vn, an, h, np.where(stop_v, s, 1.0))
            x_end = np.where(cut, xn, x_end)
            v_end = np.where(cut, vn, np.where(stop_v, 0.0, v_end))
            h_used, s_used = np.where(cut, s * h, h), np.where(cut, 1.0, s)  # a cut step was redone to its end
            self._peak_rk4(live, xs, vs, a_s, xn, vn, an, h_used, s_used, x_end, v_end, pk, pkx, P)
            ts = np.where(live, ts + s * h, ts)
            eds = np.where(live, eds + ed, eds)
            eis = np.where(live, eis + ei, eis)
            xs = np.where(live, x_end, xs)
            vs = np.where(live, v_end, vs)
            if stopping.any():
                j = np.flatnonzero(stopping & live)
                self.end[W[j]] = np.where(stop_x[j], "full_depth", "arrest")
                live[j] = False
            if count % STEPS == 0:
                h_plan = h_plan * 2.0
            if count % 8 == 0 or count == 1:  # regime check: hand over to the exact linear flow
                self.x[W], self.v[W] = xs, vs
                ready = live & self._linear_ready(W)
                self.end[W[ready]] = "linear"
                live &= ~ready
        self.x[W], self.v[W], self.t[W] = xs, vs, ts
        self.e_damp[W], self.e_inert[W], self.peak[W], self.peak_x[W] = eds, eis, pk, pkx
        self.h[W] = h

    def _step(self, xs, vs, h, P):
        """One classical RK4 step of length h: (x, v, damping energy, inertia energy, a at start, a at end)."""
        a_s = self.accel(xs, vs, P)
        k2x, k2v = vs + 0.5 * h * a_s, self.accel(xs + 0.5 * h * vs, vs + 0.5 * h * a_s, P)
        k3x, k3v = vs + 0.5 * h * k2v, self.accel(xs + 0.5 * h * k2x, vs + 0.5 * h * k2v, P)
        k4x, k4v = vs + h * k3v, self.accel(xs + h * k3x, vs + h * k3v, P)
        xn = xs + h * (vs + 2 * k2x + 2 * k3x + k4x) / 6
        vn = vs + h * (a_s + 2 * k2v + 2 * k3v + k4v) / 6
        v1, v2, v3, v4 = (np.maximum(q, 0.0) for q in (vs, k2x, k3x, k4x))
        ed = h * P["b"] * (v1 * v1 + 2 * v2 * v2 + 2 * v3 * v3 + v4 * v4) / 6  # ∫ b v² dt
        ei = h * P["d"] * (v1 ** 3 + 2 * v2 ** 3 + 2 * v3 ** 3 + v4 ** 3) / 6  # ∫ d v³ dt
        return xn, vn, ed, ei, a_s, self.accel(xn, vn, P)

    def _peak_rk4(self, live, xs, vs, a_s, xn, vn, an, h, s, x_end, v_end, pk, pkx, P):
        vpos = np.maximum(v_end, 0.0)
        r_end = _resistance(x_end, vpos, P)
        better = live & (r_end > pk)
        pk[better], pkx[better] = r_end[better], x_end[better]
        rise0 = P["a1"] * vs + (P["b"] + 2.0 * P["d"] * np.maximum(vs, 0.0)) * a_s
        rise1 = _resistance_slope(xs, vs, a_s, xn, vn, an, h, s, P)
        inner = np.flatnonzero(live & (rise0 > 0.0) & (rise1 < 0.0))
        if inner.size:
            q = {key: val[inner] for key, val in P.items()}
            args = (xs[inner], vs[inner], a_s[inner], xn[inner], vn[inner], an[inner], h[inner])
            s_top = _bisect(lambda u: _resistance_slope(*args, u, q), s[inner])
            xm, vm = _hermite_xv(*args, s_top)
            vm = np.maximum(vm, 0.0)
            rm = _resistance(xm, vm, q)
            top = rm > pk[inner]
            pk[inner[top]], pkx[inner[top]] = rm[top], xm[top]

    # ------------------------------------------------------------------ exact linear flow
    def _linear(self, W):
        P = {k: v[W] for k, v in self.p.items()}
        x, v, t, h = self.x[W], np.maximum(self.v[W], 0.0), self.t[W], self.h[W]
        e_damp, e_inert, pk, pkx = self.e_damp[W], self.e_inert[W], self.peak[W], self.peak_x[W]
        end = np.full(W.size, "", dtype=object)
        final_x = np.full(W.size, np.nan)
        live = np.ones(W.size, dtype=bool)
        m, b, d, depth, xk = P["m"], P["b"], P["d"], P["depth"], P["xk"]
        for _ in range(4 * MAX_STEPS):
            if not live.any():
                break
            F0, k = _segment(x, xk, P["kd"], P["mg"], P["a0"], P["a1"])
            in_spring = x < xk
            vr = v
            b_lin = b + 2.0 * d * vr  # d·v² ≈ d·(2·vr·v − vr²) about this step's start
            F_lin = F0 + d * vr * vr
            x_star = rest_depth(F_lin, k)
            sigma, w2 = -0.5 * b_lin / m, k / m
            mu2 = sigma * sigma - w2
            acc = np.abs(F_lin - k * x - b_lin * v) / m
            with np.errstate(divide="ignore", invalid="ignore"):
                dv_max = np.maximum(np.sqrt(LINEARISE_TOL * b * v / np.where(d > 0, d, 1.0)),
                                    LINEARISE_TOL * b / np.where(d > 0, d, 1.0))
                cap = np.where(d > 0, dv_max / np.maximum(acc, 1e-300), np.inf)
                cap = np.minimum(cap, np.where(mu2 < 0, 0.5 * np.pi / np.sqrt(np.abs(mu2)), np.inf))
            h = np.minimum(2.0 * h, cap)
            shifted = k * depth > 1e-9 * np.abs(F_lin)  # a rest depth within reach of float64
            xi0 = np.where(shifted, x - np.where(shifted, x_star, 0.0), 0.0)
            v_term = F_lin / b_lin  # k = 0: v tends to F/b
            arrays = (h, xi0, v, sigma, mu2, w2, x_star, shifted, x, v_term)

            def state(s, j=slice(None), arrays=arrays):
                hh, xi, vv, sg, m2, ww, xs_, sh, x0, vt = (a[j] for a in arrays)
                tt = s * hh
                xi_t, v_t = _flow(tt, xi, vv, sg, m2, ww)
                decay = np.exp(2.0 * sg * tt)
                x_free = x0 + vt * tt + (vv - vt) * tt * phi1(2.0 * sg * tt)
                v_free = vt + (vv - vt) * decay
                return np.where(sh, xs_ + xi_t, x_free), np.where(sh, v_t, v_free)

            x1, v1 = state(1.0)
            s_end = np.ones(W.size)
            # arrest: v changes sign at most once in a step (overdamped always; underdamped by the cap)
            stop_v = live & (v1 <= 0.0)
            if stop_v.any():
                j = np.flatnonzero(stop_v)
                s_end[j] = _bisect(lambda s: state(s, j)[1], np.ones(j.size))
            x_far = state(s_end)[0]  # deepest point of the step (x rises while v > 0)
            kind = np.where(stop_v, "arrest", "")
            # the first of: full depth, springs at free length, creep — each before s_end
            for name, target, applies in (
                    ("full_depth", depth, np.ones(W.size, dtype=bool)),
                    ("kink", xk, in_spring & (xk < depth)),
                    ("creep", x_star - CREEP_DISTANCE_M,
                     (mu2 > 0) & (x_star < depth) & (~in_spring | (x_star < xk)))):
                hit = live & applies & (target > x) & (x_far >= target)
                if hit.any():
                    j = np.flatnonzero(hit)
                    tj = target[j]
                    s_hit = _bisect(lambda s: tj - state(s, j)[0], s_end[j])
                    if name == "creep":  # only a slow approach creeps; a fast one overshoots and arrests
                        v_hit = state(s_hit, j)[1]
                        slow = shifted[j] & (v_hit <= np.sqrt(w2[j]) * CREEP_DISTANCE_M * (1.0 + 1e-9))
                        j, s_hit = j[slow], s_hit[slow]
                    earlier = s_hit <= s_end[j]
                    j, s_hit = j[earlier], s_hit[earlier]
                    s_end[j] = s_hit
                    kind[j] = name
                    x_far[j] = target[j]
            x_new, v_new = state(s_end)
            x_new = np.where(np.isin(kind, ("full_depth", "kink", "creep")), x_far, x_new)  # on the target
            v_new = np.where(kind == "arrest", 0.0, np.maximum(v_new, 0.0))
            # peak of R = a0 + a1·x + b·v + d·v² inside the step (R' = a1·v + (b + 2dv)·a changes sign)
            self._peak_linear(live, state, s_end, x, v, x_new, v_new, F_lin, k, b_lin, pk, pkx, P)
            # energies: the rate terms dissipate the work of F less the gain in kinetic energy
            work = static_work(x, x_new, xk, P["kd"], P["mg"], P["a0"], P["a1"])
            dissipated = work - 0.5 * m * (v_new * v_new - v * v)
            v_mid = 0.5 * (v + v_new)
            share = d * v_mid / np.where(b + d * v_mid > 0, b + d * v_mid, 1.0)
            e_inert = np.where(live, e_inert + share * dissipated, e_inert)
            e_damp = np.where(live, e_damp + (1.0 - share) * dissipated, e_damp)
            t = np.where(live, t + s_end * h, t)
            x = np.where(live, np.where(kind == "kink", xk, x_new), x)
            v = np.where(live, v_new, v)
            done = live & np.isin(kind, ("arrest", "full_depth", "creep"))
            end[done] = kind[done]
            creep = done & (kind == "creep")
            if creep.any():  # the run is booked at its rest depth, where the motion tends
                j = np.flatnonzero(creep)
                xs_true = rest_depth(F0[j], k[j])
                extra = static_work(x[j], xs_true, xk[j], P["kd"][j], P["mg"][j], P["a0"][j], P["a1"][j]) \
                    + 0.5 * m[j] * v[j] ** 2
                e_damp[j] += extra
                final_x[j] = xs_true
                v[j] = 0.0
            live &= ~done
        self.x[W], self.v[W], self.t[W] = np.where(np.isnan(final_x), x, final_x), v, t
        self.e_damp[W], self.e_inert[W], self.peak[W], self.peak_x[W] = e_damp, e_inert, pk, pkx
        self.end[W] = np.where(end == "", "stalled", end)

    def _peak_linear(self, live, state, s_end, x0, v0, x1, v1, F_lin, k, b_lin, pk, pkx, P):
        r1 = _resistance(x1, v1, P)
        better = live & (r1 > pk)
        pk[better], pkx[better] = r1[better], x1[better]

        def rise(x, v):
            return P["a1"] * v + (P["b"] + 2.0 * P["d"] * v) * (F_lin - k * x - b_lin * v) / P["m"]

        inner = np.flatnonzero(live & (rise(x0, v0) > 0.0) & (rise(x1, v1) < 0.0))
        if inner.size:
            Pi = {key: val[inner] for key, val in P.items()}
            Fi, ki, bi = F_lin[inner], k[inner], b_lin[inner]

            def rise_i(s):
                xx, vv = state(s, inner)
                return Pi["a1"] * vv + (Pi["b"] + 2.0 * Pi["d"] * vv) * (Fi - ki * xx - bi * vv) / Pi["m"]

            s_top = _bisect(rise_i, s_end[inner])
            xt, vt = state(s_top, inner)
            vt = np.maximum(vt, 0.0)
            rt = _resistance(xt, vt, Pi)
            top = rt > pk[inner]
            pk[inner[top]], pkx[inner[top]] = rt[top], xt[top]


def _resistance(x, vp, P):
    """Eq. 9 in contact for the designs of P. [N]"""
    return reduced(x, vp, P["a0"], P["a1"], P["b"], P["d"])


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
    """dR/ds of R = a0 + a1·x + b·v + d·v² along the Hermite interpolant of a step (its sign matters)."""
    _, v = _hermite_xv(x0, v0, a0, x1, v1, a1, h, s)
    dx, dv = _hermite_slopes(x0, v0, a0, x1, v1, a1, h, s)
    return P["a1"] * dx + (P["b"] + 2.0 * P["d"] * np.maximum(v, 0.0)) * dv


__all__ = ["Damped", "LINEAR_TOL", "STEPS", "rest_depth"]
