"""How well is the anti-alias filter read from a run's pre-trigger noise?  Records from the simulated rig with
drawn noise and filters, each read by ``fit_anti_alias``.

Run: python -m bench.bench_anti_alias [N [SEED]]   (default 120 records, seed 47000)

Record i's rig is drawn from the stream ``[SEED, i]``: 30 or 60 kHz; white gauge noise 0.5–6 N; half with AR(1)
noise of 0.5–3 N over 0.05–2 ms; half with a converter floor of 2–20 % of the white after the filter; half behind
a Butterworth of order 2–8 with its corner at 0.05–0.4 of the rate (log-uniform), the rest unfiltered; and,
from a second stream ``[SEED, i, 1]`` so that the rest is what it would be without it, half with a narrow band
(the rig's ``resonant_noise_*``) of 0.5–1.5 × the white at 0.005–0.3 of the rate (log-uniform), damping
ratio 0.02–0.3.  Printed: per group (filtered or not, with a band or not), the records read as filtered, those
whose order is within one of the truth and corner within 15 %, and the median and largest time per reading
beside the time of the noise spectrum it reads (``fit_noise``) on the same records.  Tuned on: this is the
development world's rig.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from pencli.testing.options import check_options


def draw_rig(seed: int, i: int) -> dict:
    """Record i's rig (see the module's doc)."""
    own = np.random.default_rng([seed, i])
    rate = float(own.choice([30000.0, 60000.0]))
    white = float(own.uniform(0.5, 6.0))
    rig = {"kind": "rig", "name": "aa", "seed": seed * 1000 + i, "sampling_rate_hz": rate, "force_noise_n": white}
    if own.uniform() < 0.5:
        rig.update(correlated_noise_n=float(own.uniform(0.5, 3.0)), correlated_noise_ms=float(own.uniform(0.05, 2.0)))
    if own.uniform() < 0.5:
        rig["converter_noise_n"] = float(own.uniform(0.02, 0.2)) * white
    if own.uniform() < 0.5:
        rig.update(anti_alias_hz=float(np.exp(own.uniform(np.log(0.05), np.log(0.4)))) * rate,
                   anti_alias_order=int(own.integers(2, 9)))
    band = np.random.default_rng([seed, i, 1])
    if band.uniform() < 0.5:
        rig.update(resonant_noise_n=float(band.uniform(0.5, 1.5)) * white,
                   resonant_noise_hz=float(np.exp(band.uniform(np.log(0.005), np.log(0.3)))) * rate,
                   resonant_noise_damping=float(band.uniform(0.02, 0.3)))
    return rig


def main(count: int, seed: int) -> None:
    from pencli import api
    from pencli.diagnose.null import fit_anti_alias, fit_noise

    groups: dict[tuple[bool, bool], list[int]] = {}
    spent, spectrum = [], []
    for i in range(count):
        rig = draw_rig(seed, i)
        columns = api.acquire(springs=4, penetrator="al6061_1.5mm", material="mpacs_c", rig=rig).run.columns
        before = columns["fz_n"][columns["time_s"] < -0.01]
        start = time.perf_counter()
        noise = fit_noise(before)
        spectrum.append(time.perf_counter() - start)
        start = time.perf_counter()
        found = fit_anti_alias(noise)
        spent.append(time.perf_counter() - start)
        filtered, banded = "anti_alias_hz" in rig, "resonant_noise_n" in rig
        corner = rig.get("anti_alias_hz", 0.0) / rig["sampling_rate_hz"]
        right = (found is None) if not filtered else (
            found is not None and abs(found.order - rig["anti_alias_order"]) <= 1
            and abs(found.corner / corner - 1.0) <= 0.15)
        groups.setdefault((filtered, banded), [0, 0, 0])
        tally = groups[(filtered, banded)]
        tally[0] += 1
        tally[1] += found is not None
        tally[2] += bool(right)
        truth = f"order {rig['anti_alias_order']} at {corner:.3f}" if filtered else "none"
        band = (f" band {rig['resonant_noise_hz'] / rig['sampling_rate_hz']:.3f} "
                f"damping {rig['resonant_noise_damping']:.2f}" if banded else "")
        read = "none" if found is None else f"order {found.order} at {found.corner:.3f}"
        print(f"{i:4d} {truth:18s}{band:28s} read {read:18s} {'ok' if right else 'WRONG'}", flush=True)
    print()
    for (filtered, banded), (n, read, right) in sorted(groups.items()):
        what = ("filtered" if filtered else "unfiltered") + (", with a band" if banded else "")
        print(f"{what:26s} {n:4d} records: read as filtered {read:4d}, right {right:4d}")
    print(f"time per reading: median {np.median(spent):.3f} s, largest {max(spent):.3f} s; "
          f"the spectrum it reads: median {np.median(spectrum):.3f} s")


if __name__ == "__main__":
    check_options(__doc__, ())
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    main(int(args[0]) if args else 120, int(args[1]) if len(args) > 1 else 47000)
