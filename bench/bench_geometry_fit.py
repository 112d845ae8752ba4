"""The fit of Eq. 9's coefficients on cones and tapered blades fired by the simulated rig, against the rig's truth.

Run: python -m bench.bench_geometry_fit [--seed SEED] [--material NAME] [--wide]

Nine cones (25, 35.7 and 50 mm, 60° apex) and nine tapered blades (1, 1.5 and 2 mm thick, edges 0.3-0.5 mm over
8-20 mm), each on 2, 4 and 6 springs, into the material (default MPACS C; its preset's coefficients are the
rig's truth), stored, tared, inertia-subtracted and fitted; prints each coefficient fitted, its 95 % interval
and its error against the truth, then what the fit warns these runs do not determine.  ``--wide``: each also on
a softer and a stronger launcher (2 springs compressed to 360 mm; 9 springs), contact speeds over a factor of
about 4 instead of 1.7, which separates C·v from K·ρ·v² where the rate terms are large (Grill Brick).
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


def _wide_launchers(folder: Path) -> tuple[str, str]:
    """A softer and a stronger launcher than the bundled springs: the 2-spring preset compressed to 360 mm only
    (a sixth of its energy), and 9 of its springs."""
    from pencli.params.load import load_preset

    base = load_preset("springs_2", "energizing").to_mapping()
    base.pop("notes", None)
    out = []
    for name, change in (("soft", {"spring_compressed_length_mm": 360.0}), ("strong", {"spring_count": 9})):
        path = folder / f"{name}.yaml"
        path.write_text(yaml.safe_dump({**base, **change, "name": name}))
        out.append(str(path))
    return tuple(out)


def main() -> None:
    check_options(__doc__, ("--seed", "--material", "--wide"))
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
            launchers = (2, 4, 6) + (_wide_launchers(folder) if "--wide" in args else ())
            shots = [(f, springs) for f in _files(folder, shape) for springs in launchers]
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
