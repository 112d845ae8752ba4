"""A free-fall penetrometer's record to motion: accelerometers stitched, release, impact and stop found, the
specific force integrated to speed and depth with the sensors' bias removed where the probe is at rest.

An axial accelerometer reads the specific force f = (g − a)/g in g (a the
acceleration, positive down): 1 at rest, 0 in a vacuum's free fall, above
1 while the bed decelerates the probe.  Where the probe hangs before its
release and where it lies on the bed after it stopped, f must be 1; what
the stitched reading shows there beyond 1 is the sensors' bias, taken out
along a straight line in time between the two rests (a constant bias when
one rest is missing), or held at the first rest's until the impact and at
the last rest's from it on (``bias_at="impact"``: the zero offset a shock
leaves in a sensor).  Then a = g·(1 − f) is integrated from the release
(v = 0) by the trapezoid rule.  Each accelerometer has its own bias, so
each is corrected at rest before the readings are stitched.

The probe lies still after the stop, so the integrated speed must be 0
there; what it shows over the rest after the stop (:attr:`DropMotion.rest_speed_m_s`)
is the integral of what the bias model missed during the drop, plus the
trapezoid rule's error where the deceleration ends within a sample (at
most half a sample of it, :attr:`DropMotion.rest_speed_bound_m_s`) and the
sensors' noise integrated (:attr:`DropMotion.rest_speed_sd_m_s`, from the
scatter at rest).  Pure functions, no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

G = 9.80665
"""Standard gravity. [m/s²]"""

STITCH_MARGIN = 0.9
"""Share of an accelerometer's range below which its reading is taken (the finest such sensor, row by row)."""

RELEASE_DROP_G = 0.2
"""Fall of the specific force below the rest's 1 g that marks a release: a probe falling in water starts at
1 − (m − ρV)/(m + m_a) ≈ 0.35 g, in air at 0. [g]"""

REST_MS = 100.0
"""Span before the release taken as the rest that gives the bias (and after the stop, the same). [ms]"""

IMPACT_RISE_G = 0.5
"""Rise of the specific force over its level in the water just before it that marks the bed: a fall at its
terminal speed reads 1 g, an impact several g. [g]"""

LEVEL_MS = 50.0
"""Span before an impact whose median and scatter set the level the impact rises from. [ms]"""

IMPACT_SIGMAS = 5.0
"""Scatters of the pre-impact level a reading must exceed to belong to the impact (traced back from the rise)."""

BIAS_MODELS = ("ramp", "impact")
"""How a sensor's bias goes from the rest before the release to the rest after the stop: along a straight line in
time (a drift), or as a step at the impact (a shock's zero offset)."""

STOP_SPEED_M_S = 0.02
"""Speed above the least after the impact at which the probe counts as stopped: the 2 kHz samples leave the
integral a residue of about a·Δt/2 where the deceleration ends within a sample. [m/s]"""


def stitch(channels: dict[str, np.ndarray], ranges_g: dict[str, float]) -> np.ndarray:
    """Per row, the reading of the finest accelerometer (smallest range) whose reading is within
    ``STITCH_MARGIN`` of its range on every one of its rows so far stitched; the coarsest where none is. [g]"""
    order = sorted(ranges_g, key=ranges_g.get)
    out = np.array(channels[order[-1]], dtype=float)
    chosen = np.zeros(out.size, dtype=bool)
    for name in order[:-1]:
        fits = ~chosen & (np.abs(channels[name]) < STITCH_MARGIN * ranges_g[name])
        out[fits] = channels[name][fits]
        chosen |= fits
    return out


@dataclass(frozen=True)
class DropMotion:
    """A drop's motion from its record: time [s], acceleration (positive down) [m/s²], speed [m/s] and travel from
    the release [m]; the release, impact (the first row in the bed) and stop rows; the time of impact [s] and the
    speed there [m/s]; penetration, travel from impact to stop [m]; each sensor's bias taken out before the
    release and after the stop [g]."""

    time_s: np.ndarray
    accel_m_s2: np.ndarray
    speed_m_s: np.ndarray
    travel_m: np.ndarray
    release: int
    impact: int
    stop: int
    impact_s: float
    impact_speed_m_s: float
    penetration_m: float
    bias_g: dict[str, tuple[float, float]]
    rest_speed_m_s: float = math.nan
    """Mean integrated speed over the rest after the stop, where the probe lies still (NaN: no such rest). [m/s]"""
    rest_speed_bound_m_s: float = 0.0
    """The most the trapezoid rule leaves there from a deceleration that ends within a sample: half a sample of
    the largest deceleration in the samples before the stop. [m/s]"""
    rest_speed_sd_m_s: float = 0.0
    """Standard deviation the sensors' white noise (their scatter at rest) gives it: integrated from the release,
    and through the two rests' bias estimates. [m/s]"""
    bias_at: str = "ramp"
    """The bias model the motion was integrated with (:data:`BIAS_MODELS`)."""

    @property
    def peak_deceleration_g(self) -> float:
        """The largest deceleration between impact and stop. [g]"""
        bed = self.accel_m_s2[self.impact:self.stop + 1]
        return float(-np.min(bed) / G) if bed.size else 0.0


