"""The smoothing spline's derivatives of many records at once (the null replicates' path) against the spline itself
on each record alone."""

from __future__ import annotations

import numpy as np

from pencli.filter.derivatives import spline, spline_columns

RATE_HZ = 30000.0
COUNT_M = 0.16e-3


def _quantised(position_m: np.ndarray, phase: float) -> np.ndarray:
    """An encoder's reading of ``position_m``: whole counts, its edges ``phase`` of a count off the rest. [m]"""
    return np.floor(position_m / COUNT_M + phase) * COUNT_M


def test_many_records_at_once_give_what_the_spline_gives_each_alone():
    """Records of one motion's breaks: a decelerating motion read at six encoder phases (one quintic meets the
    budget: the batched path), the same with a strength step halfway through that doubles its deceleration (the
    spline needs knots: each goes through the spline alone), and a record resting on an edge (no motion).  Every
    column's acceleration equals the spline's on that column alone, within 1e-9 of the largest."""
    t = np.arange(1800) / RATE_HZ
    start, stop = 300, 1500  # the segment between two breaks, the blade at rest outside it
    s = np.clip(t - t[start], 0.0, t[stop] - t[start])
    smooth = 6.0 * s - 0.5 * 380.0 * s ** 2 + 2e3 * s ** 3
    kink = t[900] - t[start]
    stepped = smooth - 0.5 * 380.0 * np.clip(s - kink, 0.0, None) ** 2
    columns = [_quantised(smooth, p) for p in (0.5, 0.1, 0.35, 0.8, 0.2, 0.65)]
    columns += [_quantised(stepped, p) for p in (0.5, 0.3)]
    columns.append(_quantised(np.full(t.size, 0.08e-3), 0.49) + COUNT_M * (np.arange(t.size) % 7 == 0))
    x = np.column_stack(columns)
    breaks = [start, stop]
    together = spline_columns(x, RATE_HZ, breaks, COUNT_M)
    alone = np.column_stack([spline(x[:, j], RATE_HZ, breaks, COUNT_M)[1] for j in range(x.shape[1])])
    scale = float(np.max(np.abs(alone)))
    assert scale > 300.0 and np.all(alone[:, -1] == 0.0)
    np.testing.assert_allclose(together, alone, rtol=0.0, atol=1e-9 * scale)
    # the stepped records are where one quintic would not do: it misses their deceleration by far more
    coef = np.polyfit(t[start:stop] - t[start], x[start:stop, 6], 5)
    one_quintic = np.polyval(np.polyder(coef, 2), t[start:stop] - t[start])
    assert np.max(np.abs(one_quintic - alone[start:stop, 6])) > 10.0
