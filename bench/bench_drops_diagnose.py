"""How often `pen drops diagnose` names a hidden layer and a hidden accelerometer bias, and calls nothing in a bed
without either.

Run: python -m bench.bench_drops_diagnose [--seeds START END]

Each seed draws a bed (σ 10-40 kPa, b 0-300 kPa/m, c 0-30 kPa·s/m), a probe in the water (drag coefficient
0.5-1.2, added mass 0.1-0.8) and a layer 130-220 mm into the bed where q rises or falls by 25-60 % of its value
there, and drops the simulated BlueDrop (:mod:`pencli.acquire.freefall`) from 0.5, 1, 3 and 8 m into the bed
with the layer and into the same bed without it, each accelerometer with its own bias within ±0.03 g.  The
drops are read, integrated and diagnosed (the probe's drag and added mass fitted, 199 rotations, a 1 %
false-alarm rate).  A layer is *met* when at least two drops go 10 mm past it (fewer: no method can tell it from
one drop's own misfit) and *found* when the verdict is ``layer`` within 10 mm of its depth.  Two more worlds
per seed, into the bed without the layer: *shifted*, each accelerometer's bias shifting at the impact by
0.005-0.03 g of either sign (a shock's zero offset, which the rests before and after cannot show), found when
the verdict is ``accelerometer_bias``; and *drifting*, each bias drifting in time by up to ±0.002 g/s (which
the pipeline takes out between the rests), a null; and *leaning*, each drop coming to rest leaning by up to
15° towards a random side (its axial sensors then read cos θ of gravity; pen reads the lean from the tilt
channels), a null.  Prints a row per seed, then the layers found among those met, the shifts found, and the
nulls (plain, drifting and leaning) called.  Seeds START to END (default 8001-8021, unused; 0-6 is the range
the diagnosis was made on, 1000-1019, 4000-4019, 5000-5019, 6000-6019 and 7000-7020 have been run and looked at).
"""

from __future__ import annotations

import sys

import numpy as np

from pencli.testing.options import check_options

HEIGHTS_M = (0.5, 1.0, 3.0, 8.0)
FOUND_WITHIN_M = 0.010


def _drops(seed: int, layered: bool, **sensors):
    from pencli import api
    from pencli.acquire.freefall import Bed, Probe
    from pencli.testing.drops import drops_into

    rng = np.random.default_rng(seed)
    probe = Probe(drag_coefficient=float(rng.uniform(0.5, 1.2)), added_mass_coefficient=float(rng.uniform(0.1, 0.8)))
    sigma, gradient, damping = float(rng.uniform(10, 40)), float(rng.uniform(0, 300)), float(rng.uniform(0, 30))
    depth = float(rng.uniform(0.13, 0.22))
    step = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.25, 0.6) * (sigma + gradient * depth))
    bed = Bed(sigma, gradient, damping, depth, step) if layered else Bed(sigma, gradient, damping)
    made = drops_into(probe, bed, HEIGHTS_M, rng, seed, **sensors)
    past = sum(truth.penetration_m > depth + FOUND_WITHIN_M for truth, _, _ in made)
    return [api.Drop(record, reading) for _, record, reading in made], bed, past >= 2


def main() -> None:
    check_options(__doc__, ("--seeds",))
    from pencli import api
    from pencli.acquire.freefall import Probe
    from pencli.fit.freefall import FreeFallProbe

    args = sys.argv[1:]
    start, end = (int(v) for v in args[args.index("--seeds") + 1:args.index("--seeds") + 3]) \
        if "--seeds" in args else (8001, 8021)
    truth_probe = Probe()
    guess = FreeFallProbe(truth_probe.mass_kg, truth_probe.volume_m3, truth_probe.half_angle_rad,
                          truth_probe.shaft_radius_m, 0.8, 0.3)
    found = called = met = found_unmet = shifts = drifts = leans = 0
    for seed in range(start, end):
        drops, bed, reached = _drops(seed, True)
        layer = api.diagnose_drops(drops, guess)
        hit = layer.verdict == "layer" and abs(layer.layer_depth_m - bed.layer_depth_m) <= FOUND_WITHIN_M
        met += reached
        found += hit and reached
        found_unmet += hit and not reached
        drops, _, _ = _drops(seed, False)
        null = api.diagnose_drops(drops, guess)
        called += null.verdict != "none"
        shifted = api.diagnose_drops(_drops(seed, False, impact_shift_g=(0.005, 0.03))[0], guess)
        shifts += shifted.verdict == "accelerometer_bias"
        drifting = api.diagnose_drops(_drops(seed, False, drift_g_per_s=0.002)[0], guess)
        drifts += drifting.verdict != "none"
        leaning = api.diagnose_drops(_drops(seed, False, rest_tilt_deg=15.0)[0], guess)
        leans += leaning.verdict != "none"
        print(f"seed {seed}: layer {1e3 * bed.layer_depth_m:.0f} mm {bed.layer_step_kpa:+.1f} kPa -> {layer.verdict} "
              f"{1e3 * layer.layer_depth_m:.0f} mm {layer.layer_step_kpa:+.1f} kPa (p {layer.p_value:.3f}, share "
              f"{layer.share:.2f}){' FOUND' if hit else ''}{'' if reached else ' (met by fewer than two drops)'}; "
              f"null -> {null.verdict} (p {null.p_value:.3f}, share {null.share:.2f}); shifted -> {shifted.verdict}; "
              f"drifting -> {drifting.verdict}; leaning -> {leaning.verdict}", flush=True)
    total = end - start
    print(f"layers met by two drops or more: found {found} of {met}; of the {total - met} others, found "
          f"{found_unmet}; hidden shifts found {shifts} of {total}; nulls called {called} of {total}, drifting nulls "
          f"called {drifts} of {total}, leaning nulls called {leans} of {total}")


if __name__ == "__main__":
    main()
