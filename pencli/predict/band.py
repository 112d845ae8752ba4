"""A prediction band: the spread of a predicted run over the fitted coefficients' uncertainty.

The coefficients are drawn from a normal law with the fit's mean and covariance (``coefficient_covariance`` of
a material file from ``pen fit``), each kept at its bound of 0 where a draw falls below it (Eq. 9's
coefficients are ≥ 0), and each draw's run is simulated with the same design and launcher.  Pure: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Mapping

import numpy as np

from pencli.fit.resistance import with_coefficients
from pencli.model.design import Design
from pencli.model.dynamics import simulate
from pencli.model.drive import SPRINGS, Drive
from pencli.model.geometry import BLADE, Geometry

BAND_DRAWS = 100
"""Coefficient draws a band is read from: the 2.5 and 97.5 % points of 100 draws scatter by about a fifth of
the band's half-width. [–]"""
BAND_LEVEL = 0.95
"""The share of the draws a band holds. [–]"""


@dataclass(frozen=True)
class Band:
    """The spread of a predicted run, on the central prediction's time and depth grids."""

    time_s: np.ndarray
    depth_low_m: np.ndarray
    depth_high_m: np.ndarray
    velocity_low_m_s: np.ndarray
    velocity_high_m_s: np.ndarray
    depth_m: np.ndarray
    """The depths of the resistance band (inside the material). [m]"""
    resistance_low_n: np.ndarray
    resistance_high_n: np.ndarray
    figures: Mapping[str, tuple[float, float]]
    """``penetration_time_s``, ``final_depth_mm``, ``residual_ke_j``, ``peak_resistance_n``: (low, high)."""
    draws: int
    level: float = BAND_LEVEL


def coefficient_draws(mean: Mapping[str, float], covariance: Mapping[str, Mapping[str, float]], draws: int,
                      seed: int = 0) -> list[dict[str, float]]:
    """``draws`` coefficient sets (file units): ``mean`` with the coefficients ``covariance`` names drawn from
    the normal law, each kept ≥ 0."""
    names = list(covariance)
    mu = np.array([mean[n] for n in names], dtype=float)
    sigma = np.array([[covariance[a][b] for b in names] for a in names], dtype=float)
    values, vectors = np.linalg.eigh(0.5 * (sigma + sigma.T))  # a covariance a hair from semidefinite still draws
    root = vectors * np.sqrt(np.clip(values, 0.0, None))
    z = np.random.default_rng(seed).standard_normal((draws, len(names)))
    drawn = np.maximum(mu + z @ root.T, 0.0)
    return [{**mean, **dict(zip(names, row))} for row in drawn]


def prediction_band(design: Design, mean: Mapping[str, float], covariance: Mapping[str, Mapping[str, float]],
                    central, *, terms: Iterable[str] | str | None = None, speed_at_contact_m_s: float | None = None,
                    draws: int = BAND_DRAWS, seed: int = 0, level: float = BAND_LEVEL, geometry: Geometry = BLADE,
                    drive: Drive = SPRINGS) -> Band:
    """The band of ``central`` (the prediction's :class:`~pencli.model.dynamics.SimulationResult`) over
    ``draws`` coefficient sets (:func:`coefficient_draws`; ``mean`` in file units by coefficient name), each
    simulated on ``geometry``."""
    t = central.trajectory.time_s
    rate_hz = (t.size - 1) / (t[-1] - t[0]) if t.size > 1 else 50_000.0  # the central's: flight agrees to the bit
    depth_grid = np.linspace(0.0, float(np.max(central.trajectory.depth_m)), 200)
    depth, speed, force, figures = [], [], [], {k: [] for k in ("penetration_time_s", "final_depth_mm",
                                                                "residual_ke_j", "peak_resistance_n")}
    for values in coefficient_draws(mean, covariance, draws, seed):
        run = simulate(with_coefficients(design, values), terms, speed_at_contact_m_s=speed_at_contact_m_s,
                       output_rate_hz=rate_hz, geometry=geometry, drive=drive)
        tr = run.trajectory
        depth.append(np.interp(t, tr.time_s, tr.depth_m))  # past its end a draw holds its last value
        speed.append(np.interp(t, tr.time_s, tr.velocity_m_s))
        penetrating = tr.phase == 1
        reached = np.maximum.accumulate(tr.depth_m[penetrating]) if penetrating.any() else np.zeros(1)
        force.append(np.interp(depth_grid, reached, tr.resistance_n[penetrating] if penetrating.any() else [0.0],
                               right=np.nan))
        for key in figures:
            figures[key].append(float(getattr(run.summary, key)))
    tail = 100.0 * (1.0 - level) / 2.0
    cut = [tail, 100.0 - tail]
    d_lo, d_hi = np.percentile(np.array(depth), cut, axis=0)
    v_lo, v_hi = np.percentile(np.array(speed), cut, axis=0)
    f_lo, f_hi = np.full(depth_grid.size, np.nan), np.full(depth_grid.size, np.nan)
    reached = np.sum(np.isfinite(force), axis=0) >= max(2, int(level * draws))  # depths most draws reach
    if reached.any():
        f_lo[reached], f_hi[reached] = np.nanpercentile(np.array(force)[:, reached], cut, axis=0)
    return Band(t, d_lo, d_hi, v_lo, v_hi, depth_grid, f_lo, f_hi,
                {k: tuple(float(x) for x in np.percentile(v, cut)) for k, v in figures.items()}, draws, level)
