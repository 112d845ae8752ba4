"""How well the bed and the probe's drag are fitted across simulated free-fall drops.

Run: python -m bench.bench_freefall_fit [--seeds START END]

Each seed draws a bed (σ 10-40 kPa, b 0-300 kPa/m, c 0-30 kPa·s/m) and a probe in the water (drag coefficient
0.5-1.2, added-mass coefficient 0.1-0.8) and drops the simulated BlueDrop (:mod:`pencli.acquire.freefall`) from
0.5, 1, 3 and 8 m, each of its accelerometers with its own bias within ±0.03 g; the drops are written as
BlueDrop records, read, integrated and fitted (:func:`pencli.fit.freefall.fit_bed`) twice: with the probe's
coefficients wrongly taken as 0.8 and 0.3, and with them fitted as nuisances.  Prints each bed's relative errors
and, at the end, the largest and the median error of σ, b and c for both, and how many beds have all three
within 3 %.  Seeds START to END (default 1000-1020, the hold-out range; 0-6 is the range the fit was made on).
"""

from __future__ import annotations

import statistics
import sys

import numpy as np

from pencli.testing.options import check_options

HEIGHTS_M = (0.5, 1.0, 3.0, 8.0)


def _errors(seed: int) -> dict[str, list[float]]:
    from pencli.acquire.freefall import Bed, Probe
    from pencli.fit.freefall import FreeFallProbe, fit_bed
    from pencli.testing.drops import drops_into

    rng = np.random.default_rng(seed)
    probe = Probe(drag_coefficient=float(rng.uniform(0.5, 1.2)), added_mass_coefficient=float(rng.uniform(0.1, 0.8)))
    bed = Bed(float(rng.uniform(10, 40)), float(rng.uniform(0, 300)), float(rng.uniform(0, 30)))
    readings = [reading for _, _, reading in drops_into(probe, bed, HEIGHTS_M, rng, seed)]
    guess = FreeFallProbe(probe.mass_kg, probe.volume_m3, probe.half_angle_rad, probe.shaft_radius_m, 0.8, 0.3)
    truth = (bed.strength_kpa, bed.gradient_kpa_m, bed.damping_kpa_s_m)
    out = {}
    for label, nuisances in (("held", False), ("fitted", True)):
        fit = fit_bed(readings, guess, nuisances=nuisances)
        got = (fit.strength_kpa, fit.gradient_kpa_m, fit.damping_kpa_s_m)
        out[label] = [100.0 * (g - t) / t for g, t in zip(got, truth)]
        if nuisances:
            out["drag"] = [100.0 * (fit.drag_coefficient / probe.drag_coefficient - 1),
                           100.0 * (fit.added_mass_coefficient / probe.added_mass_coefficient - 1)]
    return out


def main() -> None:
    check_options(__doc__, ("--seeds",))
    args = sys.argv[1:]
    start, end = (int(v) for v in args[args.index("--seeds") + 1:args.index("--seeds") + 3]) \
        if "--seeds" in args else (1000, 1020)
    rows = []
    for seed in range(start, end):
        errors = _errors(seed)
        rows.append(errors)
        print(f"seed {seed}: drag held σ {errors['held'][0]:+.2f} % b {errors['held'][1]:+.2f} % c "
              f"{errors['held'][2]:+.2f} %; fitted σ {errors['fitted'][0]:+.2f} % b {errors['fitted'][1]:+.2f} % "
              f"c {errors['fitted'][2]:+.2f} % (C_D {errors['drag'][0]:+.2f} %, C_a {errors['drag'][1]:+.2f} %)",
              flush=True)
    for label in ("held", "fitted"):
        worst = [max(abs(r[label][k]) for r in rows) for k in range(3)]
        median = [statistics.median(abs(r[label][k]) for r in rows) for k in range(3)]
        within = sum(all(abs(e) <= 3.0 for e in r[label]) for r in rows)
        print(f"drag and added mass {label}: largest |error| σ {worst[0]:.2f} %, b {worst[1]:.2f} %, c "
              f"{worst[2]:.2f} %; median {median[0]:.2f} / {median[1]:.2f} / {median[2]:.2f} %; all three within "
              f"3 % on {within} of {len(rows)} beds")


if __name__ == "__main__":
    main()
