"""How often `pen soundings diagnose` names a hidden rate effect of the right sign, and calls nothing without one.

Run: python -m bench.bench_soundings_diagnose [--seeds START END] [--per-decade K]

Each seed draws a layered ground (``pencli.testing.soundings.six_rate_site``: 1 to 6 layers over 12 m) and
pushes the simulated constant-rate cone (:mod:`pencli.acquire.sounding`) through it six times, at 5-65 mm/s,
with a rate effect of K per decade (default −0.15: faster is weaker, as in a silty sand where drainage goes from
partial to undrained) and again with none; the units are the 20 mm/s sounding's layers.  Each site is diagnosed
(every ordering of the six rates, the default 0.2 % false-alarm rate).  Prints a row per seed, then how many
effects were named with their sign and how many nulls were called.  Seeds START to END (default 7000-7040, unused;
1000-1019, 2000-2039, 3000-3299, 4000-4039, 5000-5039 and 6000-6039 have been run and looked at).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

from pencli.testing.options import check_options


def main() -> None:
    check_options(__doc__, ("--seeds", "--per-decade"))
    from pencli import api
    from pencli.testing.soundings import six_rate_site

    args = sys.argv[1:]
    start, end = (int(v) for v in args[args.index("--seeds") + 1:args.index("--seeds") + 3]) \
        if "--seeds" in args else (7000, 7040)
    per_decade = float(args[args.index("--per-decade") + 1]) if "--per-decade" in args else -0.15
    named = called = 0
    for seed in range(start, end):
        verdicts = []
        for k in (per_decade, 0.0):
            with tempfile.TemporaryDirectory() as tmp:
                result = api.diagnose_soundings(six_rate_site(Path(tmp), seed, k), "sim")
            verdicts.append(result)
        effect, null = verdicts
        right = effect.verdict == "rate_effect" and (effect.effect.per_decade > 0) == (per_decade > 0)
        named += right
        called += null.verdict != "none"
        print(f"seed {seed}: K {per_decade:+.3f} -> {effect.verdict} K {effect.effect.per_decade:+.3f} "
              f"(p {effect.p_value:.3f}){' RIGHT' if right else ''}; null -> {null.verdict} "
              f"(K {null.effect.per_decade:+.3f}, p {null.p_value:.3f})", flush=True)
    total = end - start
    print(f"rate effects named with their sign {named} of {total}; nulls called {called} of {total}")


if __name__ == "__main__":
    main()
