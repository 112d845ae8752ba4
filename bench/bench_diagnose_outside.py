"""Effects outside the catalogue, on the hold-out world (never tuned on): how often the diagnosis says
``unexplained``, beside the catalogue effects and nulls of the same world.

Run: python -m bench.bench_diagnose_outside [--base SEED] [--seeds N] [--jobs J] [--no-catalogue]

Campaigns, all from ``pencli/testing/holdout_world.py``:

- every outside kind (``OUTSIDE_KINDS``: periodic in depth, intermittent and one-sided, following the time in
  the material, following the force itself, differing from run to run) at intensities 0.5, 1 and 2, ``N``
  seeds each (default 2);
- every catalogue effect once at intensity 1 and six nulls (unless ``--no-catalogue``), so that a rule that
  calls more ``unexplained`` shows what it costs the effects pen does model.

Prints one row per campaign in ``bench.compare_verdicts``'s form (right: ``unexplained`` for an outside kind,
the effect first among the verdict's effects for a catalogue effect, ``none`` for a null), the best catalogue
candidate and its share of the misfit's excess over the null floor, then the rates.  Run it at two commits and
compare the outputs with ``python -m bench.compare_verdicts BEFORE AFTER`` for the before and after.
"""

from __future__ import annotations

import statistics
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from pencli.testing.options import check_options

SIZES = (0.5, 1.0, 2.0)
NULLS = 4


def one(job: tuple[str, int, tuple[str, ...], float]) -> tuple[str, str, str, bool, str, float]:
    """Diagnose one hold-out campaign: (label, truth, verdict, right, best candidate and share, seconds)."""
    from pencli.testing import holdout_world
    from pencli.testing.campaigns import diagnose_folders

    label, seed, effects, intensity = job
    with tempfile.TemporaryDirectory() as tmp:
        campaign = holdout_world.make_campaign(Path(tmp), seed, effects, intensity=intensity)
        result, seconds, _ = diagnose_folders(campaign.folders, Path(tmp) / "runs.duckdb")
    outside = bool(effects) and effects[0] in holdout_world.OUTSIDE_KINDS
    if outside:
        right = result.verdict == "unexplained"
    elif effects:
        right = bool(result.verdict_effects) and result.verdict_effects[0] == effects[0]
    else:
        right = result.verdict == "none"
    best = next((e for e in result.effects if e.view == "resistance"), None)
    share = getattr(best, "explained_share", None) if best else None
    candidate = f"{best.name}:{share:.2f}" if best is not None and share is not None else "-"
    return label, "+".join(effects) or "none", result.verdict, right, candidate, seconds


def jobs_of(base: int, seeds: int, catalogue: bool) -> list[tuple[str, int, tuple[str, ...], float]]:
    from pencli.testing import holdout_world

    jobs = []
    for k, kind in enumerate(holdout_world.OUTSIDE_KINDS):
        for s, size in enumerate(SIZES):
            for j in range(seeds):
                seed = base + 1000 * k + 100 * s + j
                jobs.append((f"{kind[:12]}-x{size:g}-{seed}", seed, (kind,), size))
    if catalogue:
        for k, name in enumerate(holdout_world.CATALOGUE):
            seed = base + 50_000 + k
            jobs.append((f"{name[:12]}-{seed}", seed, (name,), 1.0))
        for k in range(NULLS):
            seed = base + 60_000 + k
            jobs.append((f"null-{seed}", seed, (), 1.0))
    return jobs


def main(argv: list[str]) -> None:
    check_options(__doc__, ("--base", "--seeds", "--jobs", "--no-catalogue"), argv)

    def value(flag: str, default: int) -> int:
        return int(argv[argv.index(flag) + 1]) if flag in argv else default

    base, seeds, workers = value("--base", 770_000), value("--seeds", 2), value("--jobs", 1)
    jobs = jobs_of(base, seeds, "--no-catalogue" not in argv)
    rows = []
    with ProcessPoolExecutor(workers) as pool:
        for label, truth, verdict, right, candidate, seconds in pool.map(one, jobs):
            rows.append((label, truth, verdict, right, seconds))
            print(f"{label:28s} truth={truth:45s} verdict={verdict:25s} {'OK ' if right else 'MISS'} "
                  f"best={candidate:32s} {seconds:.1f}s", flush=True)
    from pencli.testing import holdout_world

    print()
    for size in SIZES:
        mine = [r for r in rows if r[1] in holdout_world.OUTSIDE_KINDS and f"-x{size:g}-" in r[0]]
        print(f"outside kinds at intensity {size:g}: unexplained {sum(r[3] for r in mine)}/{len(mine)}")
    outside = [r for r in rows if r[1] in holdout_world.OUTSIDE_KINDS]
    print(f"outside kinds, all sizes: unexplained {sum(r[3] for r in outside)}/{len(outside)}")
    effects = [r for r in rows if r[1] in holdout_world.CATALOGUE]
    nulls = [r for r in rows if r[1] == "none"]
    if effects:
        print(f"catalogue effects named first: {sum(r[3] for r in effects)}/{len(effects)}")
        print(f"nulls called none: {sum(r[3] for r in nulls)}/{len(nulls)}")
    print(f"median diagnosis time: {statistics.median(r[4] for r in rows):.1f} s ({workers} at a time)")


if __name__ == "__main__":
    main(sys.argv[1:])
