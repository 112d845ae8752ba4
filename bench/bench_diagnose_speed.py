"""Diagnosis time of a 6-run campaign, beside another revision's on the same campaigns in the same run.

Run: python -m bench.bench_diagnose_speed [--campaigns N] [--seed SEED] [--runs R] [--against REV]

Makes N hold-out campaigns of R runs (default 12 of 6, seeds SEED + k, every catalogue effect in turn and a null
after each; ``pencli/testing/holdout_world.py``), ingests, tares and conditions them once, then diagnoses each in a
fresh process, one at a time: with this tree's code and, with ``--against REV`` (a git revision), with that
revision's, checked out in a temporary worktree, the two alternating campaign by campaign so that a change of the
machine's load falls on both.  Each process first diagnoses a small campaign (the compiled kernels loaded), then
times the call that diagnoses the campaign.  Prints one line per campaign (truth, verdicts, seconds)
and the medians and their ratio.  Run it on a quiet machine: it times one diagnosis at a time, and a diagnosis
uses both cores.
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from pencli.testing.options import check_options

ROOT = Path(__file__).resolve().parents[1]

TIME_ONE = """
import json, sys, time
sys.path.insert(0, {root!r})
from pencli import api
api.diagnose({warm!r}, ["all"])  # the compiled kernels loaded
started = time.perf_counter()
result = api.diagnose({db!r}, ["all"])
print(json.dumps({{"verdict": result.verdict, "effects": list(result.verdict_effects),
                  "seconds": time.perf_counter() - started}}))
"""


def _campaign(folder: Path, seed: int, effects: list[str], runs: int) -> Path:
    from pencli import api
    from pencli.testing import holdout_world

    campaign = holdout_world.make_campaign(folder, seed, effects, runs=runs)
    db = folder / "runs.duckdb"
    api.ingest(campaign.folders, db)
    api.tare_runs(db, ["all"])
    api.subtract_inertia_runs(db, ["all"])
    return db


def _time(root: Path, warm: Path, db: Path) -> dict:
    out = subprocess.run([sys.executable, "-c", TIME_ONE.format(root=str(root), warm=str(warm), db=str(db))],
                         cwd=root, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    check_options(__doc__, ("--campaigns", "--seed", "--runs", "--against"))
    args = sys.argv[1:]
    value = lambda flag, default: args[args.index(flag) + 1] if flag in args else default  # noqa: E731
    n, seed, runs, against = int(value("--campaigns", 12)), int(value("--seed", 760000)), int(value("--runs", 6)), \
        value("--against", None)
    from pencli.testing import holdout_world

    names = list(holdout_world.CATALOGUE)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        trees = [("this tree", ROOT)]
        if against:
            reference = tmp / "reference"
            added = subprocess.run(["git", "worktree", "add", "--detach", "-f", str(reference), against], cwd=ROOT,
                                   capture_output=True, text=True)
            if added.returncode != 0:
                raise SystemExit(f"bench_diagnose_speed: --against {against}: git could not check it out "
                                 f"({added.stderr.strip().splitlines()[-1] if added.stderr.strip() else 'no reason given'})")
            trees.append((against, reference))
        try:
            warm = _campaign(tmp / "warm", seed - 1, [], 3)
            rows = []
            for k in range(n):
                effects = [names[k // 2 % len(names)]] if k % 2 == 0 else []
                db = _campaign(tmp / f"c{k}", seed + k, effects, runs)
                timed = [_time(root, warm, db) for _, root in (trees if k % 2 == 0 else trees[::-1])]
                timed = timed if k % 2 == 0 else timed[::-1]
                rows.append(timed)
                print(f"{seed + k}  truth={'+'.join(effects) or 'none':26s} " + "  ".join(
                    f"[{label}] {t['verdict']:26s} {t['seconds']:5.1f} s" for (label, _), t in zip(trees, timed)),
                    flush=True)
            medians = [statistics.median(r[i]["seconds"] for r in rows) for i in range(len(trees))]
            print("median diagnosis time per campaign: " + ", ".join(
                f"{label} {m:.1f} s" for (label, _), m in zip(trees, medians)) + f" ({n} campaigns of {runs} runs)")
            if against:
                same = sum(r[0]["verdict"] == r[1]["verdict"] and r[0]["effects"] == r[1]["effects"] for r in rows)
                ratio = statistics.median(r[1]["seconds"] / r[0]["seconds"] for r in rows)
                print(f"same verdict and effects on {same}/{n}; {against} takes {ratio:.2f}x this tree's time "
                      "(median of the campaigns' ratios)")
        finally:
            if against:
                subprocess.run(["git", "worktree", "remove", "--force", str(reference)], cwd=ROOT, check=False,
                               capture_output=True)


if __name__ == "__main__":
    main()
