r"""The CONTRACT §2 model over arrays of designs (the engine of ``pen sweep``).

Same physics as :func:`pencli.model.dynamics.simulate`, organised for throughput instead of one
trajectory, and exact at the edges (issue 12):

- the flight is the same closed form (:func:`pencli.model.flight.reach`, compiled);
- without damping (C = 0, every Table 1 material) the penetration has a closed form over depth
  (:mod:`pencli.predict.closed_form`): arrest depth, residual energy and peak exact to round-off, the time
  by Gauss–Legendre quadrature with the end singularities substituted away;
- with damping it is integrated in time (:mod:`pencli.predict.damped`): RK4 on steps that resolve the
  damping's time scale, then the exact linear flow once the v² term is negligible, with creep towards
  the rest depth ended by the definition both simulators share.

Inputs are SI arrays named like the fields of :class:`pencli.model.design.Design` (broadcast against each
other); outputs are the CONTRACT §5 figures per design.  Pure (no I/O); the per-design loops are
compiled by numba and release the GIL, so threads can share a sweep's chunks.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
from numba import njit

from pencli.model.design import Design, beyond_limit, force_scales
from pencli.model.resistance import eq9_coefficients, reduced
from pencli.predict import closed_form, damped
from pencli.predict.compiled import JIT as _JIT
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


@dataclass(frozen=True)
class BatchResult:
    """CONTRACT §5 figures per design (arrays of equal length), plus how each ended."""

    figures: dict[str, np.ndarray]
    code: np.ndarray
    """Index into :data:`ENDS` per design (int8)."""

    @property
    def end(self) -> np.ndarray:
        """``arrest``, ``full_depth``, ``creep`` (see :mod:`pencli.predict.damped`), ``stalled``, ``no_contact``,
        ``invalid`` (a CONTRACT §1 rule broken) or ``overflow`` (a force beyond
        :data:`~pencli.model.design.FORCE_LIMIT_N`: not simulated, as ``pen predict`` refuses it) per design."""
        return np.asarray(ENDS)[self.code]

    def __len__(self) -> int:
        return int(self.code.size)

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


def simulate_batch(d: dict[str, np.ndarray], *, speed_at_contact_m_s: np.ndarray | float | None = None) -> BatchResult:
    """Simulate every design of ``d`` (see :func:`designs_from`); all four Eq. 9 terms on."""
    n = d["blade_width_m"].size
    design = Design(**d)  # one design per element: the design rules and Eq. 9 come from the model core
    m, kd, stroke = design.effective_mass_kg, design.drive_stiffness_n_m, design.stroke_m  # stroke 0: a drop
    s0, g = design.surface_offset_m, design.gravity_m_s2
    w, T = design.blade_width_m, design.blade_thickness_m
    with np.errstate(over="ignore", invalid="ignore"):  # absurd designs overflow here; marked 'overflow' below
        a0, a1, b, dd = eq9_coefficients(design)  # R = a0 + a1·x + b·v + dd·v² in contact
    depth = design.penetration_depth_m

    # ---- flight, closed form
    if speed_at_contact_m_s is None:
        v0 = _contact_speeds(np.ascontiguousarray(m), np.ascontiguousarray(kd), np.ascontiguousarray(stroke),
                             np.ascontiguousarray(g), np.ascontiguousarray(s0))
        no_contact = np.isnan(v0)
        u_start = np.zeros(n)
    else:
        v0 = np.broadcast_to(np.asarray(speed_at_contact_m_s, dtype=float), (n,)).copy()
        no_contact = np.zeros(n, dtype=bool)
        u_start = s0.copy()

    code = np.where(no_contact, _CODE["no_contact"], _CODE["arrest"]).astype(np.int8)
    # designs the parameter rules forbid (CONTRACT §1 cross-checks) are not simulated
    invalid = (T >= w) | (d["load_cell_mass_kg"] > d["sprung_mass_kg"])
    code[invalid] = _CODE["invalid"]
    no_contact = no_contact | invalid
    with np.errstate(over="ignore", invalid="ignore"):
        scales = force_scales(design, a0, a1, b, dd, np.where(no_contact, 0.0, v0))
        too_large = ~no_contact & np.logical_or.reduce([beyond_limit(f) for f in np.broadcast_arrays(*scales.values())])
    code[too_large] = _CODE["overflow"]
    no_contact = no_contact | too_large
    v0 = np.where(no_contact, 0.0, v0)
    a0, a1, b, dd = (np.where(no_contact, 0.0, c) for c in (a0, a1, b, dd))  # designs not simulated book nothing

    x, v, t = np.zeros(n), np.zeros(n), np.zeros(n)
    e_damp, e_inert = np.zeros(n), np.zeros(n)
    peak, peak_x = np.where(no_contact, 0.0, reduced(0.0, v0, a0, a1, b, dd)), np.zeros(n)
    xk = stroke - s0  # depth at which the springs reach free length
    mg = m * g
    # C = 0 (every Table 1 material): closed form over depth
    j = np.flatnonzero(~no_contact & (b == 0.0))
    if j.size:
        t[j], x[j], v[j], full, peak[j], peak_x[j], e_inert[j] = closed_form.penetrate(
            v0[j], m[j], kd[j], xk[j], mg[j], a0[j], a1[j], dd[j], depth[j])
        code[j[full]] = _CODE["full_depth"]
    # C > 0: time steps, then the exact linear flow
    j = np.flatnonzero(~no_contact & (b > 0.0))
    if j.size:
        t[j], x[j], v[j], e_damp[j], e_inert[j], peak[j], peak_x[j], ended = damped.penetrate(
            v0[j], m[j], kd[j], xk[j], mg[j], a0[j], a1[j], b[j], dd[j], depth[j],
            _time_estimate(v0[j], m[j], kd[j], xk[j], mg[j], a0[j], a1[j], b[j], dd[j], depth[j]))
        code[j] = ended  # damped's codes are those of ENDS

    x_final = np.where(no_contact, 0.0, x)
    full = code == _CODE["full_depth"]
    v_final = np.where(full, v, 0.0)
    u_end = x_final + s0
    spring_j = 0.5 * kd * (np.maximum(stroke - u_start, 0.0) ** 2 - np.maximum(stroke - u_end, 0.0) ** 2)
    figures = {
        "contact_speed_m_s": v0,
        "penetration_time_s": np.where(no_contact, 0.0, t),
        "final_depth_mm": x_final * 1e3,
        "full_penetration": full,
        "peak_resistance_n": np.where(no_contact, 0.0, peak),
        "peak_resistance_depth_mm": peak_x * 1e3,
        "residual_ke_j": 0.5 * m * v_final ** 2,
        "spring_energy_j": spring_j,
        "energy_strength_j": a0 * x_final,
        "energy_friction_j": 0.5 * a1 * x_final ** 2,
        "energy_damping_j": e_damp,
        "energy_inertia_j": e_inert,
    }
    return BatchResult(figures, code)


@njit(**_JIT)
def _contact_speeds(m, kd, stroke, g, s0):
    """Speed at contact of each design's flight; nan where the blade never reaches the surface. [m/s]"""
    v = np.empty(m.size)
    for i in range(m.size):
        t, v[i] = _reach(s0[i], m[i], kd[i], stroke[i], g[i])
        if not t < np.inf:
            v[i] = np.nan
    return v


def _time_estimate(v0, m, kd, xk, mg, a0, a1, b, dd, depth):
    """Rough penetration time under a constant mean net force (sets the first step size). [s]"""
    drive0 = np.where(xk > 0, kd * xk, 0.0) + mg
    decel = (a0 + 0.5 * a1 * depth + 0.5 * (b + dd * v0) * v0 - drive0) / m  # > 0: slows down on average
    t_stop = np.where(decel > 0, v0 / np.maximum(decel, 1e-12), np.inf)
    push = np.maximum(-decel, 0.0)  # speeding up: time to full depth under that push
    t_full = np.where(push > 0, (np.sqrt(v0 * v0 + 2 * push * depth) - v0) / np.maximum(push, 1e-12),
                      depth / np.maximum(v0, 1e-6))
    return np.clip(np.minimum(t_stop, t_full), 1e-6, 10.0)


def design_arrays(design: Design, count: int = 1) -> dict[str, np.ndarray]:
    """One :class:`Design` repeated ``count`` times, as batch input."""
    return designs_from({f.name: np.full(count, float(getattr(design, f.name))) for f in fields(Design)})


__all__ = ["BatchResult", "ENDS", "FIGURES", "design_arrays", "designs_from", "simulate_batch"]
