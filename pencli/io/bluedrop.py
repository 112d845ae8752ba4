"""Reader and writer of BlueDrop free-fall penetrometer records (``.bin``) and their calibration.

A record is headerless binary: rows of ten signed 24-bit big-endian
integers at 2 kHz, in the order of :data:`CHANNELS` (a sample count, an
unused channel, accelerometers of 2, 18, 50 g, the pore pressure, a 200 g
accelerometer, two 55 g tilt channels, a 250 g accelerometer).  The
engineering value of a channel is (raw + offset) / scale, the offset and
scale of the instrument's calibration sheet; pen reads them from a small
CSV (:func:`read_calibration`: ``channel,offset,scale,unit``).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pencli.errors import DataError

CHANNELS: tuple[str, ...] = ("count", "unused", "accel_2g", "accel_18g", "accel_50g", "pore_pressure",
                             "accel_200g", "tilt_x", "tilt_y", "accel_250g")
"""The ten channels of a row, in the file's order."""

ACCELEROMETER_RANGES_G: dict[str, float] = {"accel_2g": 1.7, "accel_18g": 18.0, "accel_50g": 50.0,
                                             "accel_200g": 200.0, "accel_250g": 250.0}
"""The axial accelerometers and the largest reading each can give (the 2 g sensor saturates at 1.7 g). [g]"""

ROW_BYTES = 3 * len(CHANNELS)
"""Bytes per row: ten 24-bit integers."""

RATE_HZ = 2000.0
"""BlueDrop's sampling rate. [Hz]"""

CALIBRATED = tuple(c for c in CHANNELS if c not in ("count", "unused"))
"""The channels a calibration must give."""


@dataclass(frozen=True)
class ChannelCalibration:
    """One channel's engineering value = (raw + offset) / scale, in ``unit``."""

    offset: float
    scale: float
    unit: str


@dataclass(frozen=True)
class DropRecord:
    """A BlueDrop record: time from the first row [s], each calibrated channel in its unit, the raw counts
    (rows, 10), and where it came from."""

    time_s: np.ndarray
    channels: dict[str, np.ndarray]
    units: dict[str, str]
    raw: np.ndarray
    source: str = ""

    @property
    def instrument(self):
        """A free-fall cone read by its accelerometers (:data:`pencli.io.field.KINDS`)."""
        from pencli.io.field import instrument_of

        return instrument_of("free_fall")


def read_calibration(path: str | Path) -> dict[str, ChannelCalibration]:
    """A calibration CSV (``channel,offset,scale,unit``, one row per channel of :data:`CALIBRATED`).  Raises
    :class:`DataError` naming the file, row and what is wrong."""
    path = Path(path)
    try:
        with path.open(newline="", encoding="utf-8") as handle:
            rows = list(csv.DictReader(handle))
    except (OSError, UnicodeDecodeError) as error:
        raise DataError(f"{path}: cannot read the calibration ({error})") from None
    out: dict[str, ChannelCalibration] = {}
    for number, row in enumerate(rows, start=2):
        missing = [k for k in ("channel", "offset", "scale", "unit") if row.get(k) is None]
        if missing:
            raise DataError(f"{path}: row {number}: no {', '.join(missing)} column; expected channel,offset,scale,unit")
        try:
            offset, scale = float(row["offset"]), float(row["scale"])
        except ValueError:
            raise DataError(f"{path}: row {number}: offset {row['offset']!r} or scale {row['scale']!r} is not a "
                            "number") from None
        if not np.isfinite(offset) or not np.isfinite(scale) or scale == 0.0:
            raise DataError(f"{path}: row {number}: scale {scale:g}: expected a finite, non-zero number")
        if row["channel"] not in CALIBRATED:
            raise DataError(f"{path}: row {number}: channel {row['channel']!r}: expected one of "
                            f"{', '.join(CALIBRATED)}")
        out[row["channel"]] = ChannelCalibration(offset, scale, row["unit"].strip())
    absent = [c for c in CALIBRATED if c not in out]
    if absent:
        raise DataError(f"{path}: no calibration for {', '.join(absent)}")
    return out


def read_bluedrop(path: str | Path, calibration: dict[str, ChannelCalibration],
                  rate_hz: float = RATE_HZ) -> DropRecord:
    """The record of a BlueDrop ``.bin`` file, calibrated.  Raises :class:`DataError` naming the file when it is
    empty or not whole rows."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as error:
        raise DataError(f"{path}: cannot read it ({error})") from None
    if not data or len(data) % ROW_BYTES:
        raise DataError(f"{path}: {len(data)} bytes: expected whole rows of {ROW_BYTES} bytes (ten 24-bit "
                        "integers)")
    bytes_ = np.frombuffer(data, dtype=np.uint8).reshape(-1, len(CHANNELS), 3).astype(np.int32)
    raw = (bytes_[..., 0] << 16) | (bytes_[..., 1] << 8) | bytes_[..., 2]
    raw = np.where(raw >= 1 << 23, raw - (1 << 24), raw)  # two's complement, 24 bits
    channels = {name: (raw[:, CHANNELS.index(name)] + cal.offset) / cal.scale for name, cal in calibration.items()}
    return DropRecord(time_s=np.arange(raw.shape[0]) / rate_hz, channels=channels,
                      units={name: cal.unit for name, cal in calibration.items()}, raw=raw, source=str(path))


def bluedrop_bytes(raw: np.ndarray) -> bytes:
    """Rows of ten integers (clipped to 24 bits) as a BlueDrop record's bytes."""
    values = np.clip(np.asarray(raw, dtype=np.int64), -(1 << 23), (1 << 23) - 1) % (1 << 24)
    packed = np.stack([(values >> 16) & 0xFF, (values >> 8) & 0xFF, values & 0xFF], axis=-1).astype(np.uint8)
    return packed.tobytes()
