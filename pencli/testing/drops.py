"""Simulated free-fall drops for tests and benches: the simulated BlueDrop (:mod:`pencli.acquire.freefall`)
dropped from several heights, each record written in the BlueDrop format, read back and integrated, so that what
is checked starts from the instrument's bytes."""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Sequence

import numpy as np


def drops_into(probe, bed, heights_m: Sequence[float], rng: np.random.Generator, seed: int,
               bias_g: float = 0.03, drift_g_per_s: float = 0.0, impact_shift_g: tuple[float, float] | None = None,
               rest_tilt_deg: float = 0.0) -> list[tuple]:
    """(truth, record, reading) of a drop of ``probe`` into ``bed`` from each height, each accelerometer with a bias
    drawn from ``rng`` within ±``bias_g``, a drift in time within ±``drift_g_per_s``, a shift at the impact whose
    size is drawn within ``impact_shift_g`` (low, high) with either sign (none by default), the probe leaning once
    stopped by an angle drawn within ``rest_tilt_deg`` towards a random side, and the sensors' noise seeded by
    ``seed``; the record read as ``pen drops`` reads it (its sensor chain's :class:`pencli.sensors.Reading`, the tilt
    channels with the accelerometers)."""
    from pencli.acquire.freefall import Sensors, simulate_drop
    from pencli.api import drop_reading
    from pencli.io.bluedrop import ACCELEROMETER_RANGES_G, bluedrop_bytes, read_bluedrop

    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for k, height in enumerate(heights_m):
            names = list(ACCELEROMETER_RANGES_G)
            shift = ({} if impact_shift_g is None else
                     {n: float(rng.choice([-1.0, 1.0]) * rng.uniform(*impact_shift_g)) for n in names})
            sensors = Sensors(bias_g={n: float(rng.uniform(-bias_g, bias_g)) for n in names},
                              drift_g_per_s=({n: float(rng.uniform(-drift_g_per_s, drift_g_per_s)) for n in names}
                                             if drift_g_per_s else {}),
                              impact_shift_g=shift)
            lean = ({"rest_tilt_deg": float(rng.uniform(0.0, rest_tilt_deg)),
                     "tilt_azimuth_deg": float(rng.uniform(0.0, 360.0))} if rest_tilt_deg else {})
            truth = simulate_drop(probe, bed, height, sensors=sensors, seed=seed * 10 + k, **lean)
            path = Path(tmp) / f"drop-{k}.bin"
            path.write_bytes(bluedrop_bytes(truth.raw))
            record = read_bluedrop(path, sensors.calibration)
            out.append((truth, record, drop_reading(record)))
    return out


__all__ = ["drops_into"]
