r"""Tare and event detection (paper Fig. 11: stored and analysed windows).

Pure functions on arrays in contract units in, SI out:

- offsets of the six load-cell channels are their means over the
  pre-trigger span (the blade at rest); subtracting them removes the
  sensor offsets *and* the blade's static weight, so the tared axial force
  is :math:`F = R + m_{lc}\,a` (CONTRACT §2);
- depth is :math:`x = \text{position} - s_0` (CONTRACT §3), position taken
  from its pre-trigger level;
- motion start, contact, arrest or full depth are located to a fraction of
  a sample: the encoder counts 0.16 mm, so each event is found on a
  low-order polynomial fitted to the samples around it rather than read off
  one quantised sample.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np

from pencli.errors import DataError
from pencli.filter.windows import PRE_TRIGGER_MARGIN_S, WINDOW_TRIM_S

FORCE_CHANNELS = ("fx_n", "fy_n", "fz_n", "tx_nm", "ty_nm", "tz_nm")
FULL_DEPTH_TOLERANCE_M = 0.5e-3
"""Within this of the full depth, a stop counts as reaching the hard stops. [m]"""
STANDOFF_TOLERANCE_M = 5e-3
"""A block's surface can sit a few mm from the file's stand-off, so the stops can come this much short of the
full depth in file coordinates; there an abrupt stop still counts as the hard stops. [m]"""


def _abrupt_stop(time_s: np.ndarray, depth_m: np.ndarray, last_change: int, step_m: float) -> bool:
    """The motion ends at speed (the hard stops), not decelerating to rest (arrest).

    A parabola through the last 3 ms before the final encoder change gives the
    speed there and the deceleration.  In an arrest the tip has less than one
    encoder count to travel after its last count; at the stops it is cut off
    with more than that still to go (1.5 counts here), or is not decelerating.  ``step_m``: the encoder's
    count (:func:`pencli.filter.derivatives.encoder_step_m`). [m]
    """
    rate = (time_s.size - 1) / (time_s[-1] - time_s[0])
    lo = max(last_change - max(int(3e-3 * rate), 12), 0)
    seg_t, seg_x = time_s[lo:last_change + 1], depth_m[lo:last_change + 1]
    if seg_t.size < 5:
        return False
    t0 = float(seg_t.mean())
    a, b, _ = np.polyfit(seg_t - t0, seg_x, 2)
    speed = 2 * a * (float(time_s[last_change]) - t0) + b
    if speed <= 0:
        return False
    if a >= 0:  # not decelerating at all
        return True
    travel_left = speed * speed / (4 * -a)  # v² / (2 |x''|), x'' = 2a
    return bool(travel_left > 1.5 * step_m)


@dataclass(frozen=True)
class Events:
    """Where a run's phases begin and end (time since release, SI)."""

    motion_start_s: float
    """The release: when the blade started to move, placed by the first encoder counts (:func:`release_time`),
    about a millisecond before the first count at a 0.32 mm encoder. [s]"""
    contact_s: float
    """Tip reaches the surface (x = 0). [s]"""
    contact_speed_m_s: float
    """Speed at contact from the flight fit. [m/s]"""
    stop_s: float
    """Arrest (v = 0) or arrival at the hard stops. [s]"""
    final_depth_m: float
    """Depth where the motion stopped. [m]"""
    end: str
    """``arrest`` or ``full_depth``."""
    window_start_s: float
    """Analysis window, start (default: contact + WINDOW_TRIM_S). [s]"""
    window_end_s: float
    """Analysis window, end (default: stop − WINDOW_TRIM_S). [s]"""
    corners_s: tuple[float, ...] = ()
    """When the tip passed a depth where the geometry's resistance has a corner (a cone's shoulder), between
    contact and stop: set by the inertia stage (:func:`pencli.filter.inertia.corner_times`), where the
    derivatives join. [s]"""

    def __post_init__(self) -> None:
        object.__setattr__(self, "corners_s", tuple(float(c) for c in self.corners_s))  # a stored list reads back

    def to_dict(self) -> dict:
        """The events as stored (a run without corners stores none)."""
        out = asdict(self)
        corners = out.pop("corners_s")
        return {**out, "corners_s": list(corners)} if corners else out


@dataclass(frozen=True)
class Tared:
    """A tared run: SI columns plus its events and offsets."""

    time_s: np.ndarray
    depth_m: np.ndarray
    forces: dict[str, np.ndarray]
    """Tared channels by contract name (N, N·m)."""
    offsets: dict[str, float]
    """What was subtracted from each channel (N, N·m)."""
    events: Events


