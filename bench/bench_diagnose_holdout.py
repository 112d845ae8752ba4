"""The diagnosis measured on the hold-out truth world (pencli/testing/holdout_world.py), which it was never tuned on.

Run: python -m bench.bench_diagnose_holdout [--quick] [--base SEED] [--no-ladder] [--out FILE.jsonl] [--world three]
     [--ladder-only] [--drive N] [--nulls N]

``--world three`` measures on world three (pencli/testing/world_three.py) instead, written by a developer who had not worked
on the method after it was frozen, and drawn once blind: its own pairs, three draws of every effect and three
outside campaigns.  ``--ladder-only`` runs part 3 alone (with the two nulls it is twinned on), so that it can run
beside parts 1-2 in a second process.  ``--drive N`` runs only launcher losses: N campaigns of a propulsion loss
alone (seeds base + 500 + i; every other one cut to 4 runs) and N of a propulsion loss beside a resistance effect
drawn by the seed (seeds base + 600 + i), and prints how many were found by the loss's form and the run count.
``--nulls N`` runs only N campaigns without effect (seeds base + 1000 + i, as part 2's) and prints how many got a
verdict other than ``none``, and which, and how many the run-to-run test (each run's own depth profile) calls a
gap.

Every campaign is written as CONTRACT §3 run folders and goes through
ingest → tare → subtract-inertia → diagnose, as the README says.  Parts:

1. accuracy: 20 null campaigns, every catalogue effect twice (random forms,
   full intensity), 4 two-effect campaigns, 2 outside-catalogue campaigns;
2. false alarms: 40 more nulls (60 in all, every nuisance varied);
3. detection ladder: every effect at five intensities on seeds shared with
   null campaigns, so each campaign has a twin without the effect.  Effect
   size = sqrt(max(S_effect − S_null, 0)) / noise, where S is the baseline's
   held-out mean square: the RMS the effect leaves after the baseline is
   refitted, in units of the campaign's noise.  Detected = the effect is
   significant and first (or among the verdict's effects).

Every effect, pair and outside campaign of part 1 is also run without its effects (its twin: the same seed,
so the same runs, nuisances and noise), which gives its size as in part 3.  The summary prints the verdicts
right both over all those campaigns (the figure the issue's target is set on) and over those whose effects
leave at least :data:`SEEN` × the noise after the baseline refit: a campaign whose effect the baseline absorbs
(a rate strength that only rescales the damping terms) leaves nothing for any method to name.  Propulsion loss
always counts: the resistance view does not see it (its size is ~0), the drive view does.

Prints each campaign, then the figures; ``--out FILE.jsonl`` appends every row as it is made, and
``--summary FILE.jsonl`` prints the figures from such a file again (give it the ``--world`` it was drawn on).
"""

from __future__ import annotations

import json
import math
import statistics
import sys
import tempfile
from pathlib import Path

from pencli.testing.options import check_options
from pencli.testing import holdout_world, world_three
from pencli.testing.campaigns import diagnose_folders

WORLDS = {"holdout": holdout_world, "three": world_three}
"""The truth worlds by ``--world`` name; each declares its CATALOGUE, OUTSIDE effect, PAIRS, DRAWS per effect,
OUTSIDE_DRAWS and TITLE."""
WORLD = holdout_world
CATALOGUE, OUTSIDE = WORLD.CATALOGUE, WORLD.OUTSIDE

LADDER = (0.04, 0.08, 0.16, 0.32, 0.64)
SEEN = 0.5
"""Size (RMS left after the baseline refit / noise) from which a campaign counts in the second accuracy figure;
set before any twin was measured, at the lower edge of the ladder's bin where detection starts."""
SIZE_BINS = (0.0, 0.25, 0.5, 1.0, 2.0, 4.0, math.inf)


