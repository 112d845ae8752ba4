"""The diagnosis's whole report on a fixed set of development and hold-out campaigns, as one fingerprint each.

Run: python -m bench.bench_diagnose_identity [--dev N] [--holdout N] [--seed SEED] [--jobs J] [--runs R]
     [--reports DIR]

Prints one line per campaign: its world and label, the truth, the verdict and its effects, and the SHA-256 of the
whole report as JSON (the time it took left out, floats rounded to 9 significant digits so that a last-bit
difference of a BLAS kernel does not count), then the median diagnosis time.  Run it before and after a change
that must leave the diagnosis as it is (a refactoring) and compare the two outputs line by line: every verdict and
every fingerprint must agree.  The development campaigns are ``bench_diagnose --varied N SEED``'s (random forms
and nuisances, nulls among them); the hold-out campaigns are the hold-out world's (``pencli/testing/holdout_world.py``),
every catalogue effect in turn and a null after every effect; ``--runs R`` gives each hold-out campaign R runs
(default: 4–8 at random).  ``--dev 0 --holdout 16 --runs 6 --jobs 1`` on a quiet machine times the diagnosis of a
6-run campaign.  ``--reports DIR`` also writes each campaign's whole report as JSON into DIR; a change to the solver's
arithmetic moves the last digits of near-collinear fits and with them every fingerprint, and
``python -m bench.compare_reports BEFORE_DIR AFTER_DIR`` then says by how much each report moved.
"""

from __future__ import annotations

import hashlib
import json
import statistics
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from pencli.testing.options import check_options


def _rounded(value):
    if isinstance(value, float):
        return float(f"{value:.9g}")
    if isinstance(value, dict):
        return {k: _rounded(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_rounded(v) for v in value]
    return value


def report_text(result) -> str:
    """The whole report as JSON, the time it took left out."""
    report = result.to_dict()
    report.get("decision", {}).pop("seconds", None)
    return json.dumps(report, sort_keys=True, default=str)


def fingerprint(text: str) -> str:
    text = json.dumps(_rounded(json.loads(text)), sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def dev_one(args) -> tuple[str, str, str, str, str, str, float, str]:
    from bench.bench_diagnose import run_one

    seed, label, material, effects, truth, nuisances = args
    result, seconds = run_one(label, material, effects, seed, nuisances)
    text = report_text(result)
    return (f"dev {seed}", label, "+".join(sorted(truth)) or "none", result.verdict,
            "+".join(result.verdict_effects) or "-", fingerprint(text), seconds, text)


def holdout_one(args) -> tuple[str, str, str, str, str, str, float, str]:
    from pencli.testing import holdout_world
    from pencli.testing.campaigns import diagnose_folders

    seed, effects, runs = args
    with tempfile.TemporaryDirectory() as tmp:
        campaign = holdout_world.make_campaign(Path(tmp), seed, effects, runs=runs)
        result, seconds, _ = diagnose_folders(campaign.folders, Path(tmp) / "runs.duckdb")
    text = report_text(result)
    return (f"holdout {seed}", "+".join(effects) or "null", "+".join(effects) or "none", result.verdict,
            "+".join(result.verdict_effects) or "-", fingerprint(text), seconds, text)


def main() -> None:
    check_options(__doc__, ("--dev", "--holdout", "--seed", "--jobs", "--runs", "--reports"))
    value = lambda flag, default: int(sys.argv[sys.argv.index(flag) + 1]) if flag in sys.argv else default  # noqa: E731
    n_dev, n_holdout, seed, jobs = value("--dev", 8), value("--holdout", 8), value("--seed", 700000), value("--jobs", 2)
    runs = value("--runs", 0) or None
    reports = Path(sys.argv[sys.argv.index("--reports") + 1]) if "--reports" in sys.argv else None
    if reports is not None:
        reports.mkdir(parents=True, exist_ok=True)
    from pencli.testing import holdout_world
    from pencli.testing.campaigns import varied_campaigns

    dev = [(seed + k, *campaign) for k, campaign in enumerate(varied_campaigns(n_dev, seed))]
    names = list(holdout_world.CATALOGUE)
    held = [(seed + 1000 + k, [names[k // 2 % len(names)]] if k % 2 == 0 else [], runs) for k in range(n_holdout)]
    rows = []
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        futures = [pool.submit(dev_one, a) for a in dev] + [pool.submit(holdout_one, a) for a in held]
        for future in futures:
            row = future.result()
            rows.append(row)
            if reports is not None:
                (reports / f"{row[0].replace(' ', '-')}.json").write_text(row[7])
            print(f"{row[0]:14s} {row[1]:40s} truth={row[2]:32s} verdict={row[3]:26s} effects={row[4]:40s} "
                  f"report={row[5]} {row[6]:5.1f} s", flush=True)
    print(f"median diagnosis time {statistics.median(r[6] for r in rows):.1f} s over {len(rows)} campaigns, "
          f"{jobs} at a time")


if __name__ == "__main__":
    main()
