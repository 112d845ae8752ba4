r"""Velocity and acceleration from a quantised encoder.

The string encoder counts 0.16 mm; at 30 kHz a count lasts several samples,
so finite differences of position are mostly zero with spikes between, and
their second difference is useless.  Methods are registered by name in
:data:`METHODS`; ``bench/bench_derivatives.py`` measures each against the
simulated rig's true motion, and the default is the one with the lowest
acceleration error there (see ``DEFAULT_METHOD``).

Every method works piecewise: the motion is smooth *within* flight, within
penetration and at rest, but its acceleration jumps at contact (the strength
term switches on) and at the stop, so no smoothing window straddles those
instants.
"""

from __future__ import annotations

import functools

import warnings
from typing import Callable, Sequence

from pencli.lazy import lazy

from pencli.errors import DataError

np = lazy("numpy")  # imported on first use: `pen --help` does not load numpy


def _segments(n: int, breaks: Sequence[int]) -> list[tuple[int, int]]:
    edges = sorted({0, n, *[int(b) for b in breaks if 0 < b < n]})
    return [(a, b) for a, b in zip(edges[:-1], edges[1:]) if b > a]


def savgol(x: np.ndarray, rate_hz: float, breaks: Sequence[int], window_s: float = 1.5e-3, order: int = 3
           ) -> tuple[np.ndarray, np.ndarray]:
    """Savitzky–Golay local cubic fits, window ``window_s``, per segment. [m/s, m/s²]"""
    from scipy.signal import savgol_filter

    v = np.zeros_like(x)
    a = np.zeros_like(x)
    dt = 1.0 / rate_hz
    for lo, hi in _segments(x.size, breaks):
        seg = x[lo:hi]
        n = seg.size
        window = int(round(window_s * rate_hz)) | 1
        window = min(window, n if n % 2 else n - 1)
        if window < order + 2:
            if n >= 3:
                v[lo:hi] = np.gradient(seg, dt)
                a[lo:hi] = np.gradient(v[lo:hi], dt)
            continue
        v[lo:hi] = savgol_filter(seg, window, order, deriv=1, delta=dt, mode="interp")
        a[lo:hi] = savgol_filter(seg, window, order, deriv=2, delta=dt, mode="interp")
    return v, a


SMOOTHING = 2.0
"""Residual budget of the smoothing spline in units of n·(encoder step)²/12 (see ``bench_derivatives``)."""

MAX_KNOTS = 76
"""The most knots FITPACK's search may place in one segment (64 inside it, for a quintic): a bound on its time, not
on the fit.  The moving segments of 24 development campaigns (``varied_campaigns(24, 262000)``, 300 segments of
258-2,381 samples) used at most 14 (two inside); a record its budget cannot meet, such as a rest record flickering
over three counts, would otherwise get a knot every few samples (3,781 knots in 407 s for 12,000 samples; 76
knots take 0.4 s there)."""


MIN_SPLINE_SAMPLES = 8
"""A segment shorter than this gets differences, not a spline."""


def _budget(samples: int, count_m: float) -> float:
    """The smoothing spline's residual budget over ``samples``: :data:`SMOOTHING` times their quantisation
    variance, (encoder step)²/12 each. [m²]"""
    return SMOOTHING * samples * (count_m / np.sqrt(12.0)) ** 2  # the quantisation error's standard deviation²


def _resting(segment: np.ndarray, count_m: float):
    """Whether a segment (or each column of one) moves a count at most: at rest, an edge under the read head
    flickering it between two counts."""
    return np.ptp(segment, axis=0) <= count_m * (1.0 + 1e-9)


