"""The bed's resistance fitted across free-fall drops: q = σ + b·z + c·v on the cone's frontal area.

In the bed, the probe's equation of motion (x and a positive down) is

    (m + C_a·ρ_w·V)·a = (m − ρ_w·V)·g − ½·ρ_w·C_D·A·v|v| − A_f(z)·q(z, v),

so each sample from impact to stop gives the bed's force from the measured
acceleration, speed and depth (a :class:`pencli.sensors.Reading` of the
``accelerometers`` chain) and the probe's known mass, volume, drag and added
mass; a chain that measures the bed's force itself (a tip load cell) gives it
without the equation.  q is linear in
(σ, b, c), fitted by least squares over every drop at once (one drop
alone barely separates b from c: depth and speed move together).  The
frontal area is the cone geometry's (:class:`pencli.model.geometry.Cone`).
Pure functions, no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from pencli.filter.freefall import G
from pencli.model.geometry import Cone, embedded_volume_m3
from pencli.sensors import Reading


FLIGHT_SKIP_S = 0.02
"""The fall's first moments left out of a fit of the drag and added mass: at the release the deceleration jumps,
and the stitched sensors' filters smear the jump over a few samples. [s]"""
MIN_SPEED_M_S = 0.05
"""Slowest sample fitted: where the probe stops, the bed holds it with whatever force its weight needs, not q's
(and the stop falls between two samples). [m/s]"""


@dataclass(frozen=True)
class FreeFallProbe:
    """What the fit must know of the probe: mass [kg], volume [m³], its cone (half-angle [rad], shaft radius [m]),
    drag and added-mass coefficients [–], the water's density [kg/m³] and a tether's tension [N]."""

    mass_kg: float
    volume_m3: float
    half_angle_rad: float
    shaft_radius_m: float
    drag_coefficient: float
    added_mass_coefficient: float
    water_density: float = 1025.0
    tether_force_n: float = 0.0
    bed_density: float = 0.0
    """The bed's bulk density [kg/m³], which buoys the cone's volume below the surface by (ρ_b − ρ_w)·g per m³
    (0: not taken into account)."""

    @property
    def net_weight_n(self) -> float:
        """(m − ρ_w·V)·g − T: the weight less the buoyancy and the tether's pull. [N]"""
        return (self.mass_kg - self.water_density * self.volume_m3) * G - self.tether_force_n


@dataclass(frozen=True)
class BedFit:
    """σ [kPa], b [kPa/m], c [kPa·s/m], their standard errors, the samples and drops fitted, and the residual's
    RMS over the bed's mean force [–]."""

    strength_kpa: float
    gradient_kpa_m: float
    damping_kpa_s_m: float
    standard_errors: tuple[float, ...]
    """Of σ, b, c (and C_D, C_a when fitted)."""
    samples: int
    drops: int
    relative_rms: float
    drag_coefficient: float | None = None
    """C_D fitted as a nuisance (None: the probe's was taken)."""
    added_mass_coefficient: float | None = None
    """C_a fitted as a nuisance (None: the probe's was taken)."""


