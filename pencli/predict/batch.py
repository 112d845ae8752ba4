r"""The CONTRACT §2 model over arrays of designs (the engine of ``pen sweep``).

Same physics as :func:`pencli.model.dynamics.simulate`, organised for throughput instead of one
trajectory, and exact at the edges:

- the flight is the same closed form (:func:`pencli.model.flight.reach`, compiled);
- without damping (C = 0, every Table 1 material) the penetration has a closed form over depth
  (:mod:`pencli.predict.closed_form`): arrest depth, residual energy and peak exact to round-off, the time
  by Gauss–Legendre quadrature with the end singularities substituted away;
- with damping it is integrated in time (:mod:`pencli.predict.damped`): Taylor series on steps of the
  motion's own scale, then the exact linear flow once the v² term is negligible, with creep towards
  the rest depth ended by the definition both simulators share.

Inputs are SI arrays named like the fields of :class:`pencli.model.design.Design` (broadcast against each
other); outputs are the CONTRACT §5 figures per design.  Pure (no I/O); the per-design loops are
compiled by numba and release the GIL, so threads can share a sweep's chunks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
from numba import njit, types

from pencli.model.design import Design, near_critical
from pencli.model.resistance import eq9_coefficients
from pencli.predict import closed_form, damped
from pencli.predict.damped import ARREST, FULL_DEPTH
from pencli.predict.compiled import JIT as _JIT
from pencli.predict.compiled import beyond_limit as _beyond_limit
from pencli.predict.compiled import force_sizes as _force_sizes
from pencli.predict.compiled import reach as _reach


FIGURES = ("contact_speed_m_s", "penetration_time_s", "final_depth_mm", "full_penetration", "peak_resistance_n",
           "peak_resistance_depth_mm", "residual_ke_j", "spring_energy_j", "energy_strength_j", "energy_friction_j",
           "energy_damping_j", "energy_inertia_j")
"""The CONTRACT §5 record, in order."""


ENDS = ("arrest", "full_depth", "creep", "stalled", "no_contact", "invalid", "overflow")
"""How a design's run can end; :attr:`BatchResult.code` indexes this tuple (the damped kernel's codes are
its first four)."""
assert ENDS[:4] == tuple(name for name, code in sorted(
    {"arrest": damped.ARREST, "full_depth": damped.FULL_DEPTH, "creep": damped.CREEP,
     "stalled": damped.STALLED}.items(), key=lambda item: item[1]))
_CODE = {name: np.int8(i) for i, name in enumerate(ENDS)}
OVERFLOW = ENDS.index("overflow")
NOT_SIMULATED = ENDS.index("no_contact")
"""This end and those after it (``no_contact``, ``invalid``, ``overflow``) are designs not simulated: their
figures are NaN, not zeros, which would read as an arrest at the surface."""
assert ENDS[NOT_SIMULATED:] == ("no_contact", "invalid", "overflow")


@dataclass(frozen=True)
class BatchResult:
    """CONTRACT §5 figures per design (arrays of equal length), plus how each ended."""

    figures: dict[str, np.ndarray]
    code: np.ndarray
    """Index into :data:`ENDS` per design (int8)."""
    near_critical: np.ndarray | None = None
    """Per design: an arrest whose time is round-off, the motion at its rest depth damped within a hair of
    critical (:func:`pencli.model.design.near_critical`); its figures other than the time stand."""

    @property
    def end(self) -> np.ndarray:
        """``arrest``, ``full_depth``, ``creep`` (see :mod:`pencli.predict.damped`), ``stalled``, ``no_contact``,
        ``invalid`` (a CONTRACT §1 rule broken) or ``overflow`` (a force beyond
        :data:`~pencli.model.design.FORCE_LIMIT_N`: not simulated, as ``pen predict`` refuses it) per design;
        the last three have NaN figures."""
        return np.asarray(ENDS)[self.code]

    def __len__(self) -> int:
        return int(self.code.size)

    def to_dict(self) -> dict[str, np.ndarray]:
        return {**self.figures, "end": self.end}


def designs_from(arrays: dict[str, np.ndarray | float], *, equal_length: bool = True) -> dict[str, np.ndarray]:
    """Per-field values (SI, :class:`Design` field names) as float arrays: broadcast to equal-length copies,
    or with ``equal_length=False`` left as they are (0-d for a value every design shares), which
    :func:`simulate_batch` broadcasts without copying."""
    names = [f.name for f in fields(Design)]
    missing = [n for n in names if n not in arrays]
    if missing:
        raise KeyError(f"missing design field {missing[0]!r}")
    if not equal_length:
        return {n: np.asarray(arrays[n], dtype=float) for n in names}
    shaped = np.broadcast_arrays(*[np.asarray(arrays[n], dtype=float) for n in names])
    return {n: np.ravel(a).copy() for n, a in zip(names, shaped)}


_ROWS = tuple(name for name in FIGURES if name != "full_penetration")
"""The float figures, in the order of the driver's output rows."""


