"""The bed's resistance fitted across free-fall drops: q = σ + b·z + c·v on the cone's frontal area.

In the bed, the probe's equation of motion (x and a positive down) is

    (m + C_a·ρ_w·V)·a = (m − ρ_w·V)·g − ½·ρ_w·C_D·A·v|v| − A_f(z)·q(z, v),

so each sample from impact to stop gives the bed's force from the measured
acceleration, speed and depth (:class:`pencli.filter.freefall.DropMotion`)
and the probe's known mass, volume, drag and added mass; q is linear in
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

from pencli.filter.freefall import G, DropMotion
from pencli.model.geometry import Cone


MIN_SPEED_M_S = 0.05
"""Slowest sample fitted: where the probe stops, the bed holds it with whatever force its weight needs, not q's
(and the stop falls between two samples). [m/s]"""


@dataclass(frozen=True)
class FreeFallProbe:
    """What the fit must know of the probe: mass [kg], volume [m³], its cone (half-angle [rad], shaft radius [m]),
    drag and added-mass coefficients [–], and the water's density [kg/m³]."""

    mass_kg: float
    volume_m3: float
    half_angle_rad: float
    shaft_radius_m: float
    drag_coefficient: float
    added_mass_coefficient: float
    water_density: float = 1025.0


@dataclass(frozen=True)
class BedFit:
    """σ [kPa], b [kPa/m], c [kPa·s/m], their standard errors, the samples and drops fitted, and the residual's
    RMS over the bed's mean force [–]."""

    strength_kpa: float
    gradient_kpa_m: float
    damping_kpa_s_m: float
    standard_errors: tuple[float, float, float]
    samples: int
    drops: int
    relative_rms: float


def bed_force_n(motion: DropMotion, probe: FreeFallProbe) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(depth in the bed [m], speed [m/s], the bed's force [N]) at every row from impact to stop."""
    rows = slice(motion.impact, motion.stop + 1)
    depth = motion.travel_m[rows] - float(np.interp(motion.impact_s, motion.time_s, motion.travel_m))
    speed, accel = motion.speed_m_s[rows], motion.accel_m_s2[rows]
    rho = probe.water_density
    m_eff = probe.mass_kg + probe.added_mass_coefficient * rho * probe.volume_m3
    section = math.pi * probe.shaft_radius_m ** 2
    force = ((probe.mass_kg - rho * probe.volume_m3) * G - 0.5 * rho * probe.drag_coefficient * section * speed
             * np.abs(speed) - m_eff * accel)
    return depth, speed, force


def fit_bed(motions: Sequence[DropMotion], probe: FreeFallProbe) -> BedFit:
    """σ, b, c of q = σ + b·z + c·v fitted over every drop's rows in the bed where the whole cone has entered
    (while the tip's area grows, a millimetre's error in the depth of impact is a large share of it) and the
    probe still moves faster than ``MIN_SPEED_M_S``."""
    cone = Cone(half_angle_rad=probe.half_angle_rad, shaft_radius_m=probe.shaft_radius_m)
    rows, targets = [], []
    for motion in motions:
        depth, speed, force = bed_force_n(motion, probe)
        inside = (depth > cone.cone_length_m) & (speed > MIN_SPEED_M_S)
        area = np.array([cone.areas(z, 0.0)[0] for z in depth[inside]])
        rows.append(1e3 * area[:, None] * np.column_stack([np.ones(area.size), depth[inside], speed[inside]]))
        targets.append(force[inside])
    X, y = np.vstack(rows), np.concatenate(targets)
    theta, *_ = np.linalg.lstsq(X, y, rcond=None)
    residual = y - X @ theta
    dof = max(1, y.size - X.shape[1])
    covariance = float(residual @ residual) / dof * np.linalg.inv(X.T @ X)
    return BedFit(*(float(v) for v in theta), tuple(float(v) for v in np.sqrt(np.diag(covariance))), int(y.size),
                  len(motions), float(np.sqrt(np.mean(residual ** 2)) / max(float(np.mean(np.abs(y))), 1e-300)))
