"""Smoothing a run whose rest record flickers over more than one count: with the rest segments skipped, and without.

Run: python -m bench.bench_rest_flicker [--long]

An encoder whose own position error spans three counts at rest (0.08 mm counts, a rest position near an edge,
8.5 µm of white error: the development world's rate_strength-8 of ``--varied 16 255000``) defeats the smoothing
spline's "moving a count at most" test, and FITPACK's knot search then places a knot every few samples: 3,781 knots
and 407 s for one 12,000-sample segment of that run.  ``pencli.filter.derivatives.derivatives`` with ``at_rest``
takes a segment the events put at rest as its mean instead, and the search is bounded (``MAX_KNOTS``) where a
segment is not at rest.  This times the three (skipped; every segment fitted with the bound; every segment fitted
without it) on one synthetic run (a rest record of
N samples at 60 kHz, 25 ms of motion, N more at rest) for N = 1,500, 3,000 and 6,000 (with ``--long`` also 12,000,
which takes minutes unbounded), checks that the motion's derivatives are the same to the bit, and prints the
ratio of unbounded to skipped.  The figures are wall time in one process, after one untimed call (imports).
"""

from __future__ import annotations

import sys
import time

import numpy as np

from pencli.testing.options import check_options
from pencli.filter import derivatives as derivs
from pencli.filter.derivatives import derivatives

RATE_HZ, COUNT_M, MOVING = 60000.0, 0.08e-3, 1500


def record(rest: int, seed: int = 4):
    """Quantised depth [m] and its rest mask: ``rest`` samples flickering over three counts, motion, rest."""
    rng = np.random.default_rng(seed)
    t = np.arange(MOVING) / RATE_HZ
    flight = 0.5 * 4.0 * t ** 2 + 3.0 * t
    start = 0.45 * COUNT_M
    x = np.concatenate([start + 0.35 * COUNT_M * rng.standard_normal(rest), start + flight,
                        start + flight[-1] + 0.35 * COUNT_M * rng.standard_normal(rest)])
    at_rest = np.ones(x.size, dtype=bool)
    at_rest[rest:rest + MOVING] = False
    return np.round(x / COUNT_M) * COUNT_M, at_rest


def main() -> None:
    check_options(__doc__, ("--long",))
    sizes = (1500, 3000, 6000, 12000) if "--long" in sys.argv else (1500, 3000, 6000)
    q, at_rest = record(100)
    derivatives(q, RATE_HZ, [100, 100 + MOVING], "spline", count_m=COUNT_M, at_rest=at_rest)  # imports, warm caches
    print(f"{'rest samples':>12s} {'skipped [s]':>12s} {'capped [s]':>11s} {'unbounded [s]':>14s} "
          f"{'unbounded / skipped':>20s}  motion identical")
    for rest in sizes:
        q, at_rest = record(rest)
        breaks = [rest, rest + MOVING]
        t0 = time.perf_counter()
        v_new, a_new = derivatives(q, RATE_HZ, breaks, "spline", count_m=COUNT_M, at_rest=at_rest)
        t1 = time.perf_counter()
        v_cap, a_cap = derivatives(q, RATE_HZ, breaks, "spline", count_m=COUNT_M)  # every segment fitted, capped
        t2 = time.perf_counter()
        cap, derivs.MAX_KNOTS = derivs.MAX_KNOTS, 10 ** 9  # as before the cap: FITPACK's own bound, n + 6
        try:
            v_old, a_old = derivatives(q, RATE_HZ, breaks, "spline", count_m=COUNT_M)
        finally:
            derivs.MAX_KNOTS = cap
        t3 = time.perf_counter()
        moving = ~at_rest
        same = all(np.array_equal(v_new[moving], v[moving]) and np.array_equal(a_new[moving], a[moving])
                   for v, a in ((v_cap, a_cap), (v_old, a_old)))
        print(f"{rest:12d} {t1 - t0:12.3f} {t2 - t1:11.2f} {t3 - t2:14.2f} {(t3 - t2) / (t1 - t0):19.0f}×  {same}",
              flush=True)


if __name__ == "__main__":
    main()