def _spline_pieces(x: np.ndarray, rate_hz: float, breaks: Sequence[int], count_m: float,
                   at_rest: np.ndarray | None = None):
    """(lo, hi, piece) per segment: a quintic smoothing spline, smoothing set by the quantisation; the
    segment's mean (a float) where it is at rest (wholly inside ``at_rest``, or moving a count at most); None
    where it is too short."""
    from scipy.interpolate import make_splrep

    t = np.arange(x.size) / rate_hz
    k = 5  # quintic; FITPACK's own bounds on the knots: from 2(k + 1) to n + k + 1
    out = []
    for lo, hi in _segments(x.size, breaks):
        n = hi - lo
        if n < MIN_SPLINE_SAMPLES:
            out.append((lo, hi, None))
            continue
        seg = x[lo:hi]
        if at_rest is not None and bool(np.all(at_rest[lo:hi])):
            # at rest by the events (before the release, after the arrest): no knot search.  An encoder whose
            # own position error flickers a rest record across two edges made FITPACK's search place 3,781 knots
            # in 12,048 samples (407 s for one segment of one run; dev rate_strength-8 of ``--varied 16 255000``)
            out.append((lo, hi, float(np.mean(seg))))
            continue
        if _resting(seg, count_m):
            # at rest, flickering between two counts at most (an edge under the read head): its mean; a
            # spline held to the quantisation budget would chase the flicker with hundreds of knots
            out.append((lo, hi, float(np.mean(seg))))
            continue
        with warnings.catch_warnings():
            # FITPACK may return its closest approximation when s is tight for quantised data; that is fine here
            warnings.simplefilter("ignore", RuntimeWarning)
            # a residual budget of twice the quantisation variance: at exactly one, FITPACK's knot search
            # fails on some encoder phases (slow motion makes the error a sawtooth) and returns wild curves
            out.append((lo, hi, make_splrep(t[lo:hi], x[lo:hi], k=k, s=_budget(n, count_m),
                                            nest=max(min(MAX_KNOTS, n + k + 1), 2 * (k + 1)))))
    return t, out


