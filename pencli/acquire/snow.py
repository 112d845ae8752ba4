"""A simulated SnowMicroPen: shot noise of known elements, measured by a quantised force sensor and written as ``.pnt``.

The true snow is a stack of layers, each with its own rupture intensity λ
[mm⁻¹], rupture force f₀ [N] and deflection at rupture δ [mm]
(:class:`SnowLayer`).  Elements start at the points of a Poisson process
of intensity λ (the layer's where the element starts); an element loads
the cone linearly from 0 to f₀ over δ of travel and then breaks (the
Löwe–van Herwijnen picture).  The force of every element alive at a sample
is summed exactly on the sample grid (no time steps), then the sensor adds
white noise, rounds to its counts and clips at its range.  Above the
surface the cone is in air: the sensor's noise alone.

This is the truth the shot-noise estimator (:mod:`pencli.fit.shot_noise`)
is checked against; it shares no code with it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

STEP_MM = 0.00413223123177886
"""The SnowMicroPen's distance between samples (the motor's step). [mm]"""

COUNT_N = 0.0012716046767309308
"""Force of one count of the simulated sensor (a SnowEx 2020 instrument's). [N]"""

OVERLOAD_N = 40.0
"""The simulated sensor's range: counts beyond it are clipped. [N]"""


@dataclass(frozen=True)
class SnowLayer:
    """A layer of the true snow: thickness [mm], rupture intensity λ [mm⁻¹], rupture force f₀ [N], deflection at
    rupture δ [mm]."""

    thickness_mm: float
    intensity_per_mm: float
    rupture_force_n: float
    deflection_mm: float

    @property
    def mean_force_n(self) -> float:
        """The layer's mean force, λ f₀ δ / 2 (Campbell's theorem). [N]"""
        return 0.5 * self.intensity_per_mm * self.rupture_force_n * self.deflection_mm


def true_force(layers: list[SnowLayer], surface_mm: float, length_mm: float, rng: np.random.Generator,
               step_mm: float = STEP_MM) -> tuple[np.ndarray, np.ndarray]:
    """(depth [mm] from the motor's start, true force [N]) at every sample of a profile ``length_mm`` long whose
    snow starts at ``surface_mm``."""
    n = int(length_mm / step_mm)
    depth = np.arange(n) * step_mm
    slope_steps = np.zeros(n + 1)  # Σ f₀/δ of the elements alive, as differences at their first and past-last sample
    offset_steps = np.zeros(n + 1)  # Σ f₀/δ · z_i of the same
    top = surface_mm
    for layer in layers:
        count = rng.poisson(layer.intensity_per_mm * layer.thickness_mm)
        starts = np.sort(top + rng.uniform(0.0, layer.thickness_mm, count))
        first = np.minimum(np.ceil(starts / step_mm).astype(np.int64), n)
        past = np.minimum(np.ceil((starts + layer.deflection_mm) / step_mm).astype(np.int64), n)
        rate = layer.rupture_force_n / layer.deflection_mm
        np.add.at(slope_steps, first, rate)
        np.add.at(slope_steps, past, -rate)
        np.add.at(offset_steps, first, rate * starts)
        np.add.at(offset_steps, past, -rate * starts)
        top += layer.thickness_mm
    return depth, np.cumsum(slope_steps)[:n] * depth - np.cumsum(offset_steps)[:n]


def measured_force(force_n: np.ndarray, rng: np.random.Generator, noise_n: float = 0.005, count_n: float = COUNT_N,
                   overload_n: float = OVERLOAD_N) -> np.ndarray:
    """The sensor's reading of ``force_n``: white noise of ``noise_n`` [N], rounded to counts of ``count_n`` [N],
    clipped at ``overload_n`` [N]."""
    reading = force_n + rng.normal(0.0, noise_n, force_n.size)
    return np.minimum(np.rint(reading / count_n) * count_n, overload_n)


def header(name: str, length_mm: float) -> dict[str, object]:
    """The ``.pnt`` header fields of a simulated profile (:data:`pencli.io.pnt.HEADER` names)."""
    return {"firmware": 0, "step_mm": STEP_MM, "force_per_count_n": COUNT_N, "speed_mm_s": 20.0,
            "tip_diameter_um": 5000, "overload_n": int(OVERLOAD_N), "smp_length_mm": int(length_mm),
            "file_name": name[:8], "comment": "simulated by pen"}
