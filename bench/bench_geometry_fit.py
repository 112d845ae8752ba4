"""The fit of Eq. 9's coefficients on cones and tapered blades fired by the simulated rig, against the rig's truth.

Run: python -m bench.bench_geometry_fit [--seed SEED] [--material NAME]

Nine cones (25, 35.7 and 50 mm, 60° apex) and nine tapered blades (1, 1.5 and 2 mm thick, edges 0.3-0.5 mm over
8-20 mm), each on 2, 4 and 6 springs, into the material (default MPACS C; its preset's coefficients are the
rig's truth), stored, tared, inertia-subtracted and fitted; prints each coefficient fitted, its 95 % interval
and its error against the truth, then what the fit warns these runs do not determine.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import yaml

from pencli.testing.options import check_options

CONES = (25.0, 35.7, 50.0)
TAPERS = ((1.0, 0.3, 8.0), (1.5, 0.5, 12.0), (2.0, 0.5, 20.0))


def _files(folder: Path, shape: str) -> list[str]:
    rig = {"penetration_depth_mm": 133.0, "sprung_mass_kg": 2.443, "load_cell_mass_kg": 0.389}
    out = []
    if shape == "cone":
        for diameter in CONES:
            mapping = {"kind": "penetrator", "name": f"cone_{diameter:g}", "geometry": "cone",
                       "cone_half_angle_deg": 30.0, "shaft_diameter_mm": diameter, **rig}
            path = folder / f"{mapping['name']}.yaml"
            path.write_text(yaml.safe_dump(mapping))
            out.append(str(path))
    else:
        for thickness, tip, length in TAPERS:
            mapping = {"kind": "penetrator", "name": f"taper_{thickness:g}", "geometry": "tapered_blade",
                       "blade_width_mm": 184.0, "blade_thickness_mm": thickness, "tip_angle_deg": 89.9,
                       "tip_thickness_mm": tip, "taper_length_mm": length, **rig}
            path = folder / f"{mapping['name']}.yaml"
            path.write_text(yaml.safe_dump(mapping))
            out.append(str(path))
    return out


def main() -> None:
    check_options(__doc__, ("--seed", "--material"))
    args = sys.argv[1:]
    seed = int(args[args.index("--seed") + 1]) if "--seed" in args else 21
    material = args[args.index("--material") + 1] if "--material" in args else "mpacs_c"
    from pencli import api
    from pencli.params.load import load_preset
    from pencli.testing.campaigns import make_campaign

    truth = {k.split(".", 1)[1]: v for k, v in load_preset(material, "material").values.items()
             if k.startswith("coefficients.")}
    for shape in ("cone", "tapered_blade"):
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp)
            shots = [(f, springs) for f in _files(folder, shape) for springs in (2, 4, 6)]
            db = make_campaign(folder, material, shots=shots, seed=seed)
            api.tare_runs(db, ["all"])
            api.subtract_inertia_runs(db, ["all"])
            result = api.fit(db, material, ["all"], record=False).result
            fitted = result.coefficients
            print(f"{shape}, {len(api.list_runs(db))} runs into {material} (seed {seed}):")
            for name, value in truth.items():
                c = fitted[name]
                error = f"{100 * (c.value - value) / value:+.1f} %" if value else f"{c.value:+.3g} (truth 0)"
                print(f"  {name:24s} {c.value:10.4g}  95 % [{c.ci95[0]:.4g}, {c.ci95[1]:.4g}]  truth {value:g}  "
                      f"{error}")
            for warning in result.warnings:  # what the fit says these runs do not determine
                print(f"  fit warns: {warning}")


if __name__ == "__main__":
    main()
