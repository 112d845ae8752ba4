"""A rate effect across constant-rate soundings: how a unit's resistance changes with the push rate, of either sign.

Soundings of one site pushed at different rates cross the same soil units.
Each unit's mean of a quantity (qt, fs, ...) in each sounding is a sample
(unit, rate, value); the law fitted across them is

    value = q_u · (1 + K · log10(v / v_ref))

with q_u the unit's value at the reference rate v_ref and K the change per
decade of rate, shared by the site's units: K > 0 where faster is stronger
(a clay going undrained at any rate, viscous), K < 0 where drainage goes
from partial to undrained with rate (silty sand).  The residual is taken
relative to the unit's value, p_u·y − (1 + K·L) with p_u = 1/q_u, which
makes the fit linear in (p_u, K) and weighs each unit alike whatever its
strength, as ratios k = value/q_u do.
"""

from __future__ import annotations

import math

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from pencli.errors import FitError

MIN_RATE_SPAN = 0.1
"""The least spread of log10(rate) across the soundings a rate effect is fitted on (a factor 1.26): below it the
law's slope is fitted on the rates' noise. [decades]"""


def warp_depths(depth_m: np.ndarray, pairs_m: Sequence[Sequence[float]]) -> np.ndarray:
    """A sounding's depths at a reference sounding's: ``pairs_m`` are [depth here, depth there]; the shift between
    them is interpolated, and held beyond the first and last pair.  No pairs: the depths unchanged. [m]"""
    d = np.asarray(depth_m, dtype=float)
    if not len(pairs_m):
        return d.copy()
    here = np.array([p[0] for p in pairs_m], dtype=float)
    there = np.array([p[1] for p in pairs_m], dtype=float)
    order = np.argsort(here, kind="stable")
    return d + np.interp(d, here[order], (there - here)[order])


@dataclass(frozen=True)
class UnitMean:
    """One unit's mean of a quantity in one sounding, at the rate it was pushed there."""

    unit: int
    rate_mm_s: float
    value: float
    rows: int


def unit_means(depth_m: np.ndarray, time_s: np.ndarray | None, values: np.ndarray, units_m: Sequence[Sequence[float]],
               warp_m: Sequence[Sequence[float]] = (), drop_m: Sequence[Sequence[float]] = (),
               min_rows: int = 10, logger_rate_mm_s: np.ndarray | None = None) -> list[UnitMean]:
    """Each unit's mean of ``values`` and the push rate over its rows (:func:`pencli.filter.rate.push_rate_mm_s`
    from the clock, or where ``time_s`` is None the median of the logger's own positive rates
    ``logger_rate_mm_s``), the units given as [top, bottom] at the reference's depths (``warp_m`` maps this
    sounding's onto them; rows in a ``drop_m`` range, also at the reference's depths, are left out).  A unit with
    fewer than ``min_rows`` finite rows is left out."""
    from pencli.filter.rate import push_rate_mm_s

    d = np.asarray(depth_m, dtype=float)
    y = np.asarray(values, dtype=float)
    at = warp_depths(d, warp_m)
    keep = np.isfinite(y) & np.isfinite(d)
    for lo, hi in drop_m:
        keep &= ~((at >= lo) & (at <= hi))
    t = None if time_s is None else np.asarray(time_s, dtype=float)
    out = []
    for u, (top, bottom) in enumerate(units_m):
        rows = keep & (at >= top) & (at <= bottom)
        if rows.sum() < min_rows:
            continue
        if t is not None:
            rate = push_rate_mm_s(d[rows], t[rows])
        else:
            logged = np.asarray(logger_rate_mm_s, dtype=float)[rows]
            logged = logged[np.isfinite(logged) & (logged > 0)]
            rate = float(np.median(logged)) if logged.size else math.nan
        if np.isfinite(rate) and rate > 0:
            out.append(UnitMean(u, rate, float(np.mean(y[rows])), int(rows.sum())))
    return out


@dataclass(frozen=True)
class RateEffect:
    """The fitted law value = q_u·(1 + K·log10(v/v_ref)) across soundings."""

    per_decade: float
    """K, the relative change of the value per decade of rate. [1/decade]"""
    per_decade_se: float
    """K's standard error (ordinary least squares on the relative residuals). [1/decade]"""
    reference_rate_mm_s: float
    reference_values: dict[int, float]
    """q_u, each unit's value at the reference rate (the values' unit)."""
    residual_sd: float
    """The relative residuals' standard deviation."""
    samples: int

    @property
    def t(self) -> float:
        """K over its standard error."""
        return self.per_decade / self.per_decade_se if self.per_decade_se > 0 else float("inf")


def solve_rate_law(unit: np.ndarray, value: np.ndarray, log_rate: np.ndarray, units: int
                   ) -> tuple[np.ndarray, float, np.ndarray]:
    """Least squares of p_u·y − K·L = 1 (module docstring) over unit means given as arrays: each one's unit index
    (0…``units``−1), value and L = log10(v/v_ref).  (p per unit, 0 for a unit with no mean; K; the residuals)."""
    present = np.flatnonzero(np.bincount(unit, minlength=units) > 0)
    X = np.zeros((value.size, present.size + 1))
    X[np.arange(value.size), np.searchsorted(present, unit)] = value
    X[:, -1] = -log_rate
    coef = np.linalg.lstsq(X, np.ones(value.size), rcond=None)[0]
    p = np.zeros(units)
    p[present] = coef[:-1]
    return p, float(coef[-1]), X @ coef - 1.0


def fit_rate_effect(samples: Sequence[UnitMean], reference_rate_mm_s: float = 20.0) -> RateEffect:
    """The rate effect shared by a site's units (module docstring), fitted by linear least squares on
    p_u·y − K·L = 1 (:func:`solve_rate_law`); raises :class:`FitError` where the rates do not spread or too few
    samples are left."""
    if not samples:
        raise FitError("no unit means to fit a rate effect to")
    units = sorted({s.unit for s in samples})
    column = {u: j for j, u in enumerate(units)}
    unit = np.array([column[s.unit] for s in samples])
    y = np.array([s.value for s in samples])
    L = np.log10(np.array([s.rate_mm_s for s in samples]) / reference_rate_mm_s)
    n, q = len(samples), len(units) + 1
    if n <= q:
        raise FitError(f"{n} unit means for {q} unknowns (a value per unit and the rate effect); more soundings needed")
    if np.ptp(L) < MIN_RATE_SPAN:
        raise FitError(f"the rates span {np.ptp(L):.2f} decades; a rate effect needs soundings at different rates")
    p, K, residual = solve_rate_law(unit, y, L, len(units))
    if np.any(p <= 0):
        raise FitError("a unit's value at the reference rate comes out non-positive; the values are not a strength")
    sigma2 = float(residual @ residual) / (n - q)
    X = np.zeros((n, q))
    X[np.arange(n), unit] = y
    X[:, -1] = -L
    se = float(np.sqrt(sigma2 * np.linalg.inv(X.T @ X)[-1, -1]))
    return RateEffect(per_decade=K, per_decade_se=se, reference_rate_mm_s=float(reference_rate_mm_s),
                      reference_values={u: float(1.0 / p[column[u]]) for u in units},
                      residual_sd=float(np.sqrt(sigma2)), samples=n)