def run(seed: int, effects=(), intensity: float = 1.0, runs: int | None = None) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        campaign = (WORLD.make_campaign(Path(tmp), seed, effects, intensity=intensity) if runs is None
                    else WORLD.make_campaign(Path(tmp), seed, effects, intensity=intensity, runs=runs))
        result, seconds, pipeline = diagnose_folders(campaign.folders, Path(tmp) / "runs.duckdb")
    first = result.effects[0] if result.effects else None
    drive = next((e for e in result.effects if e.name == "propulsion_loss"), None)
    return {"drive": drive and {"t": drive.z, "threshold": result.decision["drive_threshold_t"],
                                "shrink": drive.shrink_pct, "significant": drive.significant,
                                "release_shrink": drive.params.get("dynamic_shrink_from_release_pct")},
            "seed": seed, "truth": list(effects), "intensity": intensity, "verdict": result.verdict,
            "verdict_effects": list(result.verdict_effects), "first": first.name if first else None,
            "first_significant": bool(first and first.significant),
            "significant": [e.name for e in result.effects if e.significant],
            "shrink_of_truth": next((e.shrink_pct for e in result.effects if e.name in effects), None),
            "baseline_ms_n2": result.baseline["heldout_rms_n"] ** 2, "noise_n": campaign.nuisances["noise_n"],
            "nuisances": campaign.nuisances, "forms": campaign.effects, "seconds": seconds,
            "runs": len(campaign.folders),
            "pipeline_seconds": pipeline,
            "notes": list(result.notes), "rest_drift": result.baseline.get("rest_drift"),
            "own_runs_z": result.baseline.get("own_runs_z"), "run_gap": bool(result.baseline.get("run_gap")),
            "run_gap_threshold_z": result.decision.get("run_gap_threshold_z"),
            "best_pair": result.baseline.get("best_pair")}


def with_size(row: dict) -> dict:
    """``row`` with its twin's held-out mean square and its size (see the module's doc)."""
    twin = run(row["seed"])
    return {**row, "twin_ms_n2": twin["baseline_ms_n2"], "twin_verdict": twin["verdict"],
            "size": math.sqrt(max(row["baseline_ms_n2"] - twin["baseline_ms_n2"], 0.0)) / row["noise_n"]}


def right(row: dict) -> bool:
    truth = set(row["truth"])
    if not truth:
        return row["verdict"] == "none"
    if truth == {OUTSIDE}:
        return row["verdict"] == "unexplained"
    if len(truth) == 1:
        return row["verdict"] in truth
    return truth <= set(row["verdict_effects"])


def not_there(row: dict) -> list[str]:
    """The verdict's effects that the campaign does not hold."""
    return sorted(set(row["verdict_effects"]) - set(row["truth"]))


def false_second(row: dict) -> bool:
    """A single effect named right, beside an effect that is not there."""
    return len(row["truth"]) == 1 and right(row) and bool(not_there(row))


def detected(row: dict) -> bool:
    name = row["truth"][0]
    return name in row["verdict_effects"] or (row["first"] == name and row["first_significant"])


OUT: Path | None = None


def keep(part: str, row: dict) -> dict:
    if OUT is not None:
        with OUT.open("a") as f:
            f.write(json.dumps({"part": part, **row}, default=str) + "\n")
    return row


def show(label: str, row: dict) -> None:
    print(f"{label:34s} truth={'+'.join(row['truth']) or 'none':45s} verdict={row['verdict']:25s} "
          f"{'OK ' if right(row) else 'MISS'} effects={row['verdict_effects']} {row['seconds']:.1f}s "
          f"noise={row['noise_n']:.1f}N rate={row['nuisances']['rate_hz']} enc={row['nuisances']['encoder_mm']}mm"
          + (f" size={row['size']:.2f}" if "size" in row else "")
          + (f" own_z={row['own_runs_z']}" if row.get("own_runs_z") is not None else ""),
          flush=True)


