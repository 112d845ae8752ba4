r"""Inertia subtraction: penetration resistance from the load-cell force.

The blade and its mount (mass :math:`m_{lc}`) sit between the material and
the force sensor, so the tared reading is :math:`F = R + m_{lc}\,a` and

.. math:: R = F - m_{lc}\, a

with :math:`a` from the encoder (:mod:`pencli.filter.derivatives`).  In free
flight :math:`R = 0`, so the same record also measures :math:`m_{lc}`
(:func:`estimate_load_cell_mass`), a check on the parameter file.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from typing import Sequence

import numpy as np

from pencli.filter.derivatives import CORNER_METHOD, DEFAULT_METHOD, LSQ_KNOT_S, derivatives, encoder_step_m
from pencli.filter.tare import STANDOFF_TOLERANCE_M, Events, force_onset


@dataclass(frozen=True)
class MassEstimate:
    """Load-cell mass from the free flight, F = m_lc·a."""

    value_kg: float
    stderr_kg: float
    n_samples: int
    file_value_kg: float

    @property
    def disagrees(self) -> bool:
        """Differs from the parameter file by more than 3 standard errors (and 2 %)."""
        gap = abs(self.value_kg - self.file_value_kg)
        return gap > 3 * self.stderr_kg and gap > 0.02 * max(self.file_value_kg, 1e-9)

    def to_dict(self) -> dict:
        return {**asdict(self), "disagrees": self.disagrees}


@dataclass(frozen=True)
class Kinematics:
    """Velocity, acceleration and resistance of a tared run, SI."""

    velocity_m_s: np.ndarray
    acceleration_m_s2: np.ndarray
    resistance_n: np.ndarray
    mass_used_kg: float
    mass_estimate: MassEstimate | None
    encoder_step_m: float
    """The position quantum the spline smoothed for. [m]"""
    method: str = DEFAULT_METHOD
    """The derivative method used."""


def effective_samples(residuals: np.ndarray, max_lag: int = 2000) -> float:
    """n / τ, τ = 1 + 2 Σ ρ_k summed until the autocorrelation first drops below zero.

    Samples worth of independent information: residuals of 30 kHz records are
    correlated over milliseconds, and counting them as independent would make
    every uncertainty far too small.
    """
    r = np.asarray(residuals, dtype=float) - float(np.mean(residuals))
    n = r.size
    denom = float(np.dot(r, r))
    if n < 3 or denom == 0.0:
        return float(n)
    size = 1 << int(np.ceil(np.log2(2 * n)))
    spectrum = np.fft.rfft(r, size)
    acf = np.fft.irfft(spectrum * np.conj(spectrum), size)[: min(n, max_lag)] / denom
    negative = np.flatnonzero(acf <= 0.0)
    cut = int(negative[0]) if negative.size else acf.size
    tau = 1.0 + 2.0 * float(np.sum(acf[1:cut]))
    return float(min(max(n / max(tau, 1.0), 2.0), n))


def estimate_load_cell_mass(time_s: np.ndarray, force_n: np.ndarray, acceleration_m_s2: np.ndarray,
                            events: Events, file_value_kg: float) -> MassEstimate | None:
    """Least-squares m_lc from F = m_lc·a over the free flight (2 ms after the release to 1 ms before contact)."""
    flight = (time_s > max(events.motion_start_s, 0.0) + 2e-3) & (time_s < events.contact_s - 1e-3)
    if flight.sum() < 30:
        return None
    a = acceleration_m_s2[flight]
    f = force_n[flight]
    if float(np.dot(a, a)) == 0.0:
        return None
    m = float(np.dot(f, a) / np.dot(a, a))
    resid = f - m * a
    n_eff = effective_samples(resid)
    sigma2 = float(np.dot(resid, resid)) / max(resid.size - 1, 1)
    stderr = float(np.sqrt(sigma2 / np.dot(a, a) * resid.size / n_eff))
    return MassEstimate(m, stderr, int(flight.sum()), file_value_kg)


def subtract_inertia(time_s: np.ndarray, depth_m: np.ndarray, force_n: np.ndarray, events: Events,
                     load_cell_mass_kg: float, *, method: str | None = None, use_flight_mass: bool = False
                     ) -> Kinematics:
    """Velocity, acceleration and R = F − m_lc·a of a tared run.

    Parameters
    ----------
    time_s : time since release. [s]
    depth_m : tip depth. [m]
    force_n : tared axial force, compression positive. [N]
    events : from :func:`pencli.filter.tare.detect_events`.
    load_cell_mass_kg : m_lc from the penetrator file. [kg]
    method : derivative method (:data:`pencli.filter.derivatives.METHODS`); default :func:`method_for` the events.
    use_flight_mass : subtract with the mass estimated from the free flight instead.
    """
    rate = (time_s.size - 1) / (time_s[-1] - time_s[0])
    step = encoder_step_m(depth_m)
    motion = kinematic_events(time_s, force_n, events)
    method = method or method_for(events)
    velocity, acceleration = derivatives(depth_m, rate, motion_breaks(time_s, motion), method, count_m=step,
                                         joins=motion_joins(time_s, motion), at_rest=rest_mask(time_s, events))
    estimate = estimate_load_cell_mass(time_s, force_n, acceleration, events, load_cell_mass_kg)
    mass = estimate.value_kg if (use_flight_mass and estimate is not None) else load_cell_mass_kg
    resistance = force_n - mass * acceleration  # R = F − m_lc·a
    return Kinematics(velocity, acceleration, resistance, mass, estimate, step, method)


def kinematic_events(time_s: np.ndarray, force_n: np.ndarray, events: Events) -> Events:
    """``events`` with the contact where the force sees it, for the derivatives' breaks and joins.

    The acceleration jumps when the tip meets the material.  The position's
    contact is where the tip passes the file's stand-off; a block whose surface
    sits elsewhere (stand-off scatter) moves the jump by a fraction of a
    millisecond (0.1–0.2 ms for 1 mm of scatter on the sim rig), and the
    spline should break where the jump is.  The force's change
    point (:func:`pencli.filter.tare.force_onset`) is used when it lies within
    the stand-off tolerance of the position's contact, at the contact speed.
    """
    seen = force_onset(time_s, force_n, events.contact_s, span_s=_contact_span_s(events))
    if not events.motion_start_s < seen < events.stop_s:
        return events
    return replace(events, contact_s=seen)


def _contact_span_s(events: Events) -> float:
    """How far from the position's contact the force's is looked for: the stand-off tolerance at the contact
    speed, at most 4 ms. [s]"""
    return min(4e-3, STANDOFF_TOLERANCE_M / max(events.contact_speed_m_s, 0.1))


def late_force_rise(time_s: np.ndarray, force_n: np.ndarray, events: Events, lag_s: float) -> float | None:
    """The force's rise at contact when it comes later than :func:`kinematic_events` looks, else None. [s]

    A force chain that lags by up to ``lag_s`` moves the rise that much past where the block's surface puts
    it; with the surface past the file's stand-off too, it can fall beyond the stand-off tolerance.  The
    change point is then looked for over a span ``lag_s`` wider, and kept only if it lies past the narrow
    span's end (inside it, the narrow search has already seen what there is to see)."""
    span = _contact_span_s(events)
    rise = force_onset(time_s, force_n, events.contact_s, span_s=span + lag_s)
    return rise if events.contact_s + span < rise < events.stop_s else None


