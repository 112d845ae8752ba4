"""Checks on a run's data columns before it enters a workspace.

Each check raises :class:`~pencli.errors.DataError` with one line naming the
file, the row (as the file numbers it: header is row 1), the column and what
was expected.  Pure numpy.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from pencli.errors import DataError

MIN_RATE_HZ = 1000.0
MIN_ROWS = 16

FORCE_SLACK = 30.0
"""How far a run's peak axial force may stray from S·w·T, the scale its parameter files set, before its unit is
doubted [–].  Measured peaks lie at 0.6–2.5 × S·w·T on the bundled runs, and Cs, the factor between, is
documented up to 20; a unit slip is a factor 1000 (kN) or 4.4 (lbf, within the band: not caught)."""
TRAVEL_SLACK = 2.0
"""How far a run's travel may stray from its stand-off (below) and stand-off + full depth (above) before its unit
is doubted [–].  A blade released s0 above the surface travels s0 plus what it penetrates, at most the full
depth; a unit slip is a factor 25.4 (inches), 10 (cm) or 1000 (metres)."""


@dataclass(frozen=True)
class SensorRange:
    """Full-scale range of the six-axis load cell; readings beyond it are rejected.

    Defaults are those of an ATI Omega190 SI-7200-1400, a sensor that covers
    the paper's 35 MPa dynamic blade pressure on a 184 × 2 mm blade (≈ 13 kN).
    """

    fx_n: float = 7200.0
    fy_n: float = 7200.0
    fz_n: float = 18000.0
    tx_nm: float = 1400.0
    ty_nm: float = 1400.0
    tz_nm: float = 1400.0

    def items(self):
        return (("fx_n", self.fx_n), ("fy_n", self.fy_n), ("fz_n", self.fz_n),
                ("tx_nm", self.tx_nm), ("ty_nm", self.ty_nm), ("tz_nm", self.tz_nm))


def _row(index: int) -> int:
    """File row of data index ``index`` (header is row 1)."""
    return int(index) + 2


def rounding_allowance(t: np.ndarray) -> np.ndarray:
    """Half a unit in the sixth significant digit of |t| (text exports round there). [s]"""
    magnitude = np.floor(np.log10(np.maximum(np.abs(t), 1e-300)))
    return 0.5 * 10.0 ** (magnitude - 5)


def check_run_columns(columns: Mapping[str, np.ndarray], where: str, *, surface_offset_mm: float,
                      sensor: SensorRange = SensorRange()) -> None:
    """Reject data a run cannot be analysed from (CONTRACT §3).

    Checks, in order: enough rows; no NaN or inf; time strictly increasing;
    sample rate ≥ 1 kHz; time uniform up to six-significant-digit rounding;
    position in millimetres, not metres; forces and torques within the
    sensor's range.
    """
    t = np.asarray(columns["time_s"], dtype=float)
    n = t.size
    if n == 0:
        raise DataError(f"{where}: no data rows (empty or header-only file)")
    if n < MIN_ROWS:
        raise DataError(f"{where}: only {n} data rows; expected a recording (at least {MIN_ROWS} rows)")
    for name, values in columns.items():
        bad = ~np.isfinite(values)
        if bad.any():
            i = int(np.argmax(bad))
            raise DataError(f"{where}: row {_row(i)}: column {name} is {float(values[i])!r}; expected a finite number")
    steps = np.diff(t)
    if (steps <= 0).any():
        i = int(np.argmax(steps <= 0)) + 1
        raise DataError(f"{where}: row {_row(i)}: time_s {float(t[i])!r} does not increase (previous row {float(t[i - 1])!r}); "
                        f"expected strictly increasing time")
    rate = (n - 1) / (t[-1] - t[0])
    if rate < MIN_RATE_HZ * (1 - 1e-9):  # exactly 1 kHz computes as 999.9999... from a float span
        raise DataError(f"{where}: sample rate {rate:.1f} Hz from the time span; expected ≥ {MIN_RATE_HZ:g} Hz "
                        f"(is time_s in milliseconds? use --time-unit ms)")
    step = 1.0 / rate
    expected = t[0] + np.arange(n) * step
    deviation = np.abs(t - expected)
    allowed = 0.25 * step + rounding_allowance(t) + rounding_allowance(np.array([t[0]]))[0]
    off = deviation > allowed
    if off.any():
        # a missing or repeated row shows as one step far from the typical one: name that row; the cumulative
        # deviation from the span's grid crosses the tolerance far from it (a row dropped at 8002 showed at 3684)
        steps = np.diff(t)
        typical = float(np.median(steps))
        jumps = np.flatnonzero(np.abs(steps - typical) > 0.5 * typical + 2 * rounding_allowance(t[1:]))
        i = int(jumps[0]) + 1 if jumps.size else int(np.argmax(off))
        raise DataError(f"{where}: row {_row(i)}: time_s {float(t[i])!r} is {deviation[i] / step:.2f} samples off a uniform "
                        f"{rate:.1f} Hz grid; expected uniform sampling (missing or repeated rows?)")
    position = np.asarray(columns["position_mm"], dtype=float)
    span = float(position.max() - position.min())
    if span == 0.0:
        raise DataError(f"{where}: column position_mm never changes; expected the blade's travel in mm "
                        f"(did the rig fire?)")
    if span < 2.0 and surface_offset_mm > 2.0:
        raise DataError(f"{where}: column position_mm spans only {span:g} while the stand-off is "
                        f"{surface_offset_mm:g} mm: it looks like metres; expected millimetres "
                        f"(use --position-unit m)")
    for name, limit in sensor.items():
        values = np.abs(np.asarray(columns[name], dtype=float))
        beyond = values > limit
        if beyond.any():
            i = int(np.argmax(beyond))
            unit = "N" if name.endswith("_n") else "N·m"
            raise DataError(f"{where}: row {_row(i)}: column {name} is {float(columns[name][i])!r}, beyond the sensor's "
                            f"range ±{limit:g} {unit} (saturated, or wrong units?)")


@dataclass(frozen=True)
class UnitScales:
    """What a run's own parameter files say its columns should roughly show (CONTRACT §1 file units)."""

    surface_offset_mm: float
    """Stand-off s0: the blade travels at least to the surface. [mm]"""
    penetration_depth_mm: float
    """Full depth d: the blade travels at most s0 + d. [mm]"""
    strength_scale_n: float
    """S·w·T, the tip resistance without its correction factor; peaks lie within a few times it. [N]"""


