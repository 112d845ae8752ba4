"""How well a sounding's layers are found, and a rate effect fitted on them, on the simulated constant-rate cone.

Run: python -m bench.bench_layers [--seeds START END] [--tolerance M] [--rates K]

Layered grounds: ``random_layers`` (1 to 6 layers at least 0.8 m thick, steps of 1.5-6x, gradients) from seeds
START to END (default 1000-1100, the hold-out range; 0-60 is the range the method was made on), noise 1-6 %,
pushed at 10, 20 or 40 mm/s; a boundary is found when the cut puts one within the tolerance (default 0.15 m).
Nulls: one layer with a gradient from the same seeds.  Prints the boundaries found, those invented and the
nulls cut, and the cut's median time.  With ``--rates K``, also six soundings of each of the first six grounds
at 5-65 mm/s with a rate effect of K per decade, the units the 20 mm/s sounding's layers: the K fitted.
"""

from __future__ import annotations

import statistics
import sys
import tempfile
import time
from pathlib import Path


from pencli.testing.options import check_options


def _value(args: list[str], option: str, count: int = 1):
    i = args.index(option)
    return args[i + 1:i + 1 + count]


def _rate(seed: int, per_decade: float) -> float:
    from pencli import api
    from pencli.testing.soundings import six_rate_site

    with tempfile.TemporaryDirectory() as tmp:
        return api.fit_soundings(six_rate_site(Path(tmp), seed, per_decade), "sim").per_decade


def main() -> None:
    check_options(__doc__, ("--seeds", "--tolerance", "--rates"))
    args = sys.argv[1:]
    start, end = (int(v) for v in _value(args, "--seeds", 2)) if "--seeds" in args else (1000, 1100)
    tolerance = float(_value(args, "--tolerance")[0]) if "--tolerance" in args else 0.15
    from pencli.fit.layers import detect_layers
    from pencli.testing.soundings import random_sounding

    found = true = invented = reported = cut_nulls = 0
    times = []
    for seed in range(start, end):
        truth, depth, qt = random_sounding(seed)
        began = time.perf_counter()
        got = detect_layers(depth, qt).boundaries_m
        times.append(time.perf_counter() - began)
        found += sum(any(abs(g - b) <= tolerance for g in got) for b in truth)
        invented += sum(not any(abs(g - b) <= tolerance for b in truth) for g in got)
        true, reported = true + len(truth), reported + len(got)
        cut_nulls += len(detect_layers(*random_sounding(seed, layered=False)[1:]).layers) > 1
    print(f"seeds {start}-{end - 1}: {found} of {true} boundaries found within {tolerance:g} m, {invented} of "
          f"{reported} reported invented; {cut_nulls} of {end - start} single layers cut; the cut takes "
          f"{statistics.median(times) * 1e3:.0f} ms (median)")
    if "--rates" in args:
        per_decade = float(_value(args, "--rates")[0])
        fitted = [_rate(seed, per_decade) for seed in range(start, start + 6)]
        worst = max(abs(k - per_decade) for k in fitted) / abs(per_decade) if per_decade else max(map(abs, fitted))
        print(f"rate effect {per_decade:+g} per decade from six soundings at 5-65 mm/s on grounds {start}-{start + 5}: "
              + ", ".join(f"{k:+.4f}" for k in fitted) + f" (worst {100 * worst:.1f} %)")


if __name__ == "__main__":
    main()
