"""Does a null campaign's verdict depend on where its encoder's counts fall?  One development null, its
shared encoder phase scanned.

Run: python -m bench.bench_null_phase N SEED INDEX [PHASES...]   (default phases 0, 0.1, ..., 0.9)

Null ``INDEX`` of ``pencli.testing.campaigns.varied_campaigns(N, SEED, only="nulls")`` is fired again with every shot's
encoder phase (where the blade rests within one count) set to each value in turn, all else as drawn; each
time the diagnosis scores the families on the data and on its 200 replicates.  The replicates shift the
phase of every run by one random amount, so if they are the data's null, the data's rank among them
(replicates at least as high) is uniform over the phases the rig could have rested at: about 5.5 % of
phases at rank <= 10 of 200.  Printed per phase: each family's rank; then per family, how many phases
ranked <= 10.  The sensor lag was found at rank <= 10 on 4 of the 10 default phases of
dev null 25 of 40 at seed 124000, and of null 34.  Tuned on: this is the development world.
"""

from __future__ import annotations

import sys

import numpy as np

from pencli.testing.options import check_options
from bench.bench_diagnose import run_one
from bench.bench_null_ranks import FAMILIES, data_ranks, record_ranks
from pencli.testing.campaigns import varied_campaigns


def main(count: int, seed: int, index: int, phases: list[float]) -> None:
    seen = record_ranks()
    label, material, effects, _, nuisances = varied_campaigns(count, seed, only="nulls")[index]
    drawn = nuisances.get("encoder_phase", [0.0])
    print(f"{label} of --nulls {count} {seed}: drawn phases {np.round(drawn, 3)}")
    print("phase  verdict                  " + " ".join(f"{n[:8]:>8s}" for n in FAMILIES))
    ranks = []
    for phase in phases:
        seen.clear()
        result, _ = run_one(label, material, effects, seed + index, {**nuisances, "encoder_phase": [phase] * len(drawn)})
        ranks.append(data_ranks(seen[0]))
        print(f"{phase:5.2f}  {result.verdict:24s} " + " ".join(f"{r:8d}" for r in ranks[-1]), flush=True)
    ranks = np.array(ranks)
    b = len(seen[0]["replicate_z"][0])
    print(f"\nphases at rank <= 10 of {b} (expected {11 / (b + 1):.1%} of {len(phases)}):")
    for j, name in enumerate(FAMILIES):
        print(f"  {name:26s} {int((ranks[:, j] <= 10).sum())} of {len(phases)}   median rank {np.median(ranks[:, j]):.0f}")


if __name__ == "__main__":
    check_options(__doc__, ())
    args = sys.argv[1:]
    grid = [float(a) for a in args[3:]] or [k / 10 for k in range(10)]
    main(int(args[0]), int(args[1]), int(args[2]), grid)