def bed_force_n(reading: Reading, probe: FreeFallProbe) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(depth in the bed [m], speed [m/s], the bed's force [N], less its buoyancy) at every row from impact to
    stop: the force the chain measured, else the equation of motion's from the measured acceleration."""
    rows = reading.penetration
    depth, speed = reading.depth_m(), reading.speed_m_s[rows]
    if reading.force_n is not None:
        force = reading.force_n[rows]
    else:
        rho = probe.water_density
        m_eff = probe.mass_kg + probe.added_mass_coefficient * rho * probe.volume_m3
        section = math.pi * probe.shaft_radius_m ** 2
        force = (probe.net_weight_n - 0.5 * rho * probe.drag_coefficient * section * speed
                 * np.abs(speed) - m_eff * reading.accel_m_s2[rows])
    return depth, speed, force - bed_buoyancy_n(depth, probe)


def bed_buoyancy_n(depth: np.ndarray, probe: FreeFallProbe) -> np.ndarray:
    """(ρ_b − ρ_w)·g·V_e(z): what the bed buoys of the cone's volume below its surface at each depth ``depth`` [m]
    (0 without a bed density). [N]"""
    if probe.bed_density <= 0.0:
        return np.zeros(np.shape(depth))
    cone = Cone(half_angle_rad=probe.half_angle_rad, shaft_radius_m=probe.shaft_radius_m)
    volume = np.array([embedded_volume_m3(cone, None, float(z)) for z in np.ravel(depth)]).reshape(np.shape(depth))
    return (probe.bed_density - probe.water_density) * G * volume


def _fitted_rows(reading: Reading, probe: FreeFallProbe, cone: Cone):
    """The rows :func:`fit_bed` fits (the whole cone in the bed, faster than ``MIN_SPEED_M_S``), as (mask over the
    rows from impact to stop, depth [m], speed [m/s], the bed's force [N], the cone's frontal area [m²]) there."""
    depth, speed, force = bed_force_n(reading, probe)
    inside = (depth > cone.cone_length_m) & (speed > MIN_SPEED_M_S)
    area = np.array([cone.section_areas(z, 0.0)[0] for z in depth[inside]])
    return inside, depth[inside], speed[inside], force[inside], area


def bed_pressure(reading: Reading, probe: FreeFallProbe) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(depth [m], speed [m/s], the bed's pressure on the cone's frontal area [kPa]) at the rows :func:`fit_bed`
    fits: the whole cone in the bed, faster than ``MIN_SPEED_M_S``."""
    cone = Cone(half_angle_rad=probe.half_angle_rad, shaft_radius_m=probe.shaft_radius_m)
    _, depth, speed, force, area = _fitted_rows(reading, probe, cone)
    return depth, speed, force / area / 1e3


def fit_bed(readings: Sequence[Reading], probe: FreeFallProbe, *, nuisances: bool = False) -> BedFit:
    """σ, b, c of q = σ + b·z + c·v fitted over every drop's rows in the bed where the whole cone has entered
    (while the tip's area grows, a millimetre's error in the depth of impact is a large share of it) and the
    probe still moves faster than ``MIN_SPEED_M_S``.

    ``nuisances``: the drag and added-mass coefficients are fitted too (the probe's are not taken).  The equation
    is linear in them as well, and the fall through the water, where the bed pushes nothing, is what determines
    them: its rows from ``FLIGHT_SKIP_S`` after the release to the impact join the fit.  They are fitted only
    from drops whose chain reads the acceleration and not the bed's force (where it reads the force, the
    equation of motion is not needed); none such: they are not fitted."""
    cone = Cone(half_angle_rad=probe.half_angle_rad, shaft_radius_m=probe.shaft_radius_m)
    rho, volume = probe.water_density, probe.volume_m3
    section = math.pi * probe.shaft_radius_m ** 2
    nuisances = nuisances and any(r.force_n is None for r in readings)
    rows, targets, in_bed = [], [], []
    for reading in readings:
        inside, depth, speed, force, area = _fitted_rows(reading, probe, cone)
        columns = [1e3 * area, 1e3 * area * depth, 1e3 * area * speed]
        in_bed.append(np.ones(area.size, dtype=bool))
        if not nuisances or reading.force_n is not None:
            rows.append(np.column_stack(columns + [np.zeros(area.size)] * (2 if nuisances else 0)))
            targets.append(force)
            continue
        bed = reading.penetration
        v, a = reading.speed_m_s[bed][inside], reading.accel_m_s2[bed][inside]
        rows.append(np.column_stack(columns + [0.5 * rho * section * v * np.abs(v), rho * volume * a]))
        targets.append(probe.net_weight_n - probe.mass_kg * a - bed_buoyancy_n(depth, probe))
        start = int(np.searchsorted(reading.time_s, reading.time_s[reading.start] + FLIGHT_SKIP_S))
        flight = slice(start, reading.contact)
        v, a = reading.speed_m_s[flight], reading.accel_m_s2[flight]
        zero = np.zeros(v.size)
        rows.append(np.column_stack([zero, zero, zero, 0.5 * rho * section * v * np.abs(v), rho * volume * a]))
        targets.append(probe.net_weight_n - probe.mass_kg * a)
        in_bed.append(np.zeros(v.size, dtype=bool))
    X, y = np.vstack(rows), np.concatenate(targets)
    theta, *_ = np.linalg.lstsq(X, y, rcond=None)
    residual = y - X @ theta
    dof = max(1, y.size - X.shape[1])
    covariance = float(residual @ residual) / dof * np.linalg.inv(X.T @ X)
    bed_rows = np.concatenate(in_bed)
    scale = max(float(np.mean(np.abs(X[bed_rows, :3] @ theta[:3]))), 1e-300)  # the bed's mean force
    return BedFit(*(float(v) for v in theta[:3]), tuple(float(v) for v in np.sqrt(np.diag(covariance))),
                  int(y.size), len(readings), float(np.sqrt(np.mean(residual[bed_rows] ** 2)) / scale),
                  *((float(theta[3]), float(theta[4])) if nuisances else ()))