def simulate_batch(d: dict[str, np.ndarray], *, speed_at_contact_m_s: np.ndarray | float | None = None) -> BatchResult:
    """Simulate every design of ``d`` (see :func:`designs_from`; fields broadcast against each other, so a
    value all designs share may be 0-d); all four Eq. 9 terms on."""
    design = Design(**d)  # one design per element: the design rules and Eq. 9 come from the model core
    speed = None if speed_at_contact_m_s is None else np.asarray(speed_at_contact_m_s, dtype=float)
    shape = np.broadcast_shapes(*(np.shape(v) for v in d.values()), *(() if speed is None else (speed.shape,)))
    n = int(np.prod(shape))

    def per_design(a) -> np.ndarray:  # a stride-0 view where every design shares the value: no copy
        return np.broadcast_to(np.asarray(a, dtype=float).reshape(-1) if np.ndim(a) else a, (n,))

    m, kd, stroke = design.effective_mass_kg, design.drive_stiffness_n_m, design.stroke_m  # stroke 0: a drop
    s0, g = design.surface_offset_m, design.gravity_m_s2
    w, T = design.blade_width_m, design.blade_thickness_m
    with np.errstate(over="ignore", invalid="ignore"):  # absurd designs overflow here; the kernel marks them
        a0, a1, b, dd = eq9_coefficients(design)  # R = a0 + a1·x + b·v + dd·v² in contact

    # ---- flight, closed form (once when every design flies the same way)
    if speed is None:
        flight = (m, kd, stroke, g, s0)
        size = n if any(np.size(a) > 1 for a in flight) else 1
        v0 = _contact_speeds(*(np.broadcast_to(np.asarray(a, dtype=float).reshape(-1), (size,)) for a in flight))
        v0 = per_design(v0 if size > 1 else v0[0])
        no_contact = np.isnan(v0)
    else:
        v0 = per_design(speed)
        no_contact = np.zeros((), dtype=bool)

    # designs not simulated: the parameter rules forbid them (CONTRACT §1 cross-checks); a force beyond what
    # float64 integrates (pen predict refuses those in one line) is found by the kernel, design by design
    invalid = (T >= w) | (d["load_cell_mass_kg"] > d["sprung_mass_kg"])
    skip = np.zeros(n, dtype=np.int8)
    for name, mask in (("no_contact", no_contact), ("invalid", invalid)):
        skip[np.broadcast_to(mask, (n,))] = _CODE[name]

    out = np.empty((len(_ROWS), n))
    code = np.empty(n, dtype=np.int8)
    _simulate_all(v0, *(per_design(a) for a in (m, kd, stroke, s0, g, a0, a1, b, dd, design.penetration_depth_m)),
                  speed is not None, skip, out, code)  # compiled; releases the GIL
    figures = dict(zip(_ROWS, out))
    figures["full_penetration"] = code == _CODE["full_depth"]
    with np.errstate(over="ignore", invalid="ignore"):
        near = near_critical(m, kd, stroke - s0, m * g, a0, a1, b, design.penetration_depth_m)
    near = np.broadcast_to(near, (n,)) & (code == _CODE["arrest"])
    return BatchResult({name: figures[name] for name in FIGURES}, code, near)


_IN = types.Array(types.float64, 1, "A", readonly=True)
"""The kernels' inputs: any 1-d float array, a stride-0 view of one shared value included (an explicit type, so
one compiled version serves every mix of varied and shared fields)."""


@njit(types.float64[::1](_IN, _IN, _IN, _IN, _IN), **_JIT)
def _contact_speeds(m, kd, stroke, g, s0):
    """Speed at contact of each design's flight; nan where the blade never reaches the surface. [m/s]"""
    v = np.empty(m.size)
    for i in range(m.size):
        t, v[i] = _reach(s0[i], m[i], kd[i], stroke[i], g[i], False)  # the speed only
        if not t < np.inf:
            v[i] = np.nan
    return v


