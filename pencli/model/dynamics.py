r"""The one-degree-of-freedom spring rig of CONTRACT §2.

Equation of motion of the moving body (x = tip depth, positive down):

.. math::

    m_\mathrm{eff}\,\ddot x = \eta n k \,(L_0 - L(x))\,[L < L_0]
                              + m_\mathrm{eff}\, g - R(x, \dot x)

    m_\mathrm{eff} = m + n\,m_s/3, \qquad L(x) = L_c + x + s_0

starting at rest at :math:`x = -s_0`.

How it is solved
----------------
*Flight* (release to contact) has no resistance, so it is solved in closed
form: harmonic motion about the shifted equilibrium while the springs push,
then a parabola under gravity once they reach free length.  Contact and
spring release are found from those formulas exactly.

*Penetration* is integrated with scipy's DOP853 (8th order) at rtol 1e-10
(Radau when the damping makes the problem stiff, b²/(m·k) > 100), split
where the springs reach free length (the force's slope jumps there), and
ended at arrest (v = 0 with x > 0), full depth or creep (:func:`creep_target`);
each of these events is root-found on the dense output, never located to a
time step.  The energies of the rate terms are integrated as extra states;
the strength and friction energies have closed forms.

Pure: numpy and scipy only, SI units.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Iterable

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import minimize_scalar

from pencli.errors import ModelError
from pencli.model.design import (CREEP_DISTANCE_M, FORCE_LIMIT_N, Design, beyond_limit, creep_point,
                                 creep_time_constant, damping_ratio_at_rest, force_scales,
                                 near_critical, static_work)
from pencli.model.drive import SPRINGS, Drive, Flight, FlightPath, flight_of, inertia_of, prescribed_speed
from pencli.model.geometry import BLADE, Geometry
from pencli.model.resistance import TERMS, ResistanceLaw, parse_terms, reduced, term_keys

MODEL_NAME = "contract-2/eq9-1dof"
"""Identifier of the reference dynamic model (CONTRACT §2: the blade's Eq. 9 on the springs), recorded with every
result it produced."""


def model_name(geometry: Geometry, drive: Drive) -> str:
    """The model a result came from: :data:`MODEL_NAME` for the contract's blade on its springs, else the same one
    degree of freedom with the geometry's resistance and the drive's push named (``pen-1dof/cone+springs``)."""
    if geometry.name == BLADE.name and drive.name == SPRINGS.name:
        return MODEL_NAME
    return f"pen-1dof/{geometry.name}+{drive.name}"

PHASES: tuple[str, ...] = ("flight", "penetration")
"""Phase codes used in :attr:`Trajectory.phase` (index into this tuple)."""

_RTOL = 1e-10
MAX_CONTACT_SPEED_M_S = 1_000.0
"""Largest speed at contact taken: a spring launcher gives a few m/s and a dropped penetrometer tens; past a
kilometre per second the blade is a projectile the model does not describe, and the energies overflow. [m/s]"""
_WINDOW_S = 3600.0
"""Simulated time one call of the integrator covers; a run that neither arrests, creeps nor reaches full depth
within it goes on from where it stopped (a heavily damped blade may take hours to reach full depth; only the
evaluation budget :data:`MAX_EVALUATIONS` ends a run short, with an error, never a figure). [s]"""
MAX_EVALUATIONS = 2_000_000
"""Right-hand-side evaluations one penetration may take (a few seconds); beyond it the design's scales are
too far apart for float64 and the simulation ends with one line instead of running on."""
MAX_SAMPLES = 1_000_000
"""Trajectory samples kept at most (~100 MB); a longer motion is sampled more coarsely and says so."""
ENERGY_TOLERANCE = 1e-6
"""Energy balance error, relative to the energy put in, beyond which a result carries a warning. [–]"""
_WEIGHT_KEYS = ("sprung_mass_kg", "gravity_m_s2")


class SimulationLimit(ModelError):
    """A design the model cannot simulate in bounded time and memory (one line, names the inputs)."""


def _check_scales(design: Design, law: ResistanceLaw, speed_m_s: float, drive: Drive = SPRINGS,
                  other=None) -> None:
    """Refuse a design whose forces overflow float64 before integrating it.  ``other``: a resistance outside
    Eq. 9's four terms, R(x, v), checked at full depth and the contact speed."""
    forces = force_scales(design, law.strength_n, law.friction_n_m, law.damping_n_s_m, law.inertia_n_s2_m2,
                          speed_m_s)
    forces["drive"] = drive.largest_force(design)
    if other is not None:
        forces["resistance"] = other(float(design.penetration_depth_m), max(float(speed_m_s), 0.0))
    keys_of = {"drive": drive.keys, "weight": _WEIGHT_KEYS, "resistance": ("the geometry's parameters",)}
    for term, force in forces.items():
        if beyond_limit(force):
            keys = keys_of[term] if term in keys_of else term_keys(term)
            raise SimulationLimit(f"the {term} force is {force:.3g} N (from {', '.join(keys)}); "
                                  f"beyond {FORCE_LIMIT_N:g} N the model cannot be integrated in float64")


@dataclass(frozen=True)
class Summary:
    """The CONTRACT §5 record of one simulated design, plus pen's extras.

    The first twelve fields are the contract's, with its names and units.
    """

    contact_speed_m_s: float
    """Speed when the tip reaches the surface. [m/s]"""
    penetration_time_s: float
    """From contact to arrest or full depth. [s]"""
    final_depth_mm: float
    """Depth at arrest, or the full depth. [mm]"""
    full_penetration: bool
    """Reached the full penetration depth."""
    peak_resistance_n: float
    """Max of R over the penetration. [N]"""
    peak_resistance_depth_mm: float
    """Depth where the peak occurred. [mm]"""
    residual_ke_j: float
    """Kinetic energy left at full depth (0 at arrest). [J]"""
    spring_energy_j: float
    """Energy the launcher delivered over the simulated span. [J]"""
    energy_strength_j: float
    """Dissipated by the strength term. [J]"""
    energy_friction_j: float
    """Dissipated by the sidewall-friction term. [J]"""
    energy_damping_j: float
    """Dissipated by the damping term. [J]"""
    energy_inertia_j: float
    """Dissipated by the inertia term. [J]"""
    contact_time_s: float
    """Time from release to contact (0 when the speed at contact is given). [s]"""
    end: str
    """How penetration ended: ``arrest``, ``full_depth``, ``creep`` (see :func:`creep_target`) or ``no_contact``
    (a run that does not end within the evaluation budget raises :class:`SimulationLimit` instead)."""
    gravity_work_j: float
    """Work of gravity over the simulated span. [J]"""
    initial_ke_j: float
    """Kinetic energy at the start of the simulated span. [J]"""
    energy_balance_error_j: float
    """initial KE + spring + gravity − (final KE + Σ term energies + other). [J]"""
    energy_other_j: float = 0.0
    """Dissipated by resistance outside Eq. 9's four terms: a diagnosis effect's, or a geometry's that does
    not reduce to Eq. 9 (:mod:`pencli.model.geometry`). [J]"""
    near_critical: bool = False
    """An arrest whose time is round-off: damped within a hair of critical at the rest depth, the tip passes it by
    less than float64 resolves (:func:`~pencli.model.design.near_critical`); depth and energies stand."""
    creep_time_constant_s: float | None = None
    """With ``end: creep``, the slow mode's time constant at the rest depth: the penetration time is to within
    :data:`~pencli.model.design.CREEP_DISTANCE_M` of it, and each tenfold-closer end would add τ·ln 10
    (:func:`~pencli.model.design.creep_time_constant`); None otherwise. [s]"""

    def to_dict(self) -> dict:
        """Flat mapping, JSON-ready."""
        return asdict(self)


@dataclass(frozen=True)
class Trajectory:
    """Sampled time histories of one simulation, SI.

    Each attribute is a 1-D array of the same length.  Forces follow the
    contract's sign: resistance pushes the blade up and is positive.
    """

    time_s: np.ndarray
    """Time since release (since contact when the speed at contact is given). [s]"""
    depth_m: np.ndarray
    """Tip depth x, negative above the surface. [m]"""
    velocity_m_s: np.ndarray
    """dx/dt, down positive. [m/s]"""
    acceleration_m_s2: np.ndarray
    """d²x/dt², down positive. [m/s²]"""
    strength_n: np.ndarray
    """Strength term of R. [N]"""
    friction_n: np.ndarray
    """Sidewall-friction term of R. [N]"""
    damping_n: np.ndarray
    """Damping term of R. [N]"""
    inertia_n: np.ndarray
    """Inertia term of R. [N]"""
    resistance_n: np.ndarray
    """R, the sum of the switched-on terms. [N]"""
    spring_force_n: np.ndarray
    """η·n·k·(L0 − L) while L < L0, else 0. [N]"""
    load_cell_force_n: np.ndarray
    """Tared load-cell reading F = R + m_lc·a, compression positive. [N]"""
    phase: np.ndarray
    """Index into :data:`PHASES`. [–]"""

    def columns(self) -> dict[str, np.ndarray]:
        """Column name (unit-suffixed) → array."""
        return dict(asdict(self))

    def __len__(self) -> int:
        return int(self.time_s.size)


@dataclass(frozen=True)
class SimulationResult:
    """What :func:`simulate` returns."""

    design: Design
    terms: tuple[str, ...]
    speed_at_contact_m_s: float | None
    summary: Summary
    trajectory: Trajectory
    model: str = MODEL_NAME
    success: bool = True
    message: str = ""

    def to_dict(self) -> dict:
        """Summary plus the model record (which model and terms produced it)."""
        out = self.summary.to_dict()
        out["model"] = self.model
        out["terms"] = list(self.terms)
        out["speed_at_contact_override_m_s"] = self.speed_at_contact_m_s
        return out


# --------------------------------------------------------------------------- penetration
def _make_rhs(law: ResistanceLaw, mass: float, push, offset: float, gravity: float, extra=None,
              budget: int = MAX_EVALUATIONS, weight: float | None = None):
    """``push(u)``: the drive's force at travel u from release (floats). [N]; ``budget``: evaluations allowed;
    ``weight``: the body's weight when ``mass`` holds more inertia than weighs (fluid carried along). [N]"""
    a0, a1, b, d = law.strength_n, law.friction_n_m, law.damping_n_s_m, law.inertia_n_s2_m2
    weight = mass * gravity if weight is None else weight
    calls = [0]

    def rhs(_t, y):
        calls[0] += 1
        if calls[0] > budget:
            raise SimulationLimit(f"the penetration took more than {budget:,} integration steps (the "
                                  f"design's time scales are too far apart: check stiffness, masses and the "
                                  f"Eq. 9 coefficients)")
        x, v = y[0], y[1]
        vp = v if v > 0.0 else 0.0
        spring = push(x + offset)
        resist = reduced(x, vp, a0, a1, b, d)
        if extra is None:
            return [v, (spring + weight - resist) / mass, b * vp * vp, d * vp * vp * vp]
        more = extra(x, vp)
        return [v, (spring + weight - resist - more) / mass, b * vp * vp, d * vp * vp * vp, more * vp]

    return rhs


def _event(fn, direction: float):
    fn.terminal = True
    fn.direction = direction
    return fn


def _root(fn, lo: float, hi: float) -> float:
    """Root of ``fn`` on [lo, hi] where it changes sign (Brent's method, to round-off)."""
    from scipy.optimize import brentq

    if fn(lo) >= 0.0:
        return lo
    return float(brentq(fn, lo, hi, xtol=1e-15, rtol=4 * np.finfo(float).eps))


PRESCRIBED_GRID = 401
"""Points of a prescribed path's grid (its dense output's work integral, and where the peak of R is looked for
before it is refined)."""


def _prescribed_penetration(design: Design, law: ResistanceLaw, t0: float, v: float, extra=None):
    """The penetration of a drive that holds the speed ``v`` (:mod:`pencli.model.push`): x = v·(t − t0) to full
    depth, the rate terms' work b·v·x and d·v²·x, an extra resistance's ∫ R dx by adaptive quadrature (its
    running value on a grid, Simpson's rule between the nodes); as :func:`_integrate_penetration` returns."""
    from scipy.integrate import cumulative_simpson, quad

    depth = design.penetration_depth_m
    if not v > 0.0:
        raise ModelError(f"a push at {v:g} m/s: expected a rate above 0")
    t_end = t0 + depth / v
    damping, inertia = law.damping_n_s_m * v, law.inertia_n_s2_m2 * v * v  # forces along the path [N]
    grid = np.linspace(0.0, depth, PRESCRIBED_GRID)
    if extra is not None:
        running = cumulative_simpson(np.array([extra(float(x), v) for x in grid]), x=grid, initial=0.0)
        total = quad(lambda x: extra(float(x), v), 0.0, depth, epsabs=0.0, epsrel=1e-11, limit=500)[0]
        running *= total / running[-1] if running[-1] != 0.0 else 1.0  # ends on the quadrature's value

    def dense(t):
        x = np.clip(v * (np.asarray(t, dtype=float) - t0), 0.0, depth)
        rows = [x, np.full_like(x, v), damping * x, inertia * x]
        if extra is not None:
            rows.append(np.interp(x, grid, running))
        return np.array(rows)

    steps = t0 + grid / v
    y_end = dense(np.array([t_end]))[:, 0]
    y_end[0] = depth
    return [(t0, t_end, dense, steps)], "full_depth", t_end, y_end


def _integrate_penetration(design: Design, law: ResistanceLaw, t0: float, v0: float, rtol: float = _RTOL,
                           extra=None, drive: Drive = SPRINGS, budget: int = MAX_EVALUATIONS):
    """Integrate from contact; returns (segments, end, t_end, y_end)."""
    mass = inertia_of(drive, design)
    offset = design.surface_offset_m
    depth = design.penetration_depth_m
    rhs = _make_rhs(law, mass, lambda u: drive.force(design, u), offset, design.gravity_m_s2, extra, budget,
                    weight=design.effective_mass_kg * design.gravity_m_s2)
    y = np.array([0.0, v0, 0.0, 0.0] + ([0.0] if extra is not None else []))
    t = t0
    segments = []
    if v0 <= 0.0 and rhs(t, y)[1] <= 0.0:
        return segments, "arrest", t, y  # the drive cannot overcome the static resistance
    atol = np.array([1e-13, 1e-12, 1e-11, 1e-11, 1e-11][:y.size])
    ev_full = _event(lambda _t, s: s[0] - depth, 1.0)
    ev_arrest = _event(lambda _t, s: s[1], -1.0)
    stops = {"full": ev_full, "arrest": ev_arrest}
    creep = None if extra is not None or not drive.closed_form else creep_target(design, law)
    if creep is not None:
        stops["creep"] = _event(lambda _t, s: s[0] - creep[0], 1.0)
    # depths where the drive's force or slope jumps (the springs reach free length): > 0, still ahead
    corners = {f"corner {i}": u - offset for i, u in enumerate(drive.corners(design)) if 0.0 < u - offset < depth}
    for name, corner in corners.items():
        stops[name] = _event(lambda _t, s, c=corner: s[0] - c, 1.0)
    method = "Radau" if _stiff(design, law, drive) else "DOP853"
    while True:
        sol = solve_ivp(rhs, (t, t + _WINDOW_S), y, method=method, rtol=rtol, atol=atol,
                        events=list(stops.values()), dense_output=True)
        hit = [name for name, times in zip(stops, sol.t_events) if len(times)]
        if not hit:  # still moving: go on from here
            segments.append((sol.t[0], sol.t[-1], sol.sol, sol.t))
            t, y = float(sol.t[-1]), np.array(sol.y[:, -1], dtype=float)
            continue
        name = hit[0]
        i = list(stops).index(name)
        t_hit = float(sol.t_events[i][0])
        y_hit = np.array(sol.y_events[i][0], dtype=float)
        segments.append((sol.t[0], t_hit, sol.sol, sol.t))
        if name == "full":
            y_hit[0] = depth
            return segments, "full_depth", t_hit, y_hit
        if name == "arrest":
            if y_hit[0] > depth:
                # the tip passed the stops and would have come back within the same step, so the depth
                # event saw no sign change at the step ends: the stops were reached first, where x = depth
                t_full = _root(lambda tt: sol.sol(tt)[0] - depth, float(sol.t[0]), t_hit)
                y_full = np.array(sol.sol(t_full), dtype=float)
                y_full[0] = depth
                segments[-1] = (sol.t[0], t_full, sol.sol, sol.t)
                return segments, "full_depth", t_full, y_full
            y_hit[1] = 0.0
            return segments, "arrest", t_hit, y_hit
        del stops[name]  # a creep distance or a corner of the drive, passed: restart without it
        if name == "creep":
            if y_hit[1] <= creep[1]:  # slow: on the slow mode, it creeps towards x* and never gets there
                rest = creep[2]
                y_hit[2] += _work(design, law, y_hit[0], rest) + 0.5 * mass * y_hit[1] ** 2  # booked at x*
                y_hit[0], y_hit[1] = rest, 0.0
                return segments, "creep", t_hit, y_hit
            t, y = t_hit, y_hit  # fast: it will pass x* and arrest beyond it
            continue
        y_hit[0] = corners[name]  # exactly at the corner (the springs at free length)
        t, y = t_hit, y_hit
        if _stiff(design, law, drive, corners[name] + offset):
            method = "Radau"


def creep_target(design: Design, law: ResistanceLaw):
    """(x* − δ [m], speed limit ω0·δ [m/s], x* [m], the net force's slope there k [N/m]) of a design that can
    creep, else ``None``: the rule of :func:`pencli.model.design.creep_point`, which the batch simulator uses
    too."""
    point = creep_point(*_at_rest(design, law))
    return None if math.isnan(point[0]) else point


def _at_rest(design: Design, law: ResistanceLaw) -> tuple[float, ...]:
    """(m, kd, xk, m·g, a0, a1, b, depth): what the rest-depth rules of :mod:`pencli.model.design` read (SI;
    ``xk`` the depth where the springs reach free length)."""
    m = float(design.effective_mass_kg)
    return (m, float(design.drive_stiffness_n_m), float(design.stroke_m - design.surface_offset_m),
            m * float(design.gravity_m_s2), law.strength_n, law.friction_n_m, law.damping_n_s_m,
            float(design.penetration_depth_m))


def _work(design: Design, law: ResistanceLaw, x0: float, x1: float) -> float:
    """∫ (drive + weight − strength − friction) dx from x0 to x1. [J]"""
    return float(static_work(x0, x1, design.stroke_m - design.surface_offset_m, design.drive_stiffness_n_m,
                             design.effective_mass_kg * design.gravity_m_s2, law.strength_n, law.friction_n_m))


STIFF_RATIO = 100.0
"""Above this (damping time scale / motion time scale)⁻¹, i.e. b²/(m·k) with k = the largest force slope,
the penetration is integrated with Radau (implicit) instead of DOP853, whose steps the damping would
hold to m/b. [–]"""


def _stiff(design: Design, law: ResistanceLaw, drive: Drive = SPRINGS, beyond_m: float = 0.0) -> bool:
    """Whether the damping makes the motion stiff past travel ``beyond_m`` from release [m]: past the springs'
    free length their slope no longer counts, and a blade creeping at its terminal speed m·g/b under a weak
    gravity would hold an explicit integrator to steps of m/b for hours of simulated time."""
    b = law.damping_n_s_m
    k = drive.largest_slope(design, beyond_m) + law.friction_n_m
    return b > 0.0 and b * b > STIFF_RATIO * design.effective_mass_kg * max(k, 1e-300)


def _peak(law: ResistanceLaw, segments, extra=None) -> tuple[float, float]:
    """Largest R over the penetration and the depth where it occurs. [N, m]"""
    extra_v = None if extra is None else np.vectorize(extra, otypes=[float])

    def resistance(state):
        x, v = state[0], np.maximum(state[1], 0.0)
        r = reduced(x, v, law.strength_n, law.friction_n_m, law.damping_n_s_m, law.inertia_n_s2_m2)
        return r if extra_v is None else r + extra_v(x, v)

    best_r, best_x = -math.inf, 0.0
    for t_start, t_end, dense, steps in segments:
        if not t_end > t_start:
            continue
        grid = np.union1d(np.linspace(t_start, t_end, 401), steps[(steps >= t_start) & (steps <= t_end)])
        states = dense(grid)
        values = resistance(states)
        k = int(np.argmax(values))
        r_k, x_k = float(values[k]), float(states[0, k])
        if 0 < k < grid.size - 1:  # interior maximum: refine on the dense output
            res = minimize_scalar(lambda tt: -float(resistance(dense(tt))), bounds=(grid[k - 1], grid[k + 1]),
                                  method="bounded", options={"xatol": 1e-12 * max(1.0, abs(grid[k]))})
            if -res.fun > r_k:
                r_k, x_k = float(-res.fun), float(dense(res.x)[0])
        if r_k > best_r:
            best_r, best_x = r_k, x_k
    return best_r, best_x


def check_contact_speed(speed_m_s, what: str = "speed at contact") -> None:
    """Refuse a given speed at contact outside 0 … :data:`MAX_CONTACT_SPEED_M_S` (one value or an array). [m/s]"""
    values = np.asarray(speed_m_s, dtype=float)
    bad = values[~((values >= 0.0) & (values <= MAX_CONTACT_SPEED_M_S))]
    if bad.size:
        raise ModelError(f"{what} {bad.flat[0]:g} m/s: expected 0 to {MAX_CONTACT_SPEED_M_S:g} m/s")


def simulate(design: Design, terms: Iterable[str] | str | None = None, *,
             speed_at_contact_m_s: float | None = None, output_rate_hz: float = 50_000.0,
             rtol: float = _RTOL, extra_resistance=None, geometry: Geometry = BLADE,
             drive: Drive = SPRINGS, max_evaluations: int = MAX_EVALUATIONS) -> SimulationResult:
    """Simulate one shot of the rig (CONTRACT §2).

    Parameters
    ----------
    design
        Blade, material and launcher, SI.
    terms
        Eq. 9 terms switched on (default: all four).
    speed_at_contact_m_s
        When given, skip the flight and start at the surface with this speed
        (BAM's "speed at comet contact"); the springs keep their geometry. [m/s]
    output_rate_hz
        Sampling rate of the returned trajectory (events are added exactly). [Hz]
    rtol
        Relative tolerance of the penetration integration (default 1e-10; fits use less).
    extra_resistance
        Optional ``f(x [m], v [m/s]) -> N`` added to R in the material (a diagnosis effect's
        term); its dissipated energy is booked in ``energy_other_j`` and its force in ``resistance_n``.
    geometry
        The penetrator (default: CONTRACT §2's blade, Eq. 9); see :mod:`pencli.model.geometry`.
    drive
        What pushes the body (default: CONTRACT §2's springs); see :mod:`pencli.model.drive`.
    max_evaluations
        Right-hand-side evaluations the penetration may take before it ends with :class:`SimulationLimit`
        (default :data:`MAX_EVALUATIONS`; a caller for whom the figure is a side note gives less).

    Returns
    -------
    SimulationResult
        Summary (CONTRACT §5) and trajectory.
    """
    chosen = parse_terms(terms)
    law = geometry.law(design, chosen)
    other = None
    if law is None:  # not Eq. 9's form: the whole resistance is integrated as a force of its own
        law = ResistanceLaw(0.0, 0.0, 0.0, 0.0)
        other = geometry.resistance(design, chosen)
        extra_resistance = other if extra_resistance is None else _sum(other, extra_resistance)
    mass = inertia_of(drive, design)  # inertia; the weight is the body's own
    flight = drive.flight(design)
    prescribed = prescribed_speed(drive) is not None
    if speed_at_contact_m_s is not None and prescribed:
        raise ModelError(f"a speed at contact of {speed_at_contact_m_s:g} m/s for a push at a constant rate, "
                         f"which meets the surface at its own rate: set push_rate_mm_s instead")

    if speed_at_contact_m_s is None:
        t_contact, v_contact = flight.reach(design.surface_offset_m)
        if not math.isfinite(t_contact):
            return replace(_no_contact(design, chosen, flight, drive), model=model_name(geometry, drive))
        u_start, initial_ke = 0.0, 0.0
    else:
        t_contact, v_contact = 0.0, float(speed_at_contact_m_s)
        check_contact_speed(v_contact)
        u_start, initial_ke = design.surface_offset_m, 0.5 * mass * v_contact ** 2

    _check_scales(design, law, v_contact, drive, other)
    if prescribed:  # the motion is the push's (pencli.model.push): read the resistance along it
        segments, end, t_end, y_end = _prescribed_penetration(design, law, t_contact, v_contact, extra_resistance)
    else:
        segments, end, t_end, y_end = _integrate_penetration(design, law, t_contact, v_contact, rtol,
                                                             extra_resistance, drive, max_evaluations)
    x_end, v_end = float(y_end[0]), float(y_end[1])
    full = end == "full_depth"

    # Energy book-keeping (each term is the integral of that term over depth).
    e_strength = law.strength_n * x_end
    e_friction = 0.5 * law.friction_n_m * x_end ** 2
    # integrals of v² and v³ ≥ 0: what the integrator's interpolation leaves below 0 is round-off (−4e-71 J seen
    # on a design that crept for 78 s); energy_balance_error_j still holds any real misbalance
    e_damping, e_inertia = max(float(y_end[2]), 0.0), max(float(y_end[3]), 0.0)
    u_end = x_end + design.surface_offset_m
    spring_j = drive.work(design, u_start, u_end)
    gravity_j = design.effective_mass_kg * design.gravity_m_s2 * (u_end - u_start)
    final_ke = 0.5 * mass * v_end ** 2
    e_extra = float(y_end[4]) if len(y_end) > 4 else 0.0
    if prescribed:  # the push does what the motion takes: the resistance's work and the speed, less gravity's
        spring_j = e_strength + e_friction + e_damping + e_inertia + e_extra + final_ke - initial_ke - gravity_j
    balance = initial_ke + spring_j + gravity_j - (final_ke + e_strength + e_friction + e_damping + e_inertia
                                                   + e_extra)

    if segments:
        peak_n, peak_x = _peak(law, segments, extra_resistance)
    else:  # stopped at the surface
        peak_n, peak_x = law.strength_n, 0.0

    notes = []
    tau = None
    at_rest = _at_rest(design, law)
    near = end == "arrest" and bool(near_critical(*at_rest))
    if near:
        gap = 1.0 - float(damping_ratio_at_rest(*at_rest))
        notes.append(f"ill-conditioned: the motion is damped within {100 * gap:.2g} % of "
                     f"critical at the rest depth {x_end * 1e3:.6g} mm and passes it by less than float64 "
                     f"resolves, so the penetration time ({t_end - t_contact:.3g} s) is round-off; the depth and "
                     f"energies stand (slightly more damping makes it creep, within 1 µm, in a well-defined time)")
    if end == "creep":
        creep = creep_target(design, law)
        tau = creep_time_constant(mass, law.damping_n_s_m, creep[3])
        notes.append(f"creep: the penetration time is to within {CREEP_DISTANCE_M * 1e6:g} µm of the rest depth "
                     f"{creep[2] * 1e3:.6g} mm, which the tip approaches with time constant {tau:.3g} s (each "
                     f"tenfold-closer end adds {tau * math.log(10.0):.3g} s)")
    if t_end * output_rate_hz > MAX_SAMPLES:
        notes.append(f"the motion lasts {t_end:.3g} s: its trajectory is sampled at {MAX_SAMPLES / t_end:.3g} Hz "
                     f"instead of {output_rate_hz:g} Hz to stay within {MAX_SAMPLES:,} samples")
        output_rate_hz = MAX_SAMPLES / t_end
    trajectory = _sample(design, law, flight, segments, speed_at_contact_m_s is None, t_contact, v_contact,
                         t_end, y_end, output_rate_hz, extra_resistance, drive)
    summary = Summary(
        contact_speed_m_s=v_contact,
        penetration_time_s=t_end - t_contact,
        final_depth_mm=x_end * 1e3,
        full_penetration=full,
        peak_resistance_n=peak_n,
        peak_resistance_depth_mm=peak_x * 1e3,
        residual_ke_j=final_ke if full else 0.0,
        spring_energy_j=spring_j,
        energy_strength_j=e_strength,
        energy_friction_j=e_friction,
        energy_damping_j=e_damping,
        energy_inertia_j=e_inertia,
        contact_time_s=t_contact,
        end=end,
        gravity_work_j=gravity_j,
        initial_ke_j=initial_ke,
        energy_balance_error_j=balance,
        energy_other_j=e_extra,
        creep_time_constant_s=tau,
        near_critical=near,
    )
    energy_in = initial_ke + abs(spring_j) + abs(gravity_j)
    if abs(balance) > ENERGY_TOLERANCE * max(energy_in, 1.0):
        notes.append(f"the energy balance closes only to {balance:.3g} J of {energy_in:.3g} J put in "
                     f"(tolerance {ENERGY_TOLERANCE:g}); the design's scales strain float64, treat the figures "
                     f"with care")
    message = "; ".join(notes)
    return SimulationResult(design, chosen, speed_at_contact_m_s, summary, trajectory, model_name(geometry, drive),
                            success=True, message=message)


def _no_contact(design: Design, chosen: tuple[str, ...], flight: FlightPath, drive: Drive) -> SimulationResult:
    """The body never reaches the surface (no gravity and no push left, or it floats)."""
    mass = inertia_of(drive, design)
    t = np.linspace(0.0, flight.release_time_s, 2)
    u, v, a = flight.state(t)
    spring_j = drive.work(design, 0.0, float(u[-1]))
    zeros = np.zeros_like(t)
    trajectory = Trajectory(t, u - design.surface_offset_m, v, a, zeros, zeros, zeros, zeros, zeros,
                            drive.force(design, u), design.load_cell_mass_kg * a,
                            np.zeros(t.size, dtype=np.int8))
    summary = Summary(0.0, 0.0, 0.0, False, 0.0, 0.0, 0.0, spring_j, 0.0, 0.0, 0.0, 0.0, math.inf,
                      "no_contact", 0.0, 0.0, spring_j - 0.5 * mass * float(v[-1]) ** 2)
    return SimulationResult(design, chosen, None, summary, trajectory, success=True,
                            message="the body never reaches the surface (nothing pushes it there, or it floats)")


def _sample(design, law, flight, segments, with_flight, t_contact, v_contact, t_end, y_end, rate_hz, extra=None,
            drive: Drive = SPRINGS):
    """Uniformly sampled trajectory, with contact and the end included exactly."""
    step = 1.0 / rate_hz
    mass = inertia_of(drive, design)
    weight = design.effective_mass_kg * design.gravity_m_s2
    parts_t, parts_x, parts_v, parts_a, parts_phase = [], [], [], [], []
    if with_flight and t_contact > 0.0:
        tf = np.arange(0.0, t_contact, step)
        u, v, a = flight.state(tf)
        parts_t.append(tf)
        parts_x.append(u - design.surface_offset_m)
        parts_v.append(v)
        parts_a.append(a)
        parts_phase.append(np.zeros(tf.size, dtype=np.int8))
    for t_start, t_stop, dense, _ in segments:
        tp = np.arange(t_start, t_stop, step)
        states = dense(tp) if tp.size else np.zeros((len(y_end), 0))
        parts_t.append(tp)
        parts_x.append(states[0])
        parts_v.append(states[1])
        parts_a.append(np.zeros(tp.size))  # filled below from the equation of motion
        parts_phase.append(np.ones(tp.size, dtype=np.int8))
    parts_t.append(np.array([t_end]))
    parts_x.append(np.array([float(y_end[0]) if segments else 0.0]))
    parts_v.append(np.array([float(y_end[1]) if segments else v_contact]))
    parts_a.append(np.zeros(1))
    parts_phase.append(np.ones(1, dtype=np.int8))
    t = np.concatenate(parts_t)
    x = np.concatenate(parts_x)
    v = np.concatenate(parts_v)
    a_flight = np.concatenate(parts_a)
    phase = np.concatenate(parts_phase)
    in_material = phase == 1
    strength, friction, damping, inertia = law.terms_in_contact(x, v)
    mask = in_material.astype(float)
    strength, friction, damping, inertia = strength * mask, friction * mask, damping * mask, inertia * mask
    resistance = strength + friction + damping + inertia
    if extra is not None:
        resistance = resistance + mask * np.vectorize(extra, otypes=[float])(x, np.maximum(v, 0.0))
    if prescribed_speed(drive) is not None:  # the push holds the speed: it takes R − m·g
        spring = np.where(in_material, resistance - weight, 0.0)
        a = np.zeros_like(t)
    else:
        spring = drive.force(design, x + design.surface_offset_m)
        a = np.where(in_material, (spring + weight - resistance) / mass, a_flight)
    load_cell = resistance + design.load_cell_mass_kg * a
    return Trajectory(t, x, v, a, strength, friction, damping, inertia, resistance, spring, load_cell, phase)


def _sum(first, second):
    """R(x, v) of two resistances together. [N]"""
    return lambda x, v: first(x, v) + second(x, v)


__all__ = ["CREEP_DISTANCE_M", "MODEL_NAME", "model_name", "PHASES", "TERMS", "Flight", "SimulationResult", "Summary", "Trajectory",
           "creep_target", "flight_of", "simulate"]
