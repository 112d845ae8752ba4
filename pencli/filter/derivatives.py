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

import warnings
from typing import Callable, Sequence

import numpy as np
from scipy.signal import savgol_filter

from pencli.errors import DataError


def _segments(n: int, breaks: Sequence[int]) -> list[tuple[int, int]]:
    edges = sorted({0, n, *[int(b) for b in breaks if 0 < b < n]})
    return [(a, b) for a, b in zip(edges[:-1], edges[1:]) if b > a]


def savgol(x: np.ndarray, rate_hz: float, breaks: Sequence[int], window_s: float = 1.5e-3, order: int = 3
           ) -> tuple[np.ndarray, np.ndarray]:
    """Savitzky–Golay local cubic fits, window ``window_s``, per segment. [m/s, m/s²]"""
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


def spline(x: np.ndarray, rate_hz: float, breaks: Sequence[int], count_m: float = 0.16e-3
           ) -> tuple[np.ndarray, np.ndarray]:
    """Quintic smoothing spline per segment, smoothing set by the quantisation noise. [m/s, m/s²]"""
    from scipy.interpolate import make_splrep

    v = np.zeros_like(x)
    a = np.zeros_like(x)
    t = np.arange(x.size) / rate_hz
    sigma = count_m / np.sqrt(12.0)
    for lo, hi in _segments(x.size, breaks):
        n = hi - lo
        if n < 8:
            if n >= 3:
                v[lo:hi] = np.gradient(x[lo:hi], t[lo:hi])
                a[lo:hi] = np.gradient(v[lo:hi], t[lo:hi])
            continue
        with warnings.catch_warnings():
            # FITPACK may return its closest approximation when s is tight for quantised data; that is fine here
            warnings.simplefilter("ignore", RuntimeWarning)
            spl = make_splrep(t[lo:hi], x[lo:hi], k=5, s=n * sigma ** 2)
        v[lo:hi] = spl(t[lo:hi], 1)
        a[lo:hi] = spl(t[lo:hi], 2)
    return v, a


def lsq_spline(x: np.ndarray, rate_hz: float, breaks: Sequence[int], *, t0: float = 0.0,
               break_times: Sequence[tuple[float, int]] | None = None, knot_s: float = 3e-3,
               rest_knot_s: float = 5e-3) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares quintic spline over the whole record, with knots at the events. [m/s, m/s²]

    ``break_times`` are (time [s], continuity) pairs: continuity 1 keeps position
    and velocity continuous there (contact, arrest: the acceleration jumps),
    0 keeps only position (the hard stops: the velocity jumps).  Without them,
    the sample indices in ``breaks`` are used with continuity 1.  Knots are
    ``knot_s`` apart while moving and ``rest_knot_s`` apart before the first
    and after the last break.
    """
    from scipy.interpolate import make_lsq_spline

    k = 5
    t = t0 + np.arange(x.size) / rate_hz
    if break_times is None:
        break_times = [(float(t[int(b)]), 1) for b in breaks if 0 < b < x.size]
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
"""Lowest error on simulated runs (bench/bench_derivatives.py, medians over 6 shots over the whole
contact-to-stop window, edges included): smoothing spline 24 m/s² RMS acceleration error (0.6 % of peak
resistance once × m_lc); least-squares spline with knots at the events 25 m/s² at its best knot spacing
(3 ms); Savitzky–Golay (1.5 ms) 122 m/s² (4.2 %); central differences 25,000 m/s².  Every method's error
gathers in the first and last few samples of the window, hence the analysis window's inner limits
(:data:`pencli.filter.tare.WINDOW_TRIM_S`)."""


def derivatives(x: np.ndarray, rate_hz: float, breaks: Sequence[int], method: str = DEFAULT_METHOD
                ) -> tuple[np.ndarray, np.ndarray]:
    """Velocity and acceleration of ``x`` sampled at ``rate_hz``, smooth between ``breaks`` (sample indices)."""
    fn = METHODS.get(method)
    if fn is None:
        raise DataError(f"unknown derivative method {method!r}; methods: {', '.join(METHODS)}")
    return fn(np.asarray(x, dtype=float), rate_hz, breaks)
