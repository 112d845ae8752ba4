"""The ``cone_tip`` chain: a cone penetrometer's tip, sleeve and pore-pressure channels against depth.

The tip's load cell reads the cone resistance qc, which the pore pressure behind the cone u₂ lowers on the part of
the tip's area the load cell does not see: qc = qt − (1 − a)·u₂ with a the net area ratio, so the resistance the
soil puts on the cone is qt = qc + (1 − a)·u₂.  The sleeve reads fs.  The speed comes from the logger's rate
where it wrote one, else from depth and the clock.
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from pencli.sensors import Reading


def qt_kpa(qc_mpa: np.ndarray, u2_kpa: np.ndarray, net_area_ratio: float) -> np.ndarray:
    """Cone resistance corrected for the pore pressure on the cone's shoulder: qt = qc + (1 − a)·u₂. [kPa]"""
    return 1e3 * np.asarray(qc_mpa, dtype=float) + (1.0 - net_area_ratio) * np.asarray(u2_kpa, dtype=float)


class ConeTip:
    """A cone's tip (qc [MPa]), with its sleeve (fs [kPa]) and shoulder pore pressure (u₂ [kPa]) where the record
    has them; ``net_area_ratio`` a (0 < a ≤ 1; None: unknown, and qt is not read)."""

    name = "cone_tip"
    channels = ("depth_m", "qc_mpa")

    def __init__(self, net_area_ratio: float | None = None) -> None:
        if net_area_ratio is not None and not 0.0 < net_area_ratio <= 1.0:
            raise ValueError(f"net area ratio {net_area_ratio!r}: expected 0 < a ≤ 1")
        self.net_area_ratio = net_area_ratio

    def read(self, name: str, time_s: np.ndarray | None, channels: Mapping[str, np.ndarray]) -> Reading:
        depth = np.asarray(channels["depth_m"], dtype=float)
        pressures = {"qc": 1e3 * np.asarray(channels["qc_mpa"], dtype=float)}
        if "fs_kpa" in channels:
            pressures["fs"] = np.asarray(channels["fs_kpa"], dtype=float)
        if "u2_kpa" in channels:
            pressures["u2"] = np.asarray(channels["u2_kpa"], dtype=float)
            if self.net_area_ratio is not None:
                pressures["qt"] = qt_kpa(channels["qc_mpa"], channels["u2_kpa"], self.net_area_ratio)
        return Reading(name, self.name, depth, push_speed_m_s(depth, time_s, channels.get("rate_mm_s")), time_s,
                       pressures_kpa=pressures)


def push_speed_m_s(depth_m: np.ndarray, time_s: np.ndarray | None, rate_mm_s: np.ndarray | None) -> np.ndarray:
    """A push's speed: the logger's rate where it wrote one, else depth over the clock, else NaN. [m/s]"""
    if rate_mm_s is not None:
        return np.asarray(rate_mm_s, dtype=float) / 1e3
    if time_s is not None and depth_m.size > 1:
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.gradient(depth_m, time_s)
    return np.full(depth_m.shape, math.nan)
