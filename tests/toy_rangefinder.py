"""A sensor chain added the way a user adds one: this module, and the one registration line in :func:`register`.

A free-fall probe read by a laser rangefinder (its travel from the release, to a hundredth of a millimetre)
and a load cell behind the cone's tip (the bed's force on it).  Its observation equations: r̃ = x, F̃ = R.
So the chain measures the bed's force itself, and needs no equation of motion: the speed is the rangefinder's
travel differentiated; the surface is where the square root of the force, which grows in proportion to the
depth while the cone enters (its frontal area goes with the depth squared), extrapolates to nothing; the stop
where the speed falls below a few centimetres a second.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from pencli.sensors import Reading, register_chain

ONSET_SIGMAS = 6.0
"""Noise levels above the force's level before the drop at which the tip is in the bed."""
STOPPED_M_S = 0.02
"""Speed below which the probe has stopped. [m/s]"""
SMOOTH_ROWS = 5
"""Rows of the moving mean the speed is read through (the rangefinder's noise differentiated). [rows]"""
ENTRY_M = 0.02
"""Travel past the force's onset over which √F is extrapolated to the surface (a cone longer than this). [m]"""


class RangefinderTipCell:
    name = "rangefinder_tip_cell"
    channels = ("range_m", "tip_force_n")

    def read(self, name: str, time_s: np.ndarray | None, channels: Mapping[str, np.ndarray]) -> Reading:
        travel, force = np.asarray(channels["range_m"], float), np.asarray(channels["tip_force_n"], float)
        speed = np.convolve(np.gradient(travel, time_s), np.ones(SMOOTH_ROWS) / SMOOTH_ROWS, mode="same")
        quiet = force[: max(10, force.size // 10)]
        level, noise = float(np.median(quiet)), float(np.std(quiet))
        onset = int(np.argmax(force > level + ONSET_SIGMAS * noise))
        entry = np.flatnonzero((travel >= travel[onset]) & (travel <= travel[onset] + ENTRY_M))
        slope, intercept = np.polyfit(travel[entry], np.sqrt(np.clip(force[entry] - level, 0.0, None)), 1)
        surface = -intercept / slope
        onset = int(np.searchsorted(travel[: entry[-1]], surface))  # travel grows until the stop
        moving = np.flatnonzero(speed[onset:] < STOPPED_M_S)
        stop = onset + int(moving[0]) - 1 if moving.size else travel.size - 1
        return Reading(name, self.name, travel, speed, time_s, force_n=force - level, start=0, contact=onset,
                       stop=stop, surface_m=float(surface))


def register():
    return register_chain(RangefinderTipCell)
