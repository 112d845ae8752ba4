"""A simulated constant-rate cone sounding (CPTu) through layered ground, written as SGF.

The true ground is a stack of layers (:class:`SoilLayer`), each with a cone resistance at its top and a gradient
with depth, a friction ratio and a pore-pressure ratio.  The cone senses a layer before it reaches it and
after it has left it: the resistance it reads is the true profile averaged in log over a zone a few cone
diameters wide (a Gaussian of standard deviation ``influence`` cone diameters), so a thin layer reads less
than it is and a boundary is a ramp, not a step.  A rate effect multiplies the resistance by
1 + K·log10(v / 20 mm/s), of either sign.  The sensors add multiplicative noise per row and round to the
logger's digits; the clock follows the push rate, with the pauses where a rod is added.

This is the truth the layer detection (:mod:`pencli.fit.layers`) is checked against; it shares no code with it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

REFERENCE_RATE_MM_S = 20.0
"""The standard push rate, at which a layer's resistance is its own (ISO 22476-1). [mm/s]"""

ROD_M = 1.0
"""Rod length: the push pauses every metre to add one. [m]"""

ROD_PAUSE_S = 30.0
"""How long the push stops to add a rod. [s]"""

WATER_KPA_M = 9.81
"""Hydrostatic pore pressure per metre below the water table. [kPa/m]"""


@dataclass(frozen=True)
class SoilLayer:
    """A layer of the true ground from ``top_m`` down to the next layer's top: cone resistance ``qt_mpa`` at its
    top growing by ``gradient_mpa_m`` per metre, sleeve friction a ``friction_ratio`` of it, and the pore pressure
    behind the cone hydrostatic plus ``pore_ratio`` × (qt − hydrostatic) (negative in dilating sand)."""

    top_m: float
    qt_mpa: float
    gradient_mpa_m: float = 0.0
    friction_ratio: float = 0.02
    pore_ratio: float = 0.0


@dataclass(frozen=True)
class SimulatedSounding:
    """A simulated sounding's rows and the truth it was made from."""

    columns: dict[str, np.ndarray]
    """``depth_m``, ``qc_mpa``, ``fs_kpa``, ``u2_kpa``, ``clock_ms`` per row (units in the names)."""
    layers: tuple[SoilLayer, ...]
    rate_mm_s: float
    area_ratio: float


def true_profile(layers: tuple[SoilLayer, ...] | list[SoilLayer], depth_m: np.ndarray) -> dict[str, np.ndarray]:
    """The true ground at ``depth_m`` (no cone): ``qt_mpa``, ``fs_kpa`` and the pore ratio at each depth."""
    tops = np.array([layer.top_m for layer in layers])
    k = np.clip(np.searchsorted(tops, depth_m, side="right") - 1, 0, len(layers) - 1)
    qt = np.array([layers[i].qt_mpa + layers[i].gradient_mpa_m * (z - layers[i].top_m) for i, z in zip(k, depth_m)])
    ratio = np.array([layers[i].friction_ratio for i in k])
    pore = np.array([layers[i].pore_ratio for i in k])
    return {"qt_mpa": qt, "fs_kpa": qt * ratio * 1e3, "pore_ratio": pore}


def sensed(values: np.ndarray, depth_m: np.ndarray, width_m: float) -> np.ndarray:
    """``values`` averaged in log over a Gaussian of standard deviation ``width_m`` in depth (what a cone of that
    zone of influence reads); the rows are evenly spaced."""
    step = float(depth_m[1] - depth_m[0])
    half = int(math.ceil(4.0 * width_m / step))
    offsets = np.arange(-half, half + 1) * step
    kernel = np.exp(-0.5 * (offsets / width_m) ** 2)
    padded = np.pad(np.log(values), half, mode="edge")
    return np.exp(np.convolve(padded, kernel / kernel.sum(), mode="valid"))


