"""Simulated-rig campaigns for fitting and diagnosis tests: made by the sim driver, never by the model code.

Each campaign is a list of shots (blade, springs, seed, block strength) fired
through `api.acquire` with a rig file that carries the true material, so the
truth lives only in the rig file and the sim driver.
"""

from __future__ import annotations

from pathlib import Path

import yaml

from pencli import api
from pencli.params.load import load_preset

BLADES = ("1", "1.5", "2")
SPRINGS = (2, 4, 6)


def twelve_shots() -> list[tuple[str, int]]:
    """Blades 1, 1.5, 2 mm × springs 2, 4, 6, plus three repeats: twelve runs."""
    combos = [(b, s) for b in BLADES for s in SPRINGS]
    return combos + [("1", 4), ("1.5", 2), ("2", 6)]


def make_campaign(folder: Path, material: str, *, shots=None, seed: int = 0, effects=(), block_kpa=None,
                  rig_extra=None, record_material: dict | None = None) -> Path:
    """Fire a campaign into ``folder/runs.duckdb``; returns the catalog path."""
    folder.mkdir(parents=True, exist_ok=True)
    db = folder / "runs.duckdb"
    shots = shots or twelve_shots()
    for i, (blade, springs) in enumerate(shots):
        mapping = load_preset(material, "material").to_mapping()
        mapping.pop("notes", None)
        if record_material:
            mapping.update(record_material)
        if block_kpa is not None:
            mapping["microstructure_strength_kpa"] = float(block_kpa[i % len(block_kpa)])
        material_file = folder / f"material-{i}.yaml"
        material_file.write_text(yaml.safe_dump(mapping))
        rig = {"kind": "rig", "name": "campaign", "seed": seed * 1000 + i, "true_material": str(material_file),
               "effects": [dict(e) for e in effects], **(rig_extra or {})}
        rig_file = folder / f"rig-{i}.yaml"
        rig_file.write_text(yaml.safe_dump(rig))
        shot = api.acquire(springs=springs, penetrator=f"al6061_{blade}mm", material=str(material_file), rig=rig_file,
                           duration_s=1.0, info={"id": f"r{i:02d}-{blade}mm-{springs}s"})
        api.add_run(shot.run, db, command="test campaign")
    return db