@njit(**_JIT)
def _time_estimate(v0, m, kd, xk, mg, a0, a1, b, dd, depth):
    """Rough penetration time under a constant mean net force (sets the damped path's first step). [s]"""
    drive0 = (kd * xk if xk > 0 else 0.0) + mg
    decel = (a0 + 0.5 * a1 * depth + 0.5 * (b + dd * v0) * v0 - drive0) / m  # > 0: slows down on average
    t_stop = v0 / max(decel, 1e-12) if decel > 0 else np.inf
    push = max(-decel, 0.0)  # speeding up: time to full depth under that push
    t_full = (math.sqrt(v0 * v0 + 2 * push * depth) - v0) / max(push, 1e-12) if push > 0 else depth / max(v0, 1e-6)
    return min(max(min(t_stop, t_full), 1e-6), 10.0)


@njit(types.void(*[_IN] * 11, types.boolean, types.Array(types.int8, 1, "C", readonly=True),
                 types.float64[:, ::1], types.int8[::1]), **_JIT)
def _simulate_all(v0, m, kd, stroke, s0, g, a0, a1, b, dd, depth, speed_given, skip, out, code):
    """Each design from contact to its end, its figures into the rows of ``out`` (:data:`_ROWS`) and its end
    into ``code``: the closed form at C = 0, the damped path (Taylor steps, then the exact linear flow)
    otherwise; a design with a ``skip`` code is not simulated, nor is one whose forces are beyond float64's
    useful range (``overflow``): their figures are NaN (:data:`NOT_SIMULATED`)."""
    wk = np.empty((damped.WORK_ROWS, damped.ORDER + 1))
    for i in range(v0.size):
        u_start = s0[i] if speed_given else 0.0  # a given speed at contact starts the books at the surface
        t = x = v = e_damp = e_inert = peak = peak_x = 0.0
        c0 = c1 = 0.0
        code[i] = skip[i]
        if code[i] == 0:
            for force in _force_sizes(a0[i], a1[i], b[i], dd[i], v0[i], depth[i], kd[i], stroke[i], m[i], g[i]):
                if _beyond_limit(force):
                    code[i] = OVERFLOW
        if code[i] != 0:
            speed = 0.0
        else:
            speed = v0[i]
            c0, c1 = a0[i], a1[i]
            xk = stroke[i] - s0[i]  # depth at which the springs reach free length
            mg = m[i] * g[i]
            if b[i] == 0.0:  # C = 0 (every Table 1 material): closed form over depth
                t, x, v, full, peak, peak_x, e_inert = closed_form.penetrate_one(
                    speed, m[i], kd[i], xk, mg, c0, c1, dd[i], depth[i])
                code[i] = FULL_DEPTH if full else ARREST
            else:  # C > 0: time steps, then the exact linear flow
                t_est = _time_estimate(speed, m[i], kd[i], xk, mg, c0, c1, b[i], dd[i], depth[i])
                t, x, v, e_damp, e_inert, peak, peak_x, code[i] = damped.run_one(
                    speed, m[i], kd[i], xk, mg, c0, c1, b[i], dd[i], depth[i], t_est, wk)
        v_final = v if code[i] == FULL_DEPTH else 0.0
        u_end = x + s0[i]
        out[0, i] = speed
        out[1, i] = t
        out[2, i] = x * 1e3
        out[3, i] = peak
        out[4, i] = peak_x * 1e3
        out[5, i] = 0.5 * m[i] * v_final * v_final
        out[6, i] = 0.5 * kd[i] * (max(stroke[i] - u_start, 0.0) ** 2 - max(stroke[i] - u_end, 0.0) ** 2)
        out[7, i] = c0 * x
        out[8, i] = 0.5 * c1 * x * x
        out[9, i] = e_damp
        out[10, i] = e_inert
        if code[i] >= NOT_SIMULATED:
            out[:, i] = np.nan


def design_arrays(design: Design, count: int = 1) -> dict[str, np.ndarray]:
    """One :class:`Design` repeated ``count`` times, as batch input."""
    return designs_from({f.name: np.full(count, float(getattr(design, f.name))) for f in fields(Design)})


__all__ = ["BatchResult", "ENDS", "FIGURES", "design_arrays", "designs_from", "simulate_batch"]