def motion_joins(time_s: np.ndarray, events: Events, contact: bool = True) -> list[tuple[float, int]]:
    """Release, contact (unless ``contact`` is False: a sharp tip, whose force rises from nothing, puts no jump
    in the acceleration there), the corners of the resistance the tip passed (:attr:`Events.corners_s`) and stop
    as (time since the first sample [s], continuity): the velocity is continuous at each (1) except at the hard
    stops (0); at a corner the acceleration is continuous too and only its slope jumps (2).

    A corner less than one knot spacing of the least-squares spline (:data:`LSQ_KNOT_S`) before the stop is not
    joined: approaching an arrest the tip crawls, the record places the corner no better than one count's travel
    time, and the piece between it and the stop is too short for the record to determine.  A 50 mm cone stopping
    0.3 ms past its shoulder in Grill Brick read its acceleration up to 56 % of the peak resistance off there
    (``python -m bench.bench_derivatives --cones --material grill_brick``: the stop's last 0.5 ms at 6.0 % RMS
    with those joins, 3.5 % without)."""
    t0 = float(time_s[0])
    corners = [(c - t0, CORNER_CONTINUITY) for c in events.corners_s
               if events.contact_s < c <= events.stop_s - LSQ_KNOT_S]
    return [(events.motion_start_s - t0, 1), *([(events.contact_s - t0, 1)] if contact else []), *corners,
            (events.stop_s - t0, 0 if events.end == "full_depth" else 1)]


CORNER_CONTINUITY = 2
"""At a corner of the resistance the force, and so the acceleration, is continuous; its slope is not."""


def corner_times(time_s: np.ndarray, depth_m: np.ndarray, events: Events, depths_m: Sequence[float]
                 ) -> tuple[float, ...]:
    """When the record first reaches each corner depth (:func:`pencli.model.geometry.corner_depths_m`) between
    contact and stop; a corner the tip never reaches is left out. [s]"""
    moving = (time_s > events.contact_s) & (time_s < events.stop_s)
    out = []
    for depth in depths_m:
        reached = np.flatnonzero(moving & (depth_m >= depth))
        if reached.size:
            out.append(float(time_s[reached[0]]))
    return tuple(out)


def method_for(events: Events) -> str:
    """The derivative method the inertia stage uses unless told: the smoothing spline, or the least-squares spline
    joined at the corners where the motion passes one (:data:`~pencli.filter.derivatives.CORNER_METHOD`).

    The smoothing spline spends its residual budget (twice the quantisation variance) on as few knots as it can:
    over a blade's penetration window one quintic meets it.  A cone's force bends at its shoulder, and a quintic
    through the bend still meets the budget while its acceleration misses by several per cent of the peak
    resistance; the least-squares spline, with a knot at the corner that lets the acceleration's slope jump, does
    not."""
    return CORNER_METHOD if events.corners_s else DEFAULT_METHOD


def rest_mask(time_s: np.ndarray, events: Events) -> np.ndarray:
    """Where the blade is at rest: more than a sample before the release, and after the arrest."""
    rate = (time_s.size - 1) / (time_s[-1] - time_s[0])
    return (time_s < events.motion_start_s - 1.0 / rate) | (time_s > events.stop_s)


def motion_breaks(time_s: np.ndarray, events: Events, contact: bool = True) -> list[int]:
    """Sample indices where the motion's acceleration jumps: release, contact (unless ``contact`` is False, as
    :func:`motion_joins`), stop."""
    return [int(np.searchsorted(time_s, events.motion_start_s)) - 1,
            *([int(np.searchsorted(time_s, events.contact_s))] if contact else []),
            int(np.searchsorted(time_s, events.stop_s)) + 1]
