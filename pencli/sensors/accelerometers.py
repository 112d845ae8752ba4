"""The ``accelerometers`` chain: axial accelerometers of several ranges, stitched, on a free-falling probe.

Each sensor reads the specific force fᵢ = (g − a)/g + biasᵢ(t) in g while within its range; the chain takes each
one's bias out where the probe rests, stitches them (the finest in range, row by row) and integrates a = g·(1 − f)
from the release (:func:`pencli.filter.freefall.drop_motion`).  It measures the motion and the acceleration, not
the bed's force: the drive's equation of motion gives that (:func:`pencli.fit.freefall.bed_force_n`).
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from pencli.filter.freefall import BIAS_MODELS, DropMotion, drop_motion
from pencli.sensors import Reading

TILT_CHANNELS = ("tilt_x", "tilt_y")
"""The lateral channels a lean at rest is read through where a record has both. [g]"""


class StitchedAccelerometers:
    """Axial accelerometers with ``ranges_g`` (channel → range [g]); ``bias_at``: how each one's bias goes from
    the rest before the release to the rest after the stop (:data:`pencli.filter.freefall.BIAS_MODELS`)."""

    name = "accelerometers"

    def __init__(self, ranges_g: Mapping[str, float], bias_at: str = "ramp") -> None:
        if bias_at not in BIAS_MODELS:
            raise ValueError(f"bias model {bias_at!r}: expected one of {', '.join(BIAS_MODELS)}")
        self.ranges_g = dict(ranges_g)
        self.bias_at = bias_at
        self.channels = tuple(self.ranges_g)

    def read(self, name: str, time_s: np.ndarray | None, channels: Mapping[str, np.ndarray]) -> Reading:
        if time_s is None:
            raise ValueError("no clock: accelerometers are integrated over time")
        tilt = tuple(channels[c] for c in TILT_CHANNELS) if all(c in channels for c in TILT_CHANNELS) else None
        motion = drop_motion(time_s, {c: channels[c] for c in self.channels}, self.ranges_g, bias_at=self.bias_at,
                             tilt=tilt)
        return reading_of(name, motion)


def reading_of(name: str, motion: DropMotion) -> Reading:
    """A drop's motion as a :class:`~pencli.sensors.Reading` (the motion itself kept as its account)."""
    return Reading(name, StitchedAccelerometers.name, motion.travel_m, motion.speed_m_s, motion.time_s,
                   motion.accel_m_s2, start=motion.release, contact=motion.impact, stop=motion.stop,
                   surface_m=float(np.interp(motion.impact_s, motion.time_s, motion.travel_m)), account=motion)
