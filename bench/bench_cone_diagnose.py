"""How often `pen diagnose` names a hidden strength layer in a cone's campaign, and calls nothing without one.

Run: python -m bench.bench_cone_diagnose [--seeds START END]

Each seed fires two campaigns of six shots of the 10 cm² CPT cone (``cone_10cm2``) on the simulated rig (``pen
acquire``'s sim driver, whose true world writes the cone's resistance itself) into MPACS C blocks of 5.6-8.2 MPa on
2, 4 and 6 springs: one with a strength layer drawn at 20-50 mm where the strength steps by a ratio of 0.5-0.7 or
1.4-1.8, one without.  Both are tared, inertia-subtracted and diagnosed (200 replicates, 1 % false-alarm rate).
A layer is *found* when the verdict is ``strength_layer`` within 5 mm of its depth and on the right side of 1.
Prints a row per seed, then the layers found (softer and stronger apart) and the nulls called.  Seeds START to END
(default 2000-2010, the hold-out range; 0-4 is the range the cone's diagnosis was made on, and 1000-1009 were
looked at when a layer's description was held to a strength the material can hold).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np
import yaml

from pencli.testing.options import check_options

FOUND_WITHIN_MM = 5.0


def _diagnosed(folder: Path, effects: list, seed: int):
    from pencli import api
    from pencli.params.load import load_preset
    from pencli.testing.campaigns import BLOCKS, make_campaign

    cone = load_preset("cone_10cm2", "penetrator").to_mapping()
    cone.pop("notes", None)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "cone.yaml").write_text(yaml.safe_dump(cone))
    shots = [(str(folder / "cone.yaml"), springs) for springs in (2, 4, 6, 2, 4, 6)]
    db = make_campaign(folder / "ws", "mpacs_c", shots=shots, seed=seed, effects=effects, block_kpa=BLOCKS)
    api.tare_runs(db, ["all"])
    api.subtract_inertia_runs(db, ["all"])
    return api.diagnose(db, ["all"])


def main() -> None:
    check_options(__doc__, ("--seeds",))
    args = sys.argv[1:]
    start, end = (int(v) for v in args[args.index("--seeds") + 1:args.index("--seeds") + 3]) \
        if "--seeds" in args else (2000, 2010)
    found = {"softer": [0, 0], "stronger": [0, 0]}
    called = 0
    for seed in range(start, end):
        rng = np.random.default_rng(seed)
        depth = float(rng.uniform(20.0, 50.0))
        ratio = float(rng.uniform(0.5, 0.7) if rng.random() < 0.5 else rng.uniform(1.4, 1.8))
        with tempfile.TemporaryDirectory() as tmp:
            layer = _diagnosed(Path(tmp) / "layer", [{"name": "strength_layer", "depth_mm": depth, "ratio": ratio}],
                               seed)
            null = _diagnosed(Path(tmp) / "null", [], seed)
        named = layer.effects[0] if layer.effects and layer.verdict == "strength_layer" else None
        hit = (named is not None and abs(float(named.params["depth_mm"]) - depth) <= FOUND_WITHIN_MM
               and (float(named.params["ratio"]) > 1.0) == (ratio > 1.0))
        kind = "stronger" if ratio > 1.0 else "softer"
        found[kind][0] += hit
        found[kind][1] += 1
        called += null.verdict != "none"
        said = f"{named.params['depth_mm']:.0f} mm ×{named.params['ratio']:.2f}" if named is not None else ""
        print(f"seed {seed}: layer {depth:.0f} mm ×{ratio:.2f} -> {layer.verdict} {said}{' FOUND' if hit else ''}; "
              f"null -> {null.verdict}", flush=True)
    total = end - start
    print(f"softer layers found {found['softer'][0]} of {found['softer'][1]}; stronger {found['stronger'][0]} of "
          f"{found['stronger'][1]}; nulls called {called} of {total}")


if __name__ == "__main__":
    main()