def main() -> None:
    global OUT, WORLD, CATALOGUE, OUTSIDE
    check_options(__doc__, ("--base", "--no-ladder", "--out", "--quick", "--summary", "--world", "--ladder-only",
                            "--drive", "--nulls"))
    name = sys.argv[sys.argv.index("--world") + 1] if "--world" in sys.argv else "holdout"
    if name not in WORLDS:
        print(f"bench_diagnose_holdout: unknown world {name!r}; expected one of {', '.join(WORLDS)}", file=sys.stderr)
        raise SystemExit(2)
    WORLD = WORLDS[name]
    CATALOGUE, OUTSIDE = WORLD.CATALOGUE, WORLD.OUTSIDE
    draws, outside_draws = WORLD.DRAWS, WORLD.OUTSIDE_DRAWS
    if "--summary" in sys.argv:
        rows: dict[str, list] = {"accuracy": [], "nulls": [], "ladder": []}
        for line in Path(sys.argv[sys.argv.index("--summary") + 1]).read_text().splitlines():
            row = json.loads(line)
            rows[row.pop("part")].append(row)
        summarise(rows, sum(1 for r in rows["accuracy"] if not r["truth"]))
        return
    if "--out" in sys.argv:
        OUT = Path(sys.argv[sys.argv.index("--out") + 1])
    quick = "--quick" in sys.argv
    rows = {"accuracy": [], "nulls": [], "ladder": []}
    base = int(sys.argv[sys.argv.index("--base") + 1]) if "--base" in sys.argv else 70000
    no_ladder = "--no-ladder" in sys.argv
    ladder_only = "--ladder-only" in sys.argv
    if ladder_only and (no_ladder or quick):
        print("bench_diagnose_holdout: --ladder-only runs the whole ladder; it takes neither --no-ladder nor --quick",
              file=sys.stderr)
        raise SystemExit(2)
    if "--drive" in sys.argv:
        drive_only(int(sys.argv[sys.argv.index("--drive") + 1]), base)
        return
    if "--nulls" in sys.argv:
        nulls_only(int(sys.argv[sys.argv.index("--nulls") + 1]), base)
        return
    n_nulls = 2 if ladder_only else 4 if quick else 20
    for i in range(n_nulls):
        rows["accuracy"].append(keep("accuracy", run(base + i)))
        show(f"null {i}", rows["accuracy"][-1])
    for k, effect in enumerate(() if ladder_only else CATALOGUE):
        for rep in range(1 if quick else draws):
            rows["accuracy"].append(keep("accuracy", with_size(run(base + 100 + draws * k + rep, [effect]))))
            show(f"{effect} {rep}", rows["accuracy"][-1])
    for k, pair in enumerate(() if ladder_only else WORLD.PAIRS[:1] if quick else WORLD.PAIRS):
        rows["accuracy"].append(keep("accuracy", with_size(run(base + 200 + k, list(pair)))))
        show(f"pair {k}", rows["accuracy"][-1])
    for k in range(0 if ladder_only else 1 if quick else outside_draws):
        rows["accuracy"].append(keep("accuracy", with_size(run(base + 300 + k, [OUTSIDE]))))
        show(f"outside {k}", rows["accuracy"][-1])
    if not (quick or ladder_only):
        for i in range(40):
            rows["nulls"].append(keep("nulls", run(base + 1000 + i)))
            show(f"extra null {i}", rows["nulls"][-1])
    ladder_seeds = [] if no_ladder else [base + i for i in range(2)]  # twins of the first accuracy nulls
    null_ms = {r["seed"]: r["baseline_ms_n2"] for r in rows["accuracy"] if not r["truth"]}
    for effect in CATALOGUE:
        for seed in ladder_seeds:
            for intensity in (LADDER[1:4:2] if quick else LADDER):
                row = run(seed, [effect], intensity)
                row["size"] = math.sqrt(max(row["baseline_ms_n2"] - null_ms[seed], 0.0)) / row["noise_n"]
                rows["ladder"].append(keep("ladder", row))
                show(f"ladder {effect} x{intensity} (size {row['size']:.2f})", row)
    summarise(rows, n_nulls)


