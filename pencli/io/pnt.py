"""Reader and writer of SnowMicroPen ``.pnt`` files, field records of a cone pushed at constant rate into snow.

A ``.pnt`` file is a 512-byte big-endian header followed by the force
samples as big-endian signed 16-bit integers, one per step of the motor
(the header's spatial resolution, about 4 µm), from the moment the motor
starts.  Force [N] = raw × the header's force conversion factor; depth of
sample i [mm] = i × the resolution.  The header fields pen reads are in
:data:`HEADER` (offset, struct format, pen's name, unit); the reserved
bytes between them are kept as written in :attr:`SmpProfile.raw_header`.
A file whose name ends in ``.gz`` is read through gzip.

Two quirks of field files are the instrument's, not the reader's: a clock
that was never set (the header date of SnowEx 2020 files is 2000-06-24;
their names carry the true date) and longitudes written without their
sign (108.2 for 108.2° W).  Both are kept as written.
"""

from __future__ import annotations

import gzip
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pencli.errors import DataError

HEADER_BYTES = 512
"""The header's length; the samples start here."""

HEADER: tuple[tuple[int, str, str, str], ...] = (
    (0, ">h", "firmware", ""),
    (2, ">i", "samples_total", ""),
    (6, ">f", "step_mm", "mm"),
    (10, ">f", "force_per_count_n", "N"),
    (14, ">f", "pressure_per_count", "N/bar"),
    (20, ">h", "year", ""),
    (22, ">h", "month", ""),
    (24, ">h", "day", ""),
    (26, ">h", "hour", ""),
    (28, ">h", "minute", ""),
    (30, ">h", "second", ""),
    (56, ">d", "battery_v", "V"),
    (64, ">f", "speed_mm_s", "mm/s"),
    (152, ">h", "comment_length", ""),
    (154, "102s", "comment", ""),
    (256, "8s", "file_name", ""),
    (264, ">f", "latitude_deg", "°"),
    (268, ">f", "longitude_deg", "°"),
    (272, ">f", "height_cm", "cm"),
    (276, ">f", "gps_pdop", ""),
    (280, "c", "gps_north", ""),
    (281, "c", "gps_east", ""),
    (282, ">h", "gps_satellites", ""),
    (358, ">i", "force_samples", ""),
    (362, ">i", "temperature_samples", ""),
    (366, ">h", "sensor_range_pc", "pC"),
    (368, ">h", "amplifier_range_pc", "pC"),
    (370, ">h", "sensitivity_pc_n", "pC/N"),
    (374, ">h", "hand_operated", ""),
    (376, ">i", "tip_diameter_um", "µm"),
    (380, ">h", "overload_n", "N"),
    (384, ">h", "smp_serial", ""),
    (386, ">h", "smp_length_mm", "mm"),
    (392, "20s", "sensor_serial", ""),
    (412, "20s", "amplifier_serial", ""),
)
"""Header fields pen reads: (byte offset, :mod:`struct` format, name, unit)."""


@dataclass(frozen=True)
class SmpProfile:
    """One SnowMicroPen profile: its header fields by pen's names, its depths [mm] and forces [N], and where it came
    from.  Depth 0 is where the motor started, above the snow surface."""

    name: str
    header: dict[str, object]
    depth_mm: np.ndarray
    force_n: np.ndarray
    raw_header: bytes
    source: str = ""

    @property
    def step_mm(self) -> float:
        """Distance between samples. [mm]"""
        return float(self.header["step_mm"])

    @property
    def tip_diameter_mm(self) -> float:
        """The cone's diameter. [mm]"""
        return float(self.header["tip_diameter_um"]) / 1e3

    @property
    def overload_n(self) -> float:
        """The force sensor's range: samples at it are clipped. [N]"""
        return float(self.header["overload_n"])

    @property
    def speed_mm_s(self) -> float:
        """The push rate the instrument recorded. [mm/s]"""
        return float(self.header["speed_mm_s"])


def _text(value: bytes) -> str:
    return value.split(b"\0", 1)[0].decode("latin-1").strip()


def read_pnt(path: str | Path) -> SmpProfile:
    """The profile of a ``.pnt`` file (``.pnt.gz`` through gzip).  Raises :class:`DataError` naming the file and
    what is wrong with it (too short for its header or its sample count, a conversion factor or a resolution that
    is not a positive number)."""
    path = Path(path)
    try:
        raw = path.read_bytes()
        if path.name.lower().endswith(".gz"):
            raw = gzip.decompress(raw)
    except (OSError, EOFError, gzip.BadGzipFile) as error:
        raise DataError(f"{path}: cannot read it as a SnowMicroPen file ({error})") from None
    if len(raw) < HEADER_BYTES:
        raise DataError(f"{path}: {len(raw)} bytes, shorter than a SnowMicroPen header ({HEADER_BYTES} bytes)")
    header: dict[str, object] = {}
    for offset, fmt, name, _unit in HEADER:
        value = struct.unpack_from(fmt, raw, offset)[0]
        header[name] = _text(value) if isinstance(value, bytes) else value
    count = int(header["force_samples"])
    available = (len(raw) - HEADER_BYTES) // 2
    if count < 0 or count > available:
        raise DataError(f"{path}: the header says {count} force samples (byte 358) but the file holds {available}: "
                        "not a SnowMicroPen .pnt file, or one cut short")
    for key in ("step_mm", "force_per_count_n"):
        value = float(header[key])
        if not (np.isfinite(value) and value > 0):
            raise DataError(f"{path}: header field {key} = {value!r}: expected a positive number")
    counts = np.frombuffer(raw, dtype=">i2", count=count, offset=HEADER_BYTES).astype(np.float64)
    name = str(header["file_name"]) or path.name.split(".")[0]
    return SmpProfile(name=name, header=header, depth_mm=np.arange(count) * float(header["step_mm"]),
                      force_n=counts * float(header["force_per_count_n"]), raw_header=raw[:HEADER_BYTES],
                      source=str(path))


def pnt_bytes(header: dict[str, object], force_n: np.ndarray, base: bytes | None = None) -> bytes:
    """A ``.pnt`` file's bytes: ``header`` (pen's names, :data:`HEADER`; others from ``base`` or zero) and the
    forces [N] rounded to counts of ``header["force_per_count_n"]`` (clipped to the 16-bit range)."""
    out = bytearray(base[:HEADER_BYTES] if base is not None else bytes(HEADER_BYTES))
    fields = {**header, "force_samples": len(force_n), "samples_total": len(force_n)}
    for offset, fmt, name, _unit in HEADER:
        if name in fields:
            value = fields[name]
            if fmt.endswith("s"):
                value = str(value).encode("latin-1")
            elif fmt == "c":
                value = str(value or "\0").encode("latin-1")[:1]
            struct.pack_into(fmt, out, offset, value)
    counts = np.clip(np.rint(np.asarray(force_n, float) / float(fields["force_per_count_n"])), -32768, 32767)
    return bytes(out) + counts.astype(">i2").tobytes()
