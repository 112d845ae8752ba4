"""The rate of a constant-rate push (a CPT or total sounding) from its depth and time records."""

from __future__ import annotations

import numpy as np

PAUSE_FACTOR = 5.0
"""A step that takes this many times the sounding's median step time is a pause (the rig stops to add a rod every
metre or so): spans across it are not a rate."""

MIN_ROWS = 5
"""Rows a stretch between pauses needs for its rate to be read."""


def push_rate_mm_s(depth_m: np.ndarray, time_s: np.ndarray) -> float:
    """The sounding's rate: the rows split at each pause (:data:`PAUSE_FACTOR`), each stretch's rate the
    least-squares slope of depth on time, and the median of the stretches' rates. NaN where no stretch has
    :data:`MIN_ROWS` rows. [mm/s]

    A slope over the whole stretch, not a rate per step: a logger that stamps its rows in bursts (several rows
    with one time) makes step rates jump between zero and several times the push's.  ``depth_m`` does not
    decrease; ``time_s`` is the row's time (any origin).
    """
    d = np.asarray(depth_m, dtype=float)
    t = np.asarray(time_s, dtype=float)
    ok = np.isfinite(d) & np.isfinite(t)
    d, t = d[ok], t[ok]
    if d.size < MIN_ROWS:
        return float("nan")
    dt = np.diff(t)
    moving = dt[dt > 0]
    if moving.size == 0:
        return float("nan")
    cuts = np.flatnonzero(dt > PAUSE_FACTOR * np.median(moving)) + 1  # a stretch starts after each pause
    rates = []
    for lo, hi in zip(np.r_[0, cuts], np.r_[cuts, d.size]):
        if hi - lo < MIN_ROWS:
            continue
        tt, dd = t[lo:hi] - t[lo:hi].mean(), d[lo:hi] - d[lo:hi].mean()
        spread = float(tt @ tt)
        if spread > 0:
            rates.append(float(tt @ dd) / spread)
    return float(np.median(rates) * 1e3) if rates else float("nan")