def nulls_only(n: int, base: int) -> None:
    """``--nulls N``: campaigns without effect alone, and how many were called anything but ``none``."""
    import collections

    rows = []
    for i in range(n):
        rows.append(keep("nulls", run(base + 1000 + i)))
        show(f"null {i}", rows[-1])
    called = collections.Counter(r["verdict"] for r in rows if r["verdict"] != "none")
    print(f"\nnulls called anything but none: {sum(called.values())} of {n}"
          + (f" ({', '.join(f'{v} {c}' for v, c in sorted(called.items()))})" if called else ""))
    gaps = [r for r in rows if r["run_gap"]]  # what the run-to-run test alone calls
    print(f"nulls whose run-to-run test (each run's own depth profile) passes its threshold: {len(gaps)} of {n}"
          + (" (" + ", ".join(f"seed {r['seed']}: z {r['own_runs_z']} > {r['run_gap_threshold_z']}"
                               for r in gaps) + ")" if gaps else ""))


def drive_only(n: int, base: int) -> None:
    """``--drive N``: launcher losses alone (every other campaign of 4 runs) and beside a resistance effect."""
    import numpy as np

    resistance = [e for e in CATALOGUE if e != "propulsion_loss"]
    rows = []
    for i in range(n):
        rows.append(keep("drive", run(base + 500 + i, ["propulsion_loss"], runs=4 if i % 2 else None)))
        show(f"loss {i}", rows[-1])
    for i in range(n):
        other = resistance[int(np.random.default_rng([base + 600 + i, 11]).integers(len(resistance)))]
        rows.append(keep("drive", run(base + 600 + i, ["propulsion_loss", other])))
        show(f"loss with {other} {i}", rows[-1])
    print()

    def found(row: dict) -> bool:
        return "propulsion_loss" in row["verdict_effects"]

    def count(label: str, chosen: list[dict]) -> None:
        also = [r for r in chosen if len(r["truth"]) == 2]
        print(f"{label:44s} loss found {sum(map(found, chosen))}/{len(chosen)}"
              + (f", both found {sum(right(r) for r in also)}/{len(also)}" if also else ""))

    for form in ("efficiency", "guide_friction"):
        of_form = [r for r in rows if next(f for f in r["forms"] if f["name"] == "propulsion_loss")["form"] == form]
        count(f"{form}, alone, 4 runs", [r for r in of_form if len(r["truth"]) == 1 and r["runs"] == 4])
        count(f"{form}, alone, 5-8 runs", [r for r in of_form if len(r["truth"]) == 1 and r["runs"] > 4])
        count(f"{form}, beside a resistance effect", [r for r in of_form if len(r["truth"]) == 2])
    count("all", rows)


def size_table(rows: list[dict]) -> None:
    """Found / drawn per catalogue effect and size bin, over single-effect ``rows`` that carry a size."""
    header = " ".join(f"{lo:g}-{hi:g}" for lo, hi in zip(SIZE_BINS[:-1], SIZE_BINS[1:]))
    print(f"{'effect':26s} {header}")
    for name in CATALOGUE:
        cells = []
        for lo, hi in zip(SIZE_BINS[:-1], SIZE_BINS[1:]):
            hits = [detected(r) for r in rows if r["truth"] == [name] and lo <= r["size"] < hi]
            cells.append(f"{sum(hits)}/{len(hits)}" if hits else "-")
        print(f"{name:26s} " + " ".join(f"{c:>7s}" for c in cells))


