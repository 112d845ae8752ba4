"""Do the runs ``pen diagnose --suggest`` proposes resolve an ambiguous campaign more often than random runs?

Run: python -m bench.bench_plan [--campaigns N] [--base SEED] [--add K] [--jobs J]

Each campaign is made by the simulated rig (``pen acquire``'s sim driver): five runs of one blade (1.5 mm) on
one launcher (4 springs), in blocks whose strength scatters, with one weak law effect drawn at random (a
velocity friction, a rate strength, a strength gradient or a sidewall pressure growth; random sizes near the
detection limit): runs whose speed is the same function of depth, the textbook ambiguous campaign.  It is
diagnosed with ``--suggest K``; a campaign without an ambiguity (its effect told apart already, or not found)
takes no further part.  An ambiguous one is made again twice with K more runs: the suggested designs, and K
designs drawn at random from the same design space (the rig's spring counts and blades); each is diagnosed
again.  A campaign is *resolved* when its verdict names the true effect first and nothing is said to fit as
well.  Prints one row per campaign, then both rates.
"""

from __future__ import annotations

import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from pencli.testing.options import check_options

SHOTS = [("1.5", 4)] * 5
BLOCKS = [5600, 6000, 6400, 7200, 8200]


def _effect(rng: np.random.Generator) -> dict:
    name = str(rng.choice(["velocity_friction", "rate_strength", "strength_gradient", "sidewall_pressure_growth"]))
    size = float(np.exp(rng.uniform(np.log(0.5), np.log(2.0))))
    return {"velocity_friction": {"name": name, "drop": 0.06 * size},
            "rate_strength": {"name": name, "coefficient": 0.02 * size},
            "strength_gradient": {"name": name, "change_per_100mm": 0.15 * size},
            "sidewall_pressure_growth": {"name": name, "scale_mm": 200.0 / size}}[name]


def _diagnose(folder: Path, seed: int, effect: dict, shots, suggest: int = 0):
    from pencli import api
    from pencli.testing.campaigns import make_campaign

    db = make_campaign(folder, "mpacs_c", seed=seed, shots=shots, effects=[effect], block_kpa=BLOCKS)
    api.tare_runs(db, ["all"])
    api.subtract_inertia_runs(db, ["all"])
    return api.diagnose(db, ["all"], suggest=suggest)


def _resolved(result, truth: str) -> bool:
    return bool(result.verdict_effects) and result.verdict_effects[0] == truth and not result.ambiguities


def _blade(thickness_mm: float) -> str:
    return f"{thickness_mm:g}"


def one(job: tuple[int, int]) -> dict:
    from pencli.diagnose.plan import RIG_SPRINGS, RIG_THICKNESSES_M

    seed, add = job
    rng = np.random.default_rng([seed, 5])
    effect = _effect(rng)
    with tempfile.TemporaryDirectory() as tmp:
        first = _diagnose(Path(tmp) / "first", seed, effect, SHOTS, suggest=add)
        row = {"seed": seed, "truth": effect["name"], "effect": effect, "verdict": first.verdict,
               "ambiguous": bool(first.ambiguities)}
        if not first.ambiguities:
            return row
        suggested = [(_blade(r["blade_thickness_mm"]), r["spring_count"]) for r in first.suggestions["runs"]]
        random = [(_blade(1e3 * float(rng.choice(RIG_THICKNESSES_M))), int(rng.choice(RIG_SPRINGS)))
                  for _ in suggested]
        after = _diagnose(Path(tmp) / "suggested", seed, effect, SHOTS + suggested)
        chance = _diagnose(Path(tmp) / "random", seed, effect, SHOTS + random)
    return {**row, "suggested": suggested, "random": random,
            "separation": [r["separation_sigma"] for r in first.suggestions["runs"]],
            "own_separation": first.suggestions["own_runs_separation_sigma"],
            "resolved_suggested": _resolved(after, effect["name"]), "resolved_random": _resolved(chance, effect["name"]),
            "verdict_suggested": after.verdict, "verdict_random": chance.verdict}


def main(argv: list[str]) -> None:
    check_options(__doc__, ("--campaigns", "--base", "--add", "--jobs"), argv)

    def value(flag: str, default: int) -> int:
        return int(argv[argv.index(flag) + 1]) if flag in argv else default

    n, base, add, workers = value("--campaigns", 12), value("--base", 880_000), value("--add", 2), value("--jobs", 1)
    rows = []
    with ProcessPoolExecutor(workers) as pool:
        for row in pool.map(one, [(base + k, add) for k in range(n)]):
            rows.append(row)
            if not row["ambiguous"]:
                print(f"{row['seed']}  {row['truth']:26s} verdict={row['verdict']:26s} not ambiguous", flush=True)
                continue
            print(f"{row['seed']}  {row['truth']:26s} verdict={row['verdict']:26s} suggested {row['suggested']} "
                  f"({row['separation']} σ, own runs {row['own_separation']} σ): "
                  f"{'resolved' if row['resolved_suggested'] else row['verdict_suggested']}; random {row['random']}: "
                  f"{'resolved' if row['resolved_random'] else row['verdict_random']}", flush=True)
    ambiguous = [r for r in rows if r["ambiguous"]]
    print()
    print(f"ambiguous campaigns: {len(ambiguous)} of {len(rows)}")
    if ambiguous:
        print(f"resolved after {add} suggested runs: {sum(r['resolved_suggested'] for r in ambiguous)}/{len(ambiguous)}")
        print(f"resolved after {add} random runs:    {sum(r['resolved_random'] for r in ambiguous)}/{len(ambiguous)}")


if __name__ == "__main__":
    main(sys.argv[1:])
