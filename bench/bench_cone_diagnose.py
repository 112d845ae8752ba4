"""How often `pen diagnose` names a hidden strength layer in a cone's campaign, and calls nothing without one.

Run: python -m bench.bench_cone_diagnose [--seeds START END]

Each seed fires two campaigns of six shots of the 10 cm² CPT cone (``cone_10cm2``) on the simulated rig (``pen
acquire``'s sim driver, whose true world writes the cone's resistance itself) into MPACS C blocks of 5.6-8.2 MPa on
2, 4 and 6 springs: one with a strength layer drawn at 20-50 mm where the strength steps by a ratio of 0.5-0.7 or
1.4-1.8 (the simulated rig's layer: 50 mm thick, so its bottom edge steps back by 1/ratio), one
without.  Both are tared, inertia-subtracted and diagnosed (200 replicates, 1 % false-alarm rate).
The verdict's edge is a step's, or a plateau's main edge (its more certain change of strength).  A layer is *found*
when the verdict is ``strength_layer`` and that edge lies within 5 mm of one of the layer's two edges and changes the
strength the way that edge does; *found at its top* when it is the top edge.
Prints a row per seed, then the layers found (softer and stronger apart) and the nulls called.  Seeds START to END
(default 4000-4010, the hold-out range; 0-4 is the range the cone's diagnosis was made on, 1000-1009 were looked
at when a layer's description was held to a strength the material can hold, and 2000-2009 and 3000-3009 when a
plateau's main edge was chosen, 5000-5005 before and after the inertia stage joined a cone's
derivatives at its shoulder, 5006-5011 after each run's own depth profile joined the gap tests; 5012 on are
unused).
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


def _edge(params) -> tuple[float, float]:
    """(depth [mm], strength below over above) of a layer's edge that counts: a step's, or a plateau's main edge."""
    if "main_edge_mm" in params:
        return float(params["main_edge_mm"]), float(params["main_edge_ratio"])
    return float(params["depth_mm"]), float(params["ratio"])


def main() -> None:
    check_options(__doc__, ("--seeds",))
    args = sys.argv[1:]
    start, end = (int(v) for v in args[args.index("--seeds") + 1:args.index("--seeds") + 3]) \
        if "--seeds" in args else (4000, 4010)
    from pencli.acquire.truth import TRUE_EFFECTS

    thickness_mm = TRUE_EFFECTS["strength_layer"].defaults["thickness_mm"]  # the simulated rig's layer
    found = {"softer": [0, 0, 0], "stronger": [0, 0, 0]}  # at either edge, at the top, of
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
        at = ""
        if named is not None:
            edge, across = _edge(named.params)
            for where, (truth_mm, truth_ratio) in (("top", (depth, ratio)), ("bottom", (depth + thickness_mm,
                                                                                         1.0 / ratio))):
                if abs(edge - truth_mm) <= FOUND_WITHIN_MM and (across > 1.0) == (truth_ratio > 1.0):
                    at = where
        kind = "stronger" if ratio > 1.0 else "softer"
        found[kind][0] += bool(at)
        found[kind][1] += at == "top"
        found[kind][2] += 1
        called += null.verdict != "none"
        said = "" if named is None else f"{named.params['depth_mm']:.0f} mm ×{named.params['ratio']:.2f}" + (
            f" to {named.params['bottom_mm']:.0f} mm ×{named.params['ratio_below']:.2f} below (main edge "
            f"{edge:.0f} mm ×{across:.2f})" if "main_edge_mm" in named.params else "")
        print(f"seed {seed}: layer {depth:.0f}-{depth + thickness_mm:.0f} mm ×{ratio:.2f} -> {layer.verdict} {said}"
              f"{' FOUND at its ' + at if at else ''}; null -> {null.verdict}", flush=True)
    total = end - start
    print("layers found (at their top edge): " + "; ".join(f"{k} {v[0]} ({v[1]}) of {v[2]}" for k, v in found.items())
          + f"; nulls called {called} of {total}")


if __name__ == "__main__":
    main()
