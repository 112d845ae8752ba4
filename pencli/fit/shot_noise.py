r"""Micro-mechanical estimates from a constant-rate cone's force signal: the shot-noise model of snow penetration.

Löwe and van Herwijnen (2012, Cold Reg. Sci. Technol. 70,
doi:10.1016/j.coldregions.2011.09.001) read the SnowMicroPen's force as
shot noise: the cone meets rupturing elements at random depths (a Poisson
process of intensity λ per mm of depth), each loaded elastically over a
deflection δ to its rupture force f₀ and then lost, so that

.. math:: F(z) = \sum_i f_0\,\frac{z - z_i}{\delta}\;\mathbb{1}[z_i \le z < z_i + \delta].

Campbell's theorem gives the mean k₁ = λ f₀ δ / 2, the variance
k₂ = λ f₀² δ / 3 and the autocovariance at a lag r = sΔ ≤ δ,
C(r) = λ f₀² δ (1/3 − s/2 + s³/6) with s = r/δ, so that from one window of
samples Δ apart

.. math:: \delta = -\tfrac{3}{2}\,\frac{C(0)}{C(\Delta) - C(0)}\,\Delta,\qquad
          f_0 = \tfrac{3}{2}\,\frac{k_2}{k_1},\qquad
          \lambda = \tfrac{4}{3}\,\frac{k_1^2}{k_2\,\delta},

and the element size L = (A/λ)^{1/3} with A the cone's frontal area.  The
window's force is detrended by a straight line before k₂ and C (Proksch
et al. 2015), so that a layer's gradient is not read as noise.  With
random rupture forces, f₀ is ⟨f²⟩/⟨f⟩ (the estimator's, not the mean).

pen's strength term is the mean force over the frontal area: the
resistance per unit area of a cone pushed slowly, where the paper's
speed terms vanish (Eq. 9 at v → 0; the push is constant, so C and K are
not identifiable from one profile).  Pure functions, no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pencli.fit import SNOW_OVERLAP as OVERLAP
from pencli.fit import SNOW_WINDOW_MM as WINDOW_MM


@dataclass(frozen=True)
class ShotNoise:
    """Per window (arrays of one length): the window's centre depth [mm], mean force k₁ [N] and variance k₂ of
    the detrended force [N²]; the estimates δ [mm], f₀ [N], λ [mm⁻¹], L [mm]; the strength term, the mean force
    over the cone's frontal area [kPa]; and whether a sample of the window reached the sensor's range
    (``clipped``: its estimates are biased low).  Windows where C(Δ) ≥ C(0) (no resolved correlation) have NaN
    estimates of δ, λ and L."""

    depth_mm: np.ndarray
    mean_force_n: np.ndarray
    variance_n2: np.ndarray
    deflection_mm: np.ndarray
    rupture_force_n: np.ndarray
    intensity_per_mm: np.ndarray
    element_size_mm: np.ndarray
    strength_kpa: np.ndarray
    clipped: np.ndarray


def frontal_area_mm2(diameter_mm: float) -> float:
    """A cone's frontal (projected) area, π d²/4. [mm²]"""
    return math.pi * diameter_mm ** 2 / 4.0


def windows(n: int, per_window: int, overlap: float) -> np.ndarray:
    """Start indices of windows of ``per_window`` samples over ``n`` samples, each overlapping the last by
    ``overlap`` of a window (the last window ends at or before the last sample)."""
    hop = max(1, int(round(per_window * (1.0 - overlap))))
    return np.arange(0, max(n - per_window, -1) + 1, hop)


