"""The ``rod_force`` chain: the force pushing a total sounding's rods against depth.

It measures the force the ground puts on the bit and the rods together (the rods' friction is not told apart).
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from pencli.sensors import Reading
from pencli.sensors.cone_tip import push_speed_m_s


class RodForce:
    """A push force on the rods (``push_force_kn`` [kN]) against depth."""

    name = "rod_force"
    channels = ("depth_m", "push_force_kn")

    def read(self, name: str, time_s: np.ndarray | None, channels: Mapping[str, np.ndarray]) -> Reading:
        depth = np.asarray(channels["depth_m"], dtype=float)
        return Reading(name, self.name, depth, push_speed_m_s(depth, time_s, channels.get("rate_mm_s")), time_s,
                       force_n=1e3 * np.asarray(channels["push_force_kn"], dtype=float))
