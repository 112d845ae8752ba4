"""Build the bundled example workspace: ``python -m pencli.examples``.

Twelve shots of the simulated rig (seeded, so the data are the same on every
rebuild): Grill Brick and MPACS C, blades of 1, 1.5 and 2 mm, 2, 4 and 6
springs.  MPACS C strength is measured per block (the paper: 5600–8200 kPa),
so each MPACS C run records its own block's strength.  No hidden effect.

Writes ``examples/workspace/runs.duckdb`` and its ``runs/``, ``fits/`` and
``sweeps/`` folders (or ``--out PATH``), replacing what was there.  The
example has a folder of its own, so that a workspace made in the repository
root (the default ``./runs.duckdb``) never shares its ``runs/``.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
from pathlib import Path

import yaml

from pencli import api
from pencli.params.load import load_preset

CAMPAIGN = (
    # run id, material, blade (mm), springs, block strength [kPa] (None: the preset's)
    ("gb-1.0-2", "grill_brick", "1", 2, None),
    ("gb-1.0-6", "grill_brick", "1", 6, None),
    ("gb-1.5-4", "grill_brick", "1.5", 4, None),
    ("gb-1.5-6", "grill_brick", "1.5", 6, None),
    ("gb-2.0-2", "grill_brick", "2", 2, None),
    ("gb-2.0-4", "grill_brick", "2", 4, None),
    ("mc-1.0-4", "mpacs_c", "1", 4, 5600.0),
    ("mc-1.0-6", "mpacs_c", "1", 6, 6400.0),
    ("mc-1.5-2", "mpacs_c", "1.5", 2, 7200.0),
    ("mc-1.5-6", "mpacs_c", "1.5", 6, 5900.0),
    ("mc-2.0-2", "mpacs_c", "2", 2, 8200.0),
    ("mc-2.0-4", "mpacs_c", "2", 4, 6100.0),
)


def build(db: Path) -> list[str]:
    """Rebuild the example workspace at ``db``; returns the run ids."""
    for path in (db, db.with_name(db.name + ".wal")):
        if path.exists():
            path.unlink()
    for folder in ("runs", "fits", "sweeps", "quarantine"):  # whatever a stale catalog indexed goes with it
        if (db.parent / folder).exists():
            shutil.rmtree(db.parent / folder)
    ids = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed, (run_id, material, blade, springs, block_kpa) in enumerate(CAMPAIGN):
            mapping = load_preset(material, "material").to_mapping()
            mapping.pop("notes", None)
            if block_kpa is not None:
                mapping["microstructure_strength_kpa"] = block_kpa
            material_file = Path(tmp) / f"{run_id}-material.yaml"
            material_file.write_text(yaml.safe_dump(mapping))
            rig = {"kind": "rig", "name": "sim_example", "seed": 1000 + seed, "true_material": str(material_file)}
            shot = api.acquire(springs=springs, penetrator=f"al6061_{blade}mm", material=str(material_file),
                               rig=rig, duration_s=1.0,
                               info={"id": run_id, "date": f"2026-11-{10 + seed:02d}", "operator": "sim",
                                     "notes": "example campaign (simulated rig, no hidden effect)",
                                     "tags": ["example", material]})
            added = api.add_run(shot.run, db, command="python -m pencli.examples")
            ids.append(added.run_id)
    api.workspace(db).compact()
    return ids


def analyse(db: Path) -> None:
    """Condition every run, fit both materials, sweep and diagnose: what a full report draws on."""
    api.tare_runs(db, ["all"])
    api.subtract_inertia_runs(db, ["all"])
    api.fit(db, "grill_brick", ["gb-*"], command="python -m pencli.examples")
    api.fit(db, "mpacs_c", ["mc-*"], mode="dynamic", command="python -m pencli.examples")
    api.sweep("appendix_c", "grill_brick", "appendix_c", vary=["blade_thickness_mm=0.8:2.5",
                                                                "spring_stiffness_kn_m=6:14"], resolution=25, db=db)


def build_report(db: Path, out: Path, pdf: bool = False) -> list[Path]:
    """The whole workspace's reports, as `pen report --all --diagnose` writes them (a diagnosis of each
    material's runs, and an index)."""
    import shutil

    if out.exists():
        shutil.rmtree(out)
    return api.report_all(db, out, pdf=pdf, diagnose=True)


def build_figures(db: Path, out: Path, material: str = "mpacs_c") -> list[Path]:
    """The user guide's two figures, as PNGs in the folder ``out``: the latest fit of ``material`` against its
    runs (``fit-mpacs-c.png``), and the final depth over the example sweep (``sweep-final-depth.png``)."""
    import json

    import matplotlib.pyplot as plt

    from pencli.io.atomic import write_atomic
    from pencli.report.figures import campaign_fit, sweep_map
    from pencli.report.sections import sweep_boundary

    ws = api.workspace(db)
    version = ws.material_versions(material)[-1]
    table = ws.read_table(version["model_data_path"], "model-vs-data table")
    fit, fit_caption = campaign_fit(material, {name: table.column(name).to_numpy(zero_copy_only=False)
                                               for name in table.column_names})
    fit.axes[0].set_title(fit_caption, fontsize=9, loc="left", wrap=True)  # a picture on its own carries its caption
    sweep = ws.sweep_row(1)
    keys = list(json.loads(sweep["variables"]))
    swept = ws.read_table(sweep["path"], "sweep table")
    grid = {name: swept.column(name).to_numpy(zero_copy_only=False) for name in swept.column_names}
    base = json.loads(swept.schema.metadata[b"pen:base"])
    depth, caption = sweep_map(grid, keys[0], keys[1], "final_depth_mm", keys[2:],
                               sweep_boundary(grid, base, keys[0], keys[1], keys[2:]))
    depth.suptitle(caption, fontsize=8, wrap=True)
    written = []
    for fig, name in ((fit, "fit-mpacs-c.png"), (depth, "sweep-final-depth.png")):
        write_atomic(out / name, lambda tmp, fig=fig: fig.savefig(tmp, format="png", dpi=160))
        plt.close(fig)
        written.append(out / name)
    return written


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "examples" / "workspace" / "runs.duckdb",
                        help="catalog to write (runs/ goes beside it)")
    parser.add_argument("--report", type=Path, nargs="?", const=Path(__file__).resolve().parents[1] / "examples"
                        / "report", help="also condition, fit, sweep, diagnose and write the full report here")
    parser.add_argument("--figure", type=Path, nargs="?", const=Path(__file__).resolve().parents[1] / "docs" / "img",
                        help="only draw the user guide's two figures from the workspace into this folder")
    parser.add_argument("--report-only", action="store_true",
                        help="with --report: write the reports from the workspace as it is, without rebuilding it")
    args = parser.parse_args()
    if args.figure is not None:
        for path in build_figures(args.out, args.figure):
            print(f"wrote {path}")
        return
    if args.report is not None and args.report_only:
        written = build_report(args.out, args.report)
        print(f"wrote {len(written)} report files into {args.report}")
        return
    ids = build(args.out)
    print(f"built {len(ids)} runs into {args.out}")
    if args.report is not None:
        analyse(args.out)
        api.workspace(args.out).compact()
        written = build_report(args.out, args.report)
        print(f"wrote {len(written)} report files into {args.report}")


if __name__ == "__main__":
    main()