def release_row(specific_g: np.ndarray) -> int:
    """The first row of the fall: where the specific force first falls ``RELEASE_DROP_G`` below 1 g, traced back
    to the last row before it at 1 g within half that (or the first row)."""
    falling = np.flatnonzero(specific_g < 1.0 - RELEASE_DROP_G)
    if falling.size == 0:
        raise ValueError(f"no release: the specific force never falls {RELEASE_DROP_G} g below 1 g")
    at_rest = np.flatnonzero(specific_g[: falling[0]] >= 1.0 - RELEASE_DROP_G / 2)
    return int(at_rest[-1] + 1) if at_rest.size else 0


def impact_time(time_s: np.ndarray, specific_g: np.ndarray, release: int) -> float:
    """When the tip reached the bed [s]: the rows from where the readings leave their level
    (:func:`impact_row`) to the rise of ``IMPACT_RISE_G``, read as a cone's onset, excess ∝ (t − tᵢ)² (the
    frontal area grows with the square of the depth, the speed barely changes), extrapolated to no excess."""
    rate = 1.0 / float(np.median(np.diff(time_s)))
    first = impact_row(specific_g, release, rate)
    level_rows = max(3, int(LEVEL_MS * 1e-3 * rate))
    level = float(np.median(specific_g[first - level_rows: first]))
    rise = first + int(np.argmax(specific_g[first:] > level + IMPACT_RISE_G))
    rows = np.arange(first, max(rise, first + 2) + 1)
    excess = np.sqrt(np.clip(specific_g[rows] - level, 0.0, None))
    slope, intercept = np.polyfit(time_s[rows], excess, 1)
    onset = -intercept / slope if slope > 0 else float(time_s[first])
    return float(np.clip(onset, time_s[max(first - level_rows, release)], time_s[first]))


def impact_row(specific_g: np.ndarray, release: int, rate_hz: float) -> int:
    """The first row of the impact: after the release, the first row ``IMPACT_RISE_G`` above the median of the
    ``LEVEL_MS`` before it, traced back to where the readings last stood within ``IMPACT_SIGMAS`` of that
    level's scatter."""
    level_rows = max(3, int(LEVEL_MS * 1e-3 * rate_hz))
    start = release + level_rows
    for row in range(start, specific_g.size):
        window = specific_g[row - level_rows: row]
        level = float(np.median(window))
        if specific_g[row] > level + IMPACT_RISE_G:
            spread = 1.4826 * float(np.median(np.abs(window - level)))
            back = row
            while back > start and specific_g[back - 1] > level + IMPACT_SIGMAS * spread:
                back -= 1
            return back
    raise ValueError(f"no impact: the specific force never rises {IMPACT_RISE_G} g above its level after the release")