def summarise(rows: dict, n_nulls: int) -> None:
    acc = rows["accuracy"]
    nulls = [r for r in acc + rows["nulls"] if not r["truth"]]
    singles = [r for r in acc if len(r["truth"]) == 1 and r["truth"] != [OUTSIDE]]
    pair_rows = [r for r in acc if len(r["truth"]) == 2]
    effect_rows = [r for r in acc if r["truth"]]
    shrinks = [r["shrink_of_truth"] for r in singles if r["shrink_of_truth"] is not None and right(r)]
    print()
    print(WORLD.TITLE)
    print(f"verdicts right (effect, pair and outside campaigns): {sum(map(right, effect_rows))} of {len(effect_rows)} "
          f"({100 * sum(map(right, effect_rows)) / max(len(effect_rows), 1):.0f} %)")
    print(f"verdicts right, all campaigns incl. {n_nulls} nulls:        {sum(map(right, acc))} of {len(acc)} "
          f"({100 * sum(map(right, acc)) / len(acc):.0f} %)")
    sized = [r for r in effect_rows if "size" in r]
    if sized:
        seen = [r for r in sized if r["size"] >= SEEN or "propulsion_loss" in r["truth"]]
        print(f"verdicts right where the effects leave >= {SEEN:g} x the noise: {sum(map(right, seen))} of {len(seen)} "
              f"({100 * sum(map(right, seen)) / max(len(seen), 1):.0f} %); below it: "
              + (", ".join(f"{'+'.join(r['truth'])} {r['size']:.2f} ({'right' if right(r) else r['verdict']})"
                           for r in sized if r not in seen) or "none"))
    print(f"single effects right:                                {sum(map(right, singles))} of {len(singles)}")
    print(f"right singles that also name an effect not there:    {sum(map(false_second, singles))} of "
          f"{sum(map(right, singles))}" + "".join(f"; {r['truth'][0]} + {', '.join(not_there(r))}"
                                                  for r in singles if false_second(r)))
    print(f"pairs with both effects found:                       {sum(map(right, pair_rows))} of {len(pair_rows)}")
    print(f"null campaigns called anything but none:             {sum(not right(r) for r in nulls)} of {len(nulls)} "
          f"(false-alarm rate {sum(not right(r) for r in nulls) / len(nulls):.3f}; stated 0.01)")
    print(f"median held-out shrink of the true effect (right single verdicts): "
          f"{statistics.median(shrinks) if shrinks else float('nan'):.1f} %")
    times = [r["seconds"] for r in acc]
    print(f"diagnosis time per campaign: median {statistics.median(times):.1f} s, max {max(times):.1f} s "
          f"(4-8 runs; 2 cores)")
    whole = [r["pipeline_seconds"] for r in acc if "pipeline_seconds" in r]
    if whole:  # ingest, tare, subtract-inertia and diagnose, as a lab runs them 
        print(f"whole pipeline per campaign (ingest to diagnose): median {statistics.median(whole):.1f} s, "
              f"max {max(whole):.1f} s")
    print()
    print("detection probability by effect size (RMS the effect leaves after the baseline refit / noise):")
    size_table(rows["ladder"])
    sized_singles = [r for r in singles if "size" in r]
    if sized_singles:  # full-intensity campaigns of part 1, sized by their twins: a curve from drawn strengths
        print()
        print("the same over part 1's single effects (full intensity, sized by their twins):")
        size_table(sized_singles)
    drive = [r for r in rows["ladder"] if r["truth"] == ["propulsion_loss"]]
    if drive:
        def size(row: dict) -> tuple[str, float]:  # the loss as each world names it: a share, or a friction force
            form = row["forms"][0]
            if "friction_n" in form:
                return f"a {form['friction_n']:.0f} N friction over the {form['span']}", form["friction_n"]
            share = form["loss"] if "loss" in form else form["energy_lost"]
            return f"{100 * share:.1f} % of the energy", share

        print("propulsion_loss by its size (its size above is ~0: the resistance view does not see it): "
              + ", ".join(f"{size(r)[0]} {'found' if detected(r) else 'missed'}"
                          for r in sorted(drive, key=lambda r: size(r)[::-1])))


if __name__ == "__main__":
    main()