RELEASE_COUNTS = 12
"""Encoder counts after the release whose times place it (:func:`release_time`). [–]"""


def release_time(time_s: np.ndarray, depth_m: np.ndarray, changes: np.ndarray, end: int, rate_hz: float
                 ) -> float:
    r"""When the motion started: the time the blade left rest, from the times of its first encoder counts. [s]

    The first count comes only once the blade has moved up to one count (a millisecond after the release at
    0.32 mm and 280 m/s²).  Over its first counts the blade moves from rest under a nearly constant
    push, :math:`u(t) = \tfrac12 a (t - t_r)^2`, and reaches count k's edge, at height :math:`p_k - c`
    (:math:`p_k` the level the record reads after it, c the unknown offset of the edges from rest,
    0 ≤ c < one count), between the sample before the change and the sample of the change.  For each c on
    a grid, :math:`t_k = t_r + \beta\sqrt{p_k - c}` is a straight line (:math:`\beta = \sqrt{2/a}`); the c
    whose line fits the edge times best gives :math:`t_r`.  A break of the derivatives placed at the first
    count instead bent the smoothed acceleration by +2 m/s² over the next few ms (0.32 mm encoder, 30 kHz),
    a bias along the acceleration itself, i.e. a load-cell mass error, that null replicates made from the
    smoothed record do not have.

    ``changes``: indices where the record changes; ``end``: the first index not in free flight (at the
    surface); ``rate_hz``: the record's sampling rate.  Falls back on the first count when fewer than 4 rising counts precede ``end`` or no
    straight line rises.
    """
    first = int(changes[0])
    rest = float(depth_m[first - 1]) if first > 0 else float(depth_m[0])
    rising = [first]
    for k in changes[1:]:
        if k >= end or len(rising) >= RELEASE_COUNTS or depth_m[k] <= depth_m[rising[-1]]:
            break
        rising.append(int(k))
    if len(rising) < 4 or depth_m[first] <= rest:
        return float(time_s[first])
    idx = np.asarray(rising)
    edges = time_s[idx] - 0.5 / rate_hz  # the edge lies between the sample before and the sample of the change
    heights = depth_m[idx] - rest
    offsets = heights[0] * np.arange(32)[:, None] / 32.0  # c on its grid (rows)
    s = np.sqrt(heights - offsets)  # (grid, counts): one straight line t = t_r + β·s per row
    s_mean, e_mean = s.mean(axis=1, keepdims=True), edges.mean()
    beta = np.sum((s - s_mean) * (edges - e_mean), axis=1) / np.sum((s - s_mean) ** 2, axis=1)
    t_r = e_mean - beta * s_mean[:, 0]
    sse = np.sum((edges - t_r[:, None] - beta[:, None] * s) ** 2, axis=1)
    sse[~(beta > 0.0)] = np.inf
    if not np.isfinite(sse).any():
        return float(time_s[first])
    return float(np.clip(t_r[int(np.argmin(sse))], time_s[0], time_s[first]))


REST_TAIL = 0.05
"""Share of the record, at its end, whose commonest level is the blade's rest after the stop (at least 16
samples). [–]"""


def _rest_levels(values: np.ndarray, step_m: float) -> tuple[float, float, float]:
    """(commonest level, lowest and highest level within a count of it) of a record at rest. [m]"""
    levels, counts = np.unique(values, return_counts=True)
    mode = float(levels[np.argmax(counts)])
    near = levels[np.abs(levels - mode) < 1.5 * step_m]
    return mode, float(near.min()), float(near.max())


