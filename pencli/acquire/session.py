"""One shot of the rig: arm, tare, confirm, fire, stream, disarm; then calibrate and trim.

Driver-independent: the same path serves the simulated and the real rig.
Kept: ``pre_trigger_s`` before the release and ``post_motion_s`` after the
motion stops (paper §4: 0.2 s each).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from pencli.acquire.calibration import ForceCalibration, PositionCalibration
from pencli.acquire.drivers import RigDriver, ShotSetup
from pencli.errors import RigError
from pencli.filter.tare import moving_span
from pencli.run import RAW_COLUMNS

TARE_S = 0.1


@dataclass(frozen=True)
class Shot:
    """A calibrated, trimmed recording (contract units, untared)."""

    columns: dict[str, np.ndarray]
    tare: dict[str, float]
    """Mean of each channel over the pre-fire tare, in N and N·m."""
    motion_start_s: float
    motion_stop_s: float
    warnings: tuple[str, ...] = field(default_factory=tuple)


def run_shot(driver: RigDriver, setup: ShotSetup, position_cal: PositionCalibration, force_cal: ForceCalibration,
             *, confirm: Callable[[], bool], post_motion_s: float = 0.2,
             progress: Callable[[str, int, int], None] | None = None) -> Shot:
    """Fire one shot and return the recording, trimmed."""
    tick = progress or (lambda stage, done, total: None)
    driver.arm(setup)
    try:
        tick("arming", 1, 1)
        idle = driver.read_idle(int(TARE_S * setup.sampling_rate_hz))
        tare_values = force_cal.apply(idle.volts).mean(axis=0)
        tick("tared", 1, 1)
        if not confirm():
            raise RigError("not fired: the operator declined; nothing was recorded")
        driver.fire()
        counts_parts, volts_parts = [], []
        done = 0
        for block in driver.stream():
            counts_parts.append(block.counts)
            volts_parts.append(block.volts)
            done += max(len(block), block.volts.shape[0])
            tick("streaming", min(done, setup.total_samples), setup.total_samples)
    finally:
        driver.disarm()
    counts = np.concatenate(counts_parts)
    volts = np.concatenate(volts_parts, axis=0)
    if counts.size != volts.shape[0] or counts.size == 0:
        raise RigError(f"the driver returned {counts.size} encoder and {volts.shape[0]} force samples")
    rate = setup.sampling_rate_hz
    n_pre = setup.pre_trigger_samples
    position = position_cal.to_mm(counts)
    channels = force_cal.apply(volts)
    changes = np.flatnonzero(np.diff(counts)) + 1  # samples where the encoder count changed
    warnings: list[str] = []
    if changes.size == 0:
        raise RigError("the encoder never moved: the blade did not launch (check the latch and the encoder)")
    start, stop = moving_span(counts.astype(float), np.arange(counts.size) < n_pre, 1.0)  # flicker at rest is not motion
    if start < 0:
        start, stop = int(changes[0]), int(changes[-1])
    end = stop + int(round(post_motion_s * rate)) + 1
    if end > counts.size:
        warnings.append(f"the motion had not stopped {post_motion_s:g} s before the recording ended; "
                        f"raise --duration")
        end = counts.size
    keep = slice(0, end)
    time = (np.arange(counts.size) - n_pre) / rate
    columns = {"time_s": time[keep], "position_mm": position[keep]}
    for i, name in enumerate(RAW_COLUMNS[2:]):
        columns[name] = channels[keep, i]
    tare = {name: float(tare_values[i]) for i, name in enumerate(RAW_COLUMNS[2:])}
    return Shot(columns, tare, float(time[start]), float(time[stop]), tuple(warnings))
