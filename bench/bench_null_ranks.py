"""Are development nulls exchangeable with their own null replicates?  The rank of the data among them.

Run: python -m bench.bench_null_ranks N SEED [--out FILE.jsonl] [any of bench_diagnose's redraw flags, e.g.
     --few-coloured --unknown-material]

For each of N null campaigns of the development world (``pencli.testing.campaigns.varied_campaigns``, nulls only,
every nuisance varied), the diagnosis scores every effect family on the data and on its 60 replicates.  If
the replicates are the data's null, the data's standardised improvement of each family is one more draw of
the replicates' (each replicate standardised by the others, as the family-wise threshold does), and its rank
among them is uniform: beaten by k of the B replicates with probability 1/(B+1) for each k.  Printed per
family: the median rank (B/2 expected) and how often 2 or fewer replicates beat the data (3/(B+1) of the
campaigns expected); and for the largest z over the families, which decides, how often 1 or fewer beat
it (2/(B+1) expected).  A family whose data rank sits low is one whose null the replicates miss, whatever
the threshold; this is how the sub-sample contact ("Null replicates meet the material between
samples") was found.  Tuned on: this is the development world.
"""

from __future__ import annotations

import json
import statistics
import sys
from pathlib import Path

import numpy as np

from pencli.testing.options import check_options
from bench.bench_diagnose import REDRAWS, run_one
from pencli.diagnose import engine
from pencli.testing.campaigns import varied_campaigns


FAMILIES = [n for n, e in engine.EFFECTS.items() if e.side != "drive"]
"""The effect families whose standardised improvements the family-wise threshold sees, in its order."""


def record_ranks() -> list[dict]:
    """Make every diagnosis append, at its family-wise threshold, each family's data z and replicate z's to
    the returned list (one dict per diagnosis; the probes' call, with 2 columns, is left out)."""
    seen: list[dict] = []
    threshold = engine.familywise_threshold

    def recording(improvements, floor, alpha):
        if improvements.shape[1] > len(engine.PROBES):
            seen.append({"data_z": [engine._standardise(column, floor)[0] for column in improvements.T],
                         "replicate_z": engine.replicate_z(improvements, floor).tolist()})
        return threshold(improvements, floor, alpha)

    engine.familywise_threshold = recording
    return seen


def data_ranks(record: dict) -> np.ndarray:
    """Per family, how many replicates' z reach the data's."""
    data, reps = np.array(record["data_z"]), np.array(record["replicate_z"])
    return (reps >= data[:, None]).sum(axis=1)


def main(count: int, seed: int, out: Path | None, flags: tuple[str, ...] = ()) -> None:
    seen = record_ranks()
    ranks, top_ranks = [], []
    campaigns = varied_campaigns(count, seed, only="nulls")
    for flag, redraw in REDRAWS.items():  # in bench_diagnose's order
        if flag in flags:
            campaigns = redraw(campaigns, seed)
    for i, (label, material, effects, _, nuisances) in enumerate(campaigns):
        seen.clear()
        result, seconds = run_one(label, material, effects, seed + i, nuisances)
        data, reps = np.array(seen[0]["data_z"]), np.array(seen[0]["replicate_z"])
        rank = data_ranks(seen[0])
        top = int((reps.max(axis=0) >= data.max()).sum())
        ranks.append(rank)
        top_ranks.append(top)
        print(f"{label:10s} verdict={result.verdict:24s} largest z {data.max():6.2f} beaten by {top:2d} of "
              f"{reps.shape[1]} replicates ({FAMILIES[int(data.argmax())]}) {seconds:.1f}s", flush=True)
        if out is not None:
            with out.open("a") as f:
                f.write(json.dumps({"label": label, "verdict": result.verdict, "names": FAMILIES, **seen[0]}) + "\n")
    ranks = np.array(ranks)
    n = len(top_ranks)
    b = len(seen[0]["replicate_z"][0]) if seen else 0
    print(f"\n{n} development nulls (tuned on) {' '.join(flags)}, {b} replicates each; expected: median rank "
          f"{b / 2:.0f}, rank <= 2 in {3 * n / (b + 1):.1f}, largest z beaten by <= 1 in {2 * n / (b + 1):.1f}")
    print(f"largest z beaten by <= 1 replicate: {sum(r <= 1 for r in top_ranks)} of {n}; by <= 10: "
          f"{sum(r <= 10 for r in top_ranks)} ({11 * n / (b + 1):.1f} expected)")
    for j, name in enumerate(FAMILIES):
        print(f"  {name:26s} median rank {statistics.median(ranks[:, j]):4.0f}   rank <= 2: {int((ranks[:, j] <= 2).sum())}"
              f"   rank <= 10: {int((ranks[:, j] <= 10).sum())}")


if __name__ == "__main__":
    check_options(__doc__, ("--out", *REDRAWS))
    args = sys.argv[1:]
    target = Path(args[args.index("--out") + 1]) if "--out" in args else None
    main(int(args[0]) if args else 30, int(args[1]) if len(args) > 1 else 43000, target,
         tuple(a for a in args if a in REDRAWS))