def moving_span(depth_m: np.ndarray, before: np.ndarray, step_m: float) -> tuple[int, int]:
    """(first, last): the first sample of the motion and the first sample of the rest after it, in a record
    whose encoder may flicker by a count at rest (string vibration, an edge under the read head).

    A rest is the record's commonest level over ``before`` (the blade at rest before the release, e.g. the
    pre-trigger span) or over its last :data:`REST_TAIL`, with the neighbouring counts it flickers to
    there.  A flicker moves the record by one count and back; the motion moves it further.  So the motion
    starts after the record was last at or below the first rest's commonest level before it first rose two
    counts above it (not its lowest: a blade resting a hair above a count edge flickers down a count now and
    then, and the last such flicker, 5 ms before a release on a 0.08 mm encoder, put the release there and
    the derivatives' break with it), and ends where it first entered the final rest's levels after it was
    last two counts from them.  On a record that does not flicker these are its first and last changes.
    ``(-1, -1)`` when the record never moves two counts.
    """
    x = np.asarray(depth_m, dtype=float)
    tol = 1.5 * step_m
    lead = x[before] if np.any(before) else x[:1]
    start, _, _ = _rest_levels(lead, step_m)
    final, final_lo, final_hi = _rest_levels(x[x.size - max(16, int(REST_TAIL * x.size)):], step_m)
    risen = np.flatnonzero(x - start > tol)
    away = np.flatnonzero(np.abs(x - final) > tol)
    if risen.size == 0 or away.size == 0:
        return -1, -1
    resting = np.flatnonzero(x[:risen[0]] < start + 0.5 * step_m)
    first = int(resting[-1]) + 1 if resting.size else 0
    after = x[away[-1]:]
    arrived = np.flatnonzero((after > final_lo - 0.5 * step_m) & (after < final_hi + 0.5 * step_m))
    last = int(away[-1] + arrived[0]) if arrived.size else x.size - 1
    return first, last