def simulate_sounding(layers: list[SoilLayer], bottom_m: float, rng: np.random.Generator, *, top_m: float = 1.0,
                      step_m: float = 0.02, rate_mm_s: float = REFERENCE_RATE_MM_S, rate_effect: float = 0.0,
                      noise: float = 0.03, cone_diameter_m: float = 0.0357, influence: float = 2.0,
                      area_ratio: float = 0.8, water_table_m: float = 1.0) -> SimulatedSounding:
    """A sounding from ``top_m`` to ``bottom_m`` every ``step_m``, pushed at ``rate_mm_s``; ``rate_effect`` K per
    decade of rate; ``noise`` the sensors' multiplicative scatter per row (standard deviation of its log)."""
    depth = np.round(np.arange(top_m, bottom_m + 1e-9, step_m), 6)
    truth = true_profile(layers, depth)
    factor = 1.0 + rate_effect * math.log10(rate_mm_s / REFERENCE_RATE_MM_S)
    width = influence * cone_diameter_m
    qt = sensed(truth["qt_mpa"], depth, width) * factor
    fs = sensed(truth["fs_kpa"], depth, width) * factor
    hydrostatic = WATER_KPA_M * np.maximum(depth - water_table_m, 0.0)
    u2 = hydrostatic + truth["pore_ratio"] * (qt * 1e3 - hydrostatic)
    qt = qt * np.exp(rng.normal(0.0, noise, depth.size))
    fs = fs * np.exp(rng.normal(0.0, noise, depth.size))
    u2 = u2 + rng.normal(0.0, 2.0, depth.size)  # the pore-pressure sensor's own scatter [kPa]
    qc = qt - (1.0 - area_ratio) * u2 / 1e3
    travel = (depth - depth[0]) / (rate_mm_s / 1e3)
    clock = 1e3 * (travel + ROD_PAUSE_S * np.floor((depth - depth[0]) / ROD_M))
    columns = {"depth_m": depth, "qc_mpa": np.round(qc, 4), "fs_kpa": np.round(fs, 1), "u2_kpa": np.round(u2, 1),
               "clock_ms": np.round(clock)}
    return SimulatedSounding(columns, tuple(layers), float(rate_mm_s), float(area_ratio))


def sgf_text(name: str, sounding: SimulatedSounding) -> str:
    """The sounding as an SGF file's text (a piezocone, method 07), the clock in milliseconds."""
    c = sounding.columns
    lines = ["$", f"HK={name},HM=07,MA={sounding.area_ratio:g}", "#"]
    for d, qc, fs, u2, clock in zip(c["depth_m"], c["qc_mpa"], c["fs_kpa"], c["u2_kpa"], c["clock_ms"]):
        lines.append(f"D={d:.3f},QC={qc:.4f},FS={fs:.1f},U={u2:.1f},B={sounding.rate_mm_s:.0f},%{int(clock)}")
    return "\n".join(lines) + "\n"


def random_layers(rng: np.random.Generator, top_m: float, bottom_m: float, *, min_thickness_m: float = 0.8,
                  min_contrast: float = 1.5) -> list[SoilLayer]:
    """A random stack from ``top_m`` to ``bottom_m``: 1 to 6 layers at least ``min_thickness_m`` thick, each
    boundary a change of resistance by a factor of at least ``min_contrast`` (up or down), clay-like layers
    (soft, a gradient, pore pressure) and sand-like ones (stiff, dilating)."""
    count = int(rng.integers(1, 7))
    span = bottom_m - top_m
    while True:
        tops = np.sort(rng.uniform(top_m + min_thickness_m, bottom_m - min_thickness_m, count - 1))
        edges = np.concatenate([[top_m], tops, [bottom_m]])
        if np.all(np.diff(edges) >= min_thickness_m) or count == 1 or span < count * min_thickness_m:
            break
    layers = []
    qt = float(np.exp(rng.uniform(np.log(0.5), np.log(15.0))))
    for top in edges[:-1]:
        if layers:
            ratio = float(np.exp(rng.uniform(np.log(min_contrast), np.log(6.0))))
            qt = float(np.clip(qt * ratio if rng.random() < 0.5 else qt / ratio, 0.2, 60.0))
        sandy = qt > 4.0
        layers.append(SoilLayer(float(top), qt, float(rng.uniform(0.0, 0.15) * qt),
                                float(rng.uniform(0.005, 0.015) if sandy else rng.uniform(0.02, 0.06)),
                                float(rng.uniform(-0.02, 0.0) if sandy else rng.uniform(0.2, 0.6))))
    return layers


__all__ = ["REFERENCE_RATE_MM_S", "SimulatedSounding", "SoilLayer", "random_layers", "sensed", "sgf_text",
           "simulate_sounding", "true_profile"]