def shot_noise(force_n: np.ndarray, step_mm: float, *, diameter_mm: float, window_mm: float = WINDOW_MM,
               overlap: float = OVERLAP, overload_n: float | None = None, start_mm: float = 0.0) -> ShotNoise:
    """The shot-noise estimates per window of ``force_n`` [N], sampled every ``step_mm`` [mm] from ``start_mm``
    (windows of ``window_mm``, overlapping by ``overlap``; cone of ``diameter_mm``; ``overload_n`` the sensor's
    range, None if unknown)."""
    force = np.asarray(force_n, dtype=float)
    per = int(round(window_mm / step_mm))
    if per < 3:
        raise ValueError(f"a window of {window_mm} mm holds {per} samples {step_mm} mm apart: at least 3 needed")
    starts = windows(force.size, per, overlap)
    if starts.size == 0:
        raise ValueError(f"{force.size} samples ({force.size * step_mm:.1f} mm): shorter than one window "
                         f"({window_mm} mm)")
    frames = force[starts[:, None] + np.arange(per)[None, :]]  # (windows, per)
    k1 = frames.mean(axis=1)
    x = np.arange(per) - (per - 1) / 2.0
    slope = frames @ x / (x @ x)
    rest = frames - k1[:, None] - slope[:, None] * x[None, :]  # detrended (Proksch et al. 2015)
    c0 = (rest * rest).mean(axis=1)
    c1 = (rest[:, 1:] * rest[:, :-1]).mean(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        delta = np.where(c1 < c0, -1.5 * c0 / (c1 - c0) * step_mm, np.nan)
        f0 = 1.5 * c0 / k1
        lam = 4.0 / 3.0 * k1 ** 2 / (c0 * delta)
        size = np.cbrt(frontal_area_mm2(diameter_mm) / lam)
    clipped = (frames >= overload_n).any(axis=1) if overload_n is not None else np.zeros(starts.size, bool)
    return ShotNoise(depth_mm=start_mm + (starts + (per - 1) / 2.0) * step_mm, mean_force_n=k1, variance_n2=c0,
                     deflection_mm=delta, rupture_force_n=f0, intensity_per_mm=lam, element_size_mm=size,
                     strength_kpa=k1 / frontal_area_mm2(diameter_mm) * 1e3, clipped=clipped)


@dataclass(frozen=True)
class LayerSummary:
    """A depth range's windows: (top, bottom) [mm], the windows' count, and the median of each estimate over the
    windows that are not clipped (NaN where none)."""

    top_mm: float
    bottom_mm: float
    windows: int
    strength_kpa: float
    rupture_force_n: float
    deflection_mm: float
    intensity_per_mm: float
    element_size_mm: float


def layer_summary(estimates: ShotNoise, top_mm: float, bottom_mm: float) -> LayerSummary:
    """The medians of ``estimates``' windows whose centres lie in [``top_mm``, ``bottom_mm``)."""
    inside = (estimates.depth_mm >= top_mm) & (estimates.depth_mm < bottom_mm) & ~estimates.clipped

    def median(values: np.ndarray) -> float:
        chosen = values[inside & np.isfinite(values)]
        return float(np.median(chosen)) if chosen.size else math.nan

    return LayerSummary(top_mm, bottom_mm, int(inside.sum()), median(estimates.strength_kpa),
                        median(estimates.rupture_force_n), median(estimates.deflection_mm),
                        median(estimates.intensity_per_mm), median(estimates.element_size_mm))


SURFACE_STEP_MM = 1.0
"""Length of the running means the surface is found on. [mm]"""

AIR_MM = 10.0
"""Length at the profile's start taken as air (the motor starts above the snow). [mm]"""

SURFACE_HOLD_MM = 5.0
"""Length over which every running mean must stay above the air's level for the snow to have started (a knock on
the instrument in air is a spike of a millimetre or two). [mm]"""

SURFACE_RISE_N = 0.05
"""Rise of a running mean over the air's level that marks the snow surface: in the SnowEx 2020 profiles the air's
1-mm means scatter by under 0.005 N and the first millimetre of snow reads 0.3–1 N. [N]"""


def surface_mm(force_n: np.ndarray, step_mm: float, rise_n: float = SURFACE_RISE_N) -> float | None:
    """Depth of the snow surface from the motor's start: the start of the first ``SURFACE_STEP_MM`` mean that
    exceeds the air's median (the first ``AIR_MM``) by ``rise_n`` [N], as do the means of the next
    ``SURFACE_HOLD_MM``.  None if no mean does. [mm]"""
    per = max(1, int(round(SURFACE_STEP_MM / step_mm)))
    blocks = np.asarray(force_n, float)[: force_n.size // per * per].reshape(-1, per).mean(axis=1)
    if blocks.size == 0:
        return None
    air = float(np.median(blocks[: max(1, int(AIR_MM / SURFACE_STEP_MM))]))
    hold = max(1, int(round(SURFACE_HOLD_MM / SURFACE_STEP_MM)))
    above = blocks > air + rise_n
    held = np.lib.stride_tricks.sliding_window_view(above, min(hold, above.size)).all(axis=1)
    first = np.flatnonzero(held)
    return float(first[0] * per * step_mm) if first.size else None
