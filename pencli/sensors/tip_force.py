"""The ``tip_force`` chain: a load cell right behind a cone's tip, against the motor's travel (a SnowMicroPen).

It measures the force on the tip alone, F̃ = R_tip, at a fixed step of travel; the snow's surface is found in the
force (:func:`pencli.fit.shot_noise.surface_mm`), so the travel counts from the motor's start.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from pencli.sensors import Reading
from pencli.sensors.cone_tip import push_speed_m_s


class TipForce:
    """A tip's force (``force_n`` [N]) against travel (``depth_mm`` [mm])."""

    name = "tip_force"
    channels = ("depth_mm", "force_n")

    def read(self, name: str, time_s: np.ndarray | None, channels: Mapping[str, np.ndarray]) -> Reading:
        travel = np.asarray(channels["depth_mm"], dtype=float) / 1e3
        return Reading(name, self.name, travel, push_speed_m_s(travel, time_s, None), time_s,
                       force_n=np.asarray(channels["force_n"], dtype=float))