def _fit_crossing(t: np.ndarray, x: np.ndarray, level: float, degree: int = 2) -> tuple[float, float]:
    """Time where a polynomial fit of x(t) crosses ``level``, and dx/dt there."""
    t0 = t.mean()
    coeffs = np.polyfit(t - t0, x, degree)
    shifted = coeffs.copy()
    shifted[-1] -= level
    roots = np.roots(shifted)
    real = roots[np.isreal(roots)].real + t0
    inside = real[(real >= t[0] - 1e-3) & (real <= t[-1] + 1e-3)]
    if inside.size == 0:
        raise DataError("could not locate the crossing on the position record")
    crossing = float(inside[np.argmin(np.abs(inside - t[len(t) // 2]))])
    slope = float(np.polyval(np.polyder(coeffs), crossing - t0))
    return crossing, slope


def detect_events(time_s: np.ndarray, depth_m: np.ndarray, full_depth_m: float, *, where: str = "run"
                  ) -> Events:
    """Locate motion start, contact, stop and the default analysis window.

    Parameters
    ----------
    time_s : time since release. [s]
    depth_m : tip depth x, quantised by the encoder. [m]
    full_depth_m : the penetrator's full penetration depth. [m]
    """
    from pencli.filter.derivatives import encoder_step_m

    step = encoder_step_m(depth_m)
    changes = np.flatnonzero(np.diff(depth_m)) + 1
    # a flickering encoder at rest changes count before the release and after the stop: keep the motion's
    first_move, rest_again = moving_span(depth_m, time_s < 0.0, step)
    changes = changes[(changes >= first_move) & (changes <= rest_again)]
    if changes.size < 4:
        raise DataError(f"{where}: the position barely changes; no motion to analyse")
    inside = np.flatnonzero(depth_m >= 0.0)
    if inside.size == 0:
        raise DataError(f"{where}: the tip never reaches the surface (max depth {depth_m.max() * 1e3:.2f} mm); "
                        f"check surface_offset_mm")
    first_in = int(inside[0])
    rate = (time_s.size - 1) / (time_s[-1] - time_s[0])
    motion_start = release_time(time_s, depth_m, changes, first_in, rate)
    # contact: quadratic through ~1.5 ms of flight ending at the first sample at or below the surface
    span = max(int(1.5e-3 * rate), 8)
    lo = max(first_in - span, int(changes[0]))
    hi = min(first_in + 2, depth_m.size)
    contact, speed = _fit_crossing(time_s[lo:hi], depth_m[lo:hi], 0.0)
    contact = min(max(contact, float(time_s[lo])), float(time_s[first_in]))

    last_change = int(changes[-1])
    final_depth = float(depth_m[last_change])
    if final_depth >= full_depth_m - FULL_DEPTH_TOLERANCE_M or (
            final_depth >= full_depth_m - STANDOFF_TOLERANCE_M and _abrupt_stop(time_s, depth_m, last_change, step)):
        end = "full_depth"
        stop = float(time_s[last_change])
    else:
        end = "arrest"
        # arrest: v -> 0, so x(t) is a parabola near the stop; its vertex is the stop.
        span = max(int(3e-3 * rate), 12)
        lo = max(last_change - span, first_in)
        seg_t, seg_x = time_s[lo:last_change + 1], depth_m[lo:last_change + 1]
        if seg_t.size >= 5:
            t0 = seg_t.mean()
            a, b, _ = np.polyfit(seg_t - t0, seg_x, 2)
            vertex = t0 - b / (2 * a) if a < 0 else float(time_s[last_change])
            stop = float(np.clip(vertex, time_s[last_change], time_s[min(last_change + span, time_s.size - 1)]))
        else:
            stop = float(time_s[last_change])
    if stop <= contact:
        raise DataError(f"{where}: the motion stops ({stop * 1e3:.2f} ms) before contact ({contact * 1e3:.2f} ms)")
    return Events(motion_start, contact, speed, stop, final_depth, end, *_default_window(contact, stop))


def _default_window(contact_s: float, stop_s: float) -> tuple[float, float]:
    """The default analysis window: :data:`WINDOW_TRIM_S` inside contact and stop (none in a run shorter than four
    trims). [s]"""
    trim = WINDOW_TRIM_S if stop_s - contact_s > 4 * WINDOW_TRIM_S else 0.0
    return contact_s + trim, stop_s - trim


FALL_SPAN_S = 3e-3
"""How long before the encoder's stop the force's fall at the end of penetration is looked for. [s]"""
FALL_LEVEL_S = 1e-3
"""The force's level at a sample: the median of this long before it. [s]"""
FALL_FRACTION = 0.5
"""The force has fallen where two consecutive samples lie below this fraction of its level."""
REST_FRACTION = 0.25
"""...and over the quarter of :data:`FALL_LEVEL_S` after, lies within this fraction of the fall of the force at
rest (2-12 ms after the encoder's stop)."""


def force_fall(time_s: np.ndarray, force_n: np.ndarray, events: Events, noise_n: float) -> float | None:
    """The end of penetration as the force sees it: the last sample at its level before it falls, or None. [s]

    In the material the tip's resistance holds the force up to the instant the motion ends; then the material
    holds only the drive (an arrest) or the hard stops take the load (full depth), and the axial force falls
    within a sample or two (the channel's filter and lag only delay the fall).  The encoder places the stop
    from a parabola through its last counts (:func:`detect_events`), which a hard stop reached slowly cuts off
    while still decelerating: there the parabola's vertex lies past the real stop by the speed over the
    deceleration (0.7-0.9 ms at 0.3 m/s and 400-700 m/s²), and a window ending 0.5 ms before it held samples
    after the fall.  Looked for from :data:`FALL_SPAN_S` before the encoder's stop to 1 ms after it: the first
    of two consecutive samples under :data:`FALL_FRACTION` of the median of the :data:`FALL_LEVEL_S` before
    it, where that level stands at least 20 × ``noise_n`` (the pre-trigger force's standard deviation) above 0,
    and where the force then lies near its level at rest (:data:`REST_FRACTION`): a weaker layer the tip enters
    lowers the force but not to the drive's or the stops' level.  None where the force does not fall so (a drive
    that holds nearly what the material did, or a lagging force chain that falls slowly).  On 400 sim-rig shots
    (as :data:`HARD_STOP_LEAD_S`'s, with a weak layer, a sensor lag or ringing in a fifth each) the sample so found
    lay within 0.1 ms of the true stop in 314 of the 315 without a lag (the one other had none); behind lags of
    0.1-0.8 ms it was found in 12 of 85, 0.13-0.27 ms late; the encoder's stop lay from -1.06 to +0.65 ms off.
    """
    rate = (time_s.size - 1) / (time_s[-1] - time_s[0])
    level_n = max(int(round(FALL_LEVEL_S * rate)), 8)
    lo = max(int(np.searchsorted(time_s, max(events.stop_s - FALL_SPAN_S, events.contact_s))), level_n)
    hi = min(int(np.searchsorted(time_s, events.stop_s + 1e-3)), force_n.size - 1)
    if hi - lo < 4:
        return None
    window = np.lib.stride_tricks.sliding_window_view(force_n[lo - level_n:hi], level_n)
    level = np.median(window, axis=1)  # level[j]: of the samples before lo + j
    below = force_n[lo:hi + 1] < FALL_FRACTION * level
    fallen = np.flatnonzero(below[:-1] & below[1:] & (level[:-1] > 20.0 * noise_n))
    rest = force_n[(time_s > events.stop_s + 2e-3) & (time_s < events.stop_s + 12e-3)]
    if fallen.size == 0 or rest.size < 8:
        return None
    rest_n = float(np.median(rest))
    for j in fallen:
        at = lo + int(j)
        # to the force at rest, not to a weaker layer's: the blade no longer pushes into the material
        settled = float(np.median(force_n[at:at + level_n // 4 + 2]))
        if settled - rest_n <= REST_FRACTION * (float(level[j]) - rest_n):
            return float(time_s[at - 1])
    return None


HARD_STOP_LEAD_S = 0.1e-3
"""A vertex of the encoder's parabola further than this past the force's fall is a motion the hard stops cut off
while the tip still moved, not an arrest.  On 300 sim-rig shots with blocks of 0.9-1.3 × the strength that just
reaches the stops (blades 1-2 mm, 2-6 springs, encoders 0.08-0.32 mm, 30 and 60 kHz, 0.5-6 N of noise,
stand-off errors within ±2 mm, half behind an anti-alias filter) the 149 arrests whose force fell put the
vertex at most 0.044 ms past the fall, the 150 stops at least 0.19 ms (at 0.06 m/s; the next 0.68 ms, at
0.47 m/s); on 400 more (0.7-1.3 ×, a fifth each with a weak layer, a sensor lag or ringing) the arrests at most
0.026 ms, the stops at least 0.56 ms. [s]"""


def ended_by_force(time_s: np.ndarray, force_n: np.ndarray, events: Events, full_depth_m: float,
                   noise_n: float) -> Events:
    """``events`` with the stop placed no later than the force's fall (:func:`force_fall`), and an arrest
    reclassified as the hard stops where its parabola's vertex lies more than :data:`HARD_STOP_LEAD_S` past
    that fall within :data:`STANDOFF_TOLERANCE_M` of the full depth; the default window (:func:`_default_window`)
    is that of the stop so placed.  Unchanged where the force does not fall."""
    fall = force_fall(time_s, force_n, events, noise_n)
    if fall is None or fall >= events.stop_s or fall <= events.contact_s:
        return events
    end = events.end
    if (end == "arrest" and events.stop_s - fall > HARD_STOP_LEAD_S
            and events.final_depth_m >= full_depth_m - STANDOFF_TOLERANCE_M):
        end = "full_depth"
    start, stop = _default_window(events.contact_s, fall)
    return replace(events, stop_s=fall, end=end, window_start_s=start, window_end_s=stop)


def tare(columns: dict[str, np.ndarray], surface_offset_mm: float, full_depth_mm: float, *,
         window_ms: tuple[float, float] | None = None, where: str = "run") -> Tared:
    """Tare the load cell on the pre-trigger span and locate the run's events.

    Parameters
    ----------
    columns : raw CONTRACT §3 columns (s, mm, N, N·m).
    surface_offset_mm : stand-off s0. [mm]
    full_depth_mm : penetration depth at the hard stops. [mm]
    window_ms : analysis window override (start, end), time since release. [ms]
    """
    t = np.asarray(columns["time_s"], dtype=float)
    pre = t < -PRE_TRIGGER_MARGIN_S
    if pre.sum() < 16:
        raise DataError(f"{where}: only {int(pre.sum())} pre-trigger samples (time_s < "
                        f"{-PRE_TRIGGER_MARGIN_S * 1e3:g} ms); the tare needs the blade at rest before the release")
    offsets = {name: float(np.mean(columns[name][pre])) for name in FORCE_CHANNELS}
    forces = {name: np.asarray(columns[name], dtype=float) - offsets[name] for name in FORCE_CHANNELS}
    position = np.asarray(columns["position_mm"], dtype=float)
    position_zero = float(np.median(position[pre]))
    depth = (position - position_zero - surface_offset_mm) * 1e-3  # CONTRACT §3: x = position − offset
    events = detect_events(t, depth, full_depth_mm * 1e-3, where=where)
    events = ended_by_force(t, forces["fz_n"], events, full_depth_mm * 1e-3, float(np.std(forces["fz_n"][pre])))
    if window_ms is not None:
        start, end = (w * 1e-3 for w in window_ms)
        if not (t[0] <= start < end <= t[-1]):
            raise DataError(f"{where}: --window {window_ms[0]:g},{window_ms[1]:g} ms is not inside the record "
                            f"({t[0] * 1e3:.1f} to {t[-1] * 1e3:.1f} ms) or not increasing")
        events = Events(**{**events.to_dict(), "window_start_s": start, "window_end_s": end})
    return Tared(t, depth, forces, offsets, events)


_REFERENCE_S = 2e-3
"""How long a span before the searched one the force's flight level and noise are read from. [s]"""
_DEPARTURE_SDS = 6.0
"""How far above its flight level, in the flight force's robust standard deviations, the force must be on two
consecutive samples to have departed from it."""
_LEVEL_SAMPLES = 8
"""The force's level at a sample: the median of the samples before it."""


def _first_departure(force_n: np.ndarray, lo: int, hi: int, reference: int) -> int | None:
    """The first sample in ``lo..hi`` where the force has risen off its flight level, or None.

    The level at a sample is the median of the :data:`_LEVEL_SAMPLES` before it; a rise is :data:`_DEPARTURE_SDS`
    robust standard deviations of the ``reference`` samples before ``lo`` on two consecutive samples, the
    deviation the larger of the force's about a straight line and of its rise over its level there (smooth,
    coloured noise wanders further than it steps: measured by its steps alone, a filtered flight's wander had
    been taken for a departure 0.25 ms before the contact, and a block's surface placed 2.7 mm off).  Only
    rises: the tip's contact compresses the load cell.  None where there is no reference.
    """
    start = lo - reference - _LEVEL_SAMPLES
    if reference < 4 * _LEVEL_SAMPLES or start < 0 or hi + 1 >= force_n.size:
        return None
    segment = force_n[start:hi + 2]
    level = np.median(np.lib.stride_tricks.sliding_window_view(segment[:-1], _LEVEL_SAMPLES), axis=1)
    rise = segment[_LEVEL_SAMPLES:] - level  # rise[j]: sample lo - reference + j over its level
    flight = force_n[lo - reference:lo]
    about_line = flight - np.polyval(np.polyfit(np.arange(reference), flight, 1), np.arange(reference))
    spread = max(_robust_sd(rise[:reference]), _robust_sd(about_line))
    if not spread > 0:
        return None
    above = rise > _DEPARTURE_SDS * spread
    hits = np.flatnonzero((above[:-1] & above[1:])[reference:])
    return int(lo + hits[0]) if hits.size else None


def _robust_sd(values: np.ndarray) -> float:
    """1.4826 × the median absolute deviation: the standard deviation of a normal sample, unmoved by a few
    outliers (a mode's peaks, a step). [units of ``values``]"""
    return 1.4826 * float(np.median(np.abs(values - np.median(values))))


def force_onset(time_s: np.ndarray, force_n: np.ndarray, contact_s: float, *, span_s: float = 4e-3) -> float:
    """Contact as the force sees it: the change point of the tared force within ``span_s`` of ``contact_s``. [s]

    The force follows the free flight's slow trend until the tip meets the
    material, then the strength term switches on.  The change point is the
    split that best fits two straight lines (least squares, by cumulative sums),
    or the force's first sustained rise off its flight level
    (:func:`_first_departure`) where that comes earlier: a strong mode struck at
    contact can make the two lines fit best half a period late.
    A block whose surface is not where the energizing file puts it (stand-off
    scatter) makes it differ from the position's contact.
    """
    sel = np.flatnonzero((time_s >= contact_s - span_s) & (time_s <= contact_s + span_s))
    if sel.size < 12:
        return float(contact_s)
    t = time_s[sel] - contact_s
    y = force_n[sel]
    n = t.size

    def segment_rss(tt, yy):
        k = np.arange(1, tt.size + 1, dtype=float)
        st, sy = np.cumsum(tt), np.cumsum(yy)
        stt, sty, syy = np.cumsum(tt * tt), np.cumsum(tt * yy), np.cumsum(yy * yy)
        var_t = stt - st * st / k
        cov = sty - st * sy / k
        rss = syy - sy * sy / k - np.where(var_t > 0, cov * cov / np.where(var_t > 0, var_t, 1.0), 0.0)
        return rss

    left = segment_rss(t, y)  # left[i]: samples 0..i
    right = segment_rss(t[::-1], y[::-1])[::-1]  # right[i]: samples i..n-1
    splits = np.arange(4, n - 4)  # the right segment starts at the split
    total = left[splits - 1] + right[splits]
    best = int(splits[np.argmin(total)])
    departed = _first_departure(force_n, int(sel[0]), int(sel[-1]), int(round(_REFERENCE_S / (t[1] - t[0]))))
    if departed is not None and 4 <= departed - sel[0] < best:
        # the contact is not after the force has left its flight level: a struck mode (2.1 kHz, 730 N on a 1 mm
        # blade at 12 m/s) makes two straight lines fit best half a period late, and a ringing timed from there
        # fitted no run (dev 2 of ``--varied 12 102000 --only rig_ringing``)
        best = int(departed - sel[0])
    return float(time_s[sel][best])