def check_units(columns: Mapping[str, np.ndarray], where: str, scales: UnitScales) -> None:
    """Refuse a run whose travel or axial force is off its parameter files' scale by a unit's factor.

    The travel (span of position_mm) must lie within :data:`TRAVEL_SLACK` of the stand-off below and of
    stand-off + full depth above; the peak axial force above the first tenth of the record (the pre-trigger
    level) within :data:`FORCE_SLACK` of S·w·T.  One line names the column, what it shows, the expected
    magnitude and the flag that says it is right.
    """
    position = np.asarray(columns["position_mm"], dtype=float)
    span = float(position.max() - position.min())
    low = scales.surface_offset_mm / TRAVEL_SLACK
    high = TRAVEL_SLACK * (scales.surface_offset_mm + scales.penetration_depth_mm)
    if scales.surface_offset_mm > 0 and not low <= span <= high:
        hint = "inches or centimetres (use --position-unit in or cm)" if span < low else "not millimetres"
        raise DataError(f"{where}: column position_mm travels {span:.4g} while the stand-off is "
                        f"{scales.surface_offset_mm:g} mm and full depth {scales.penetration_depth_mm:g} mm "
                        f"(expected {low:.3g} to {high:.3g} mm): it looks like {hint}; expected millimetres, or "
                        f"--allow-implausible-units if the run is right")
    if scales.strength_scale_n <= 0:
        return
    fz = np.asarray(columns["fz_n"], dtype=float)
    level = float(np.median(fz[: max(1, fz.size // 10)]))
    peak = float(np.max(np.abs(fz - level)))
    low, high = scales.strength_scale_n / FORCE_SLACK, FORCE_SLACK * scales.strength_scale_n
    if not low <= peak <= high:
        hint = "kN (use --force-unit kN)" if peak < low else "not newtons"
        raise DataError(f"{where}: column fz_n peaks {peak:.4g} from its pre-trigger level while the blade's "
                        f"strength scale S·w·T is {scales.strength_scale_n:.4g} N (expected {low:.3g} to "
                        f"{high:.3g} N): it looks like {hint}; expected newtons, or --allow-implausible-units if "
                        f"the run is right")