def smooth_motion(x: np.ndarray, rate_hz: float, breaks: Sequence[int], count_m: float = 0.16e-3,
                  at_rest: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Smoothed position, velocity and acceleration by the smoothing spline of :func:`spline`. [m, m/s, m/s²]

    ``at_rest``: where the blade is at rest (a mask of ``x``'s samples); a segment wholly inside it takes its
    mean position and no velocity or acceleration.
    """
    x = np.asarray(x, dtype=float)
    position, v, a = x.copy(), np.zeros_like(x), np.zeros_like(x)
    t, pieces = _spline_pieces(x, rate_hz, breaks, count_m, at_rest)
    for lo, hi, spl in pieces:
        if isinstance(spl, float):  # at rest
            position[lo:hi] = spl
            continue
        if spl is None:
            if hi - lo >= 3:
                v[lo:hi] = np.gradient(x[lo:hi], t[lo:hi])
                a[lo:hi] = np.gradient(v[lo:hi], t[lo:hi])
            continue
        position[lo:hi] = spl(t[lo:hi])
        v[lo:hi] = spl(t[lo:hi], 1)
        a[lo:hi] = spl(t[lo:hi], 2)
    return position, v, a


def spline(x: np.ndarray, rate_hz: float, breaks: Sequence[int], count_m: float = 0.16e-3,
           at_rest: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Quintic smoothing spline per segment, smoothing set by the quantisation noise. [m/s, m/s²]

    ``count_m`` is the encoder step (:func:`encoder_step_m` reads it from the record). [m]
    ``at_rest``: as for :func:`smooth_motion`.
    """
    _, v, a = smooth_motion(x, rate_hz, breaks, count_m, at_rest)
    return v, a


@functools.lru_cache(maxsize=64)
def _quintic(n: int, rate_hz: float):
    """(basis, least-squares solve, second derivative) of a quintic over ``n`` samples at ``rate_hz``, in Legendre
    polynomials of the time scaled to [−1, 1]: coefficients = solve @ record, acceleration = second @ coefficients.
    [–, –, 1/s²]"""
    span = (n - 1) / rate_hz
    u = np.linspace(-1.0, 1.0, n)
    basis = np.polynomial.legendre.legvander(u, 5)
    second = np.column_stack([np.polynomial.legendre.legval(u, np.polynomial.legendre.legder(np.eye(6)[j], 2,
                                                                                             scl=2.0 / span))
                              for j in range(6)])
    return basis, np.linalg.pinv(basis), second


def spline_columns(x: np.ndarray, rate_hz: float, breaks: Sequence[int], count_m: float) -> np.ndarray:
    """The acceleration :func:`spline` gives each column of ``x`` (n × m records of one motion's breaks), with the
    columns' shared work done once. [m/s²]

    FITPACK's knot search starts from the least-squares polynomial of the spline's degree and stops there when its
    residual meets the budget: over a blade's segments it does (half the budget on the simulated rig), and a
    smoothing spline with no inner knot is that polynomial.  So each segment's quintic is fitted to every column at
    once (one least-squares solve), and only a column whose residual exceeds the budget goes through :func:`spline`
    on its own; the two agree to round-off (10⁻¹⁰ m/s² against hundreds).  A segment a column rests in (a count's
    flicker at most) has no acceleration, as in :func:`spline`."""
    x = np.asarray(x, dtype=float)
    n, m = x.shape
    accel = np.zeros((n, m))
    t = np.arange(n) / rate_hz
    alone = np.zeros(m, dtype=bool)
    for lo, hi in _segments(n, breaks):
        seg = x[lo:hi]
        if hi - lo < MIN_SPLINE_SAMPLES:  # as _spline_pieces: differences where there are 3 samples
            if hi - lo >= 3:
                accel[lo:hi] = np.gradient(np.gradient(seg, t[lo:hi], axis=0), t[lo:hi], axis=0)
            continue
        basis, solve, second = _quintic(hi - lo, float(rate_hz))
        coef = solve @ seg
        sse = np.sum((seg - basis @ coef) ** 2, axis=0)
        still = _resting(seg, count_m)  # no motion, as _spline_pieces reads it
        accel[lo:hi] = np.where(still, 0.0, second @ coef)
        alone |= ~still & (sse > _budget(hi - lo, count_m))
    for column in np.flatnonzero(alone):
        accel[:, column] = spline(x[:, column], rate_hz, breaks, count_m)[1]
    return accel


def encoder_step_m(position_m: np.ndarray, default_m: float = 0.16e-3) -> float:
    """The position record's quantum: the smallest step between samples, if the steps are its multiples. [m]

    A quantised encoder moves in whole counts, so every change of the record is
    a multiple of one count.  A record that is not quantised (an analogue
    sensor, or counts already smoothed) gets the equivalent step √12·σ of its
    sample-to-sample scatter at rest, and ``default_m`` if it has none.
    """
    x = np.asarray(position_m, dtype=float)
    steps = np.abs(np.diff(x))
    steps = steps[steps > 1e-9]
    if steps.size < 4:
        return default_m
    smallest = float(np.quantile(steps, 0.02))
    ratio = steps / smallest
    if np.mean(np.abs(ratio - np.round(ratio)) < 0.05) >= 0.9:
        return smallest
    rest = np.diff(x[: max(16, x.size // 20)])
    sigma = float(np.std(rest)) / np.sqrt(2.0)
    return float(np.sqrt(12.0) * sigma) if sigma > 0 else default_m


LSQ_KNOT_S = 3e-3
"""The least-squares spline's knot spacing while the blade moves. [s]"""


def lsq_spline(x: np.ndarray, rate_hz: float, breaks: Sequence[int], *, t0: float = 0.0,
               break_times: Sequence[tuple[float, int]] | None = None, knot_s: float = LSQ_KNOT_S,
               rest_knot_s: float = 5e-3) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares quintic spline over the whole record, with knots at the events. [m/s, m/s²]

    Linear in the record: ``x`` may hold several records as columns (n, m).

    ``break_times`` are (time [s], continuity) pairs: continuity 1 keeps position
    and velocity continuous there (contact, arrest: the acceleration jumps),
    0 keeps only position (the hard stops: the velocity jumps).  Without them,
    the sample indices in ``breaks`` are used with continuity 1.  Knots are
    ``knot_s`` apart while moving and ``rest_knot_s`` apart before the first
    and after the last break.
    """
    from scipy.interpolate import make_lsq_spline

    k = 5
    n = x.shape[0]
    t = t0 + np.arange(n) / rate_hz
    if break_times is None:
        break_times = [(float(t[int(b)]), 1) for b in breaks if 0 < b < n]
    events = sorted((float(bt), int(c)) for bt, c in break_times if t[0] < bt < t[-1])
    edges = [float(t[0])] + [bt for bt, _ in events] + [float(t[-1])]
    interior: list[float] = []
    for i, (a, b) in enumerate(zip(edges[:-1], edges[1:])):
        spacing = rest_knot_s if (i == 0 or i == len(edges) - 2) and len(edges) > 2 else knot_s
        n_inner = int((b - a) / spacing)
        interior.extend(np.linspace(a, b, n_inner + 2)[1:-1].tolist())
        if i < len(events):
            interior.extend([events[i][0]] * (k - events[i][1]))
    knots = np.concatenate([[t[0]] * (k + 1), np.sort(interior), [t[-1]] * (k + 1)])
    spl = make_lsq_spline(t, x, knots, k)
    return spl(t, 1), spl(t, 2)  # evaluated per knot interval, so repeated knots are fine


def finite_difference(x: np.ndarray, rate_hz: float, breaks: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """Central differences (the naive baseline). [m/s, m/s²]"""
    dt = 1.0 / rate_hz
    v = np.gradient(x, dt)
    return v, np.gradient(v, dt)


METHODS: dict[str, Callable[..., tuple[np.ndarray, np.ndarray]]] = {
    "savgol": savgol,
    "spline": spline,
    "lsq_spline": lsq_spline,
    "fd": finite_difference,
}
"""Derivative methods by name."""

DEFAULT_METHOD = "spline"
"""Lowest error on simulated runs (``python -m bench.bench_derivatives``: 6 shots × 4 encoder phases, each
method called as the pipeline calls it, breaks at the detected events).  Smoothing spline (budget
:data:`SMOOTHING`): acceleration error 5.0 m/s² median, 30 m/s² worst over the penetration window
(0.15 % / 0.73 % of peak resistance once × m_lc), 0.7 / 2.4 m/s² in flight.  Least-squares spline with knots
at the events: 30 / 138 m/s²; Savitzky–Golay (1.5 ms): 103 / 200 m/s²; central differences 25,000 m/s².
With a budget of exactly one quantisation variance the smoothing spline failed on some phases (390 m/s²
worst).  Errors gather in the first and last few samples of the window, hence the analysis window's inner
limits (:data:`pencli.filter.tare.WINDOW_TRIM_S`)."""

CORNER_METHOD = "lsq_spline"
"""The method for a run whose resistance has a corner inside its motion (a cone's shoulder, a taper's end), joined
there (:func:`pencli.filter.inertia.method_for`).  ``python -m bench.bench_derivatives --cones`` (9 cones × 4
encoder phases, MPACS C): force error m_lc·(a − a_true) inside the fit's rows (2 ms after contact to 3 ms before
the stop), RMS over the peak resistance — smoothing spline 0.68 %, least-squares spline 0.37 %, joined at the
shoulder 0.17 %; 0–0.5 ms after contact 6.2 %, 2.4 %, 0.84 %.  Over a blade's window one quintic meets the
smoothing spline's budget and follows the motion; over a cone's it meets the budget too, but bends through the
shoulder instead of turning there, and a fit of the cone's sidewall pressure (a few per cent of its force) came
out 8 % high from it."""


def derivatives(x: np.ndarray, rate_hz: float, breaks: Sequence[int], method: str = DEFAULT_METHOD, *,
                count_m: float | None = None, joins: Sequence[tuple[float, int]] | None = None,
                at_rest: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Velocity and acceleration of ``x`` sampled at ``rate_hz``, smooth between ``breaks`` (sample indices).

    ``count_m``: the encoder step the smoothing spline smooths for (default: read from ``x``). [m]
    ``joins``: the events as (time since the first sample [s], continuity): 1 where the velocity is
    continuous (release, contact, arrest), 0 where it jumps (the hard stops); the least-squares spline
    puts its joins there (default: at ``breaks``, velocity continuous).
    ``at_rest``: where the blade is at rest (a mask of ``x``'s samples, :func:`pencli.filter.inertia.rest_mask`):
    velocity and acceleration are zero there, and the smoothing spline does not fit a segment wholly inside it.
    """
    fn = METHODS.get(method)
    if fn is None:
        raise DataError(f"unknown derivative method {method!r}; methods: {', '.join(METHODS)}")
    x = np.asarray(x, dtype=float)
    if method == "spline":
        v, a = fn(x, rate_hz, breaks, encoder_step_m(x) if count_m is None else count_m, at_rest)
    elif method == "lsq_spline" and joins is not None:
        v, a = fn(x, rate_hz, breaks, break_times=[(float(t), int(c)) for t, c in joins])
    else:
        v, a = fn(x, rate_hz, breaks)
    if at_rest is None:
        return v, a
    still = at_rest if v.ndim == 1 else at_rest[:, None]
    return np.where(still, 0.0, v), np.where(still, 0.0, a)