def drop_motion(time_s: np.ndarray, channels: dict[str, np.ndarray], ranges_g: dict[str, float],
                bias_at: str = "ramp", tilt: tuple[np.ndarray, np.ndarray] | None = None) -> DropMotion:
    """The motion of one drop from its axial accelerometers (``channels`` in g, ``ranges_g`` their ranges): each
    sensor's bias taken out where the probe rests (between the rests as ``bias_at`` says, :data:`BIAS_MODELS`),
    then stitched (:func:`stitch`) and integrated.  With ``tilt`` (the two lateral channels, in g), a probe that
    rests leaning is read through them (:func:`_lean`, :func:`_at_rest`)."""
    if bias_at not in BIAS_MODELS:
        raise ValueError(f"bias model {bias_at!r}: expected one of {', '.join(BIAS_MODELS)}")
    time_s = np.asarray(time_s, dtype=float)
    rate = 1.0 / float(np.median(np.diff(time_s)))
    rest = max(1, int(REST_MS * 1e-3 * rate))
    raw = stitch(channels, ranges_g)
    release = release_row(raw)
    impact = impact_row(raw, release, rate)
    # the stop from a first pass with each sensor's bias at the first rest, then each one's at the rest after it
    leaning = _lean(tilt, rate, time_s.size)
    lean = _at_rest(leaning, release, None)
    before = slice(max(0, release - rest), release)
    first = {name: _rest_bias(values[before], lean[before]) for name, values in channels.items()}
    _, speed, _ = _integrate(time_s, stitch({n: v - first[n] for n, v in channels.items()}, ranges_g), release)
    stop = _stop(speed, impact)
    lean = _at_rest(leaning, release, stop)
    after = slice(stop + rest // 2, stop + rest // 2 + rest)
    last = {name: (_rest_bias(values[after], lean[after]) if values[after].size >= rest // 2 else first[name])
            for name, values in channels.items()}
    if bias_at == "ramp":
        t0, t1 = time_s[max(0, release - rest // 2)], time_s[min(time_s.size - 1, stop + rest)]
        share = np.clip((time_s - t0) / max(t1 - t0, 1e-12), 0.0, 1.0)
    else:
        share = (np.arange(time_s.size) >= impact).astype(float)
    f = stitch({n: v - (first[n] + (last[n] - first[n]) * share) for n, v in channels.items()}, ranges_g)
    f = f * np.sqrt(1.0 - lean) + lean  # the vertical specific force where the probe rests leaning
    accel, speed, travel = _integrate(time_s, f, release)
    stop = _stop(speed, impact)
    hit = impact_time(time_s, f, release)
    at_hit = float(np.interp(hit, time_s, travel))
    after = slice(stop + rest // 2, stop + rest // 2 + rest)
    still = speed[after]
    before = raw[max(0, release - rest): release]
    noise = float(np.std(before)) if before.size > 1 else 0.0  # the finest sensor's scatter at rest [g]
    dt = 1.0 / rate
    span = (stop + rest - release) * dt  # release to the middle of the rest after the stop [s]
    walk = G * noise * math.sqrt(span * dt)  # white noise integrated over it
    estimates = G * noise / math.sqrt(max(rest, 1)) * span  # a rest's mean bias off by its standard error, over it
    return DropMotion(time_s=time_s, accel_m_s2=accel, speed_m_s=speed, travel_m=travel, release=release,
                      impact=int(np.searchsorted(time_s, hit)), stop=stop, impact_s=hit,
                      impact_speed_m_s=float(np.interp(hit, time_s, speed)),
                      penetration_m=float(travel[stop] - at_hit),
                      bias_g={name: (first[name], last[name]) for name in channels},
                      rest_speed_m_s=float(np.mean(still)) if still.size >= rest // 2 else math.nan,
                      rest_speed_bound_m_s=0.5 * dt * float(np.max(np.abs(accel[max(release, stop - 3): stop + 1]))),
                      rest_speed_sd_m_s=math.hypot(walk, estimates), bias_at=bias_at)


TILT_SMOOTH_MS = 20.0
"""Span of the moving mean the tilt channels are read through at rest (their noise squared would otherwise add
to the lean). [ms]"""


def _lean(tilt, rate_hz: float, rows: int) -> np.ndarray:
    """sin²θ of the probe's lean from the vertical as the tilt channels read it, row by row (0 without them).

    At rest the specific force is gravity, 1 g up; leaning by θ, the axial sensors read cos θ of it and the
    lateral (tilt) channels sin θ between them, so sin²θ = t_x² + t_y² (through a moving mean of
    ``TILT_SMOOTH_MS``).  The vertical specific force is then the axial reading (bias out) times cos θ plus
    sin²θ, and a rest's bias is its axial reading less cos θ."""
    if tilt is None:
        return np.zeros(rows)
    width = max(1, int(TILT_SMOOTH_MS * 1e-3 * rate_hz))
    kernel = np.ones(width) / width
    return np.clip(sum(np.convolve(np.asarray(c, dtype=float), kernel, mode="same") ** 2 for c in tilt), 0.0, 1.0)


def _at_rest(lean: np.ndarray, release: int, stop: int | None) -> np.ndarray:
    """``lean`` where the probe rests (before the release and, once ``stop`` is known, from the stop on), 0 while
    it moves: the lateral channels then read the impact's shocks, not gravity, and the probe is taken as
    vertical."""
    rows = np.arange(lean.size)
    resting = rows < release if stop is None else (rows < release) | (rows >= stop)
    return np.where(resting, lean, 0.0)


def _rest_bias(values: np.ndarray, lean: np.ndarray | None = None) -> float:
    """What a sensor reads beyond gravity's share along its axis at rest, cos θ (1 g upright; 0 where there is
    no rest). [g]"""
    if not values.size:
        return 0.0
    return float(np.mean(values - (1.0 if lean is None else np.sqrt(1.0 - lean))))


def _integrate(time_s: np.ndarray, specific_g: np.ndarray, release: int):
    accel = G * (1.0 - specific_g)
    accel[:release] = 0.0
    dt = np.diff(time_s)
    speed = np.concatenate([[0.0], np.cumsum(0.5 * (accel[1:] + accel[:-1]) * dt)])
    speed[:release] = 0.0
    speed -= speed[release]
    travel = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * dt)])
    travel -= travel[release]
    return accel, speed, travel


def _stop(speed: np.ndarray, impact: int) -> int:
    """The first row after the impact where the integrated ``speed`` is within ``STOP_SPEED_M_S`` of its least
    there."""
    after = speed[impact:]
    return int(impact + np.flatnonzero(after <= after.min() + STOP_SPEED_M_S)[0])
