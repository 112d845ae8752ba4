"""``pen snow``: SnowMicroPen profiles (``.pnt``): read them, and their shot-noise micro-mechanics per window."""

from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer
from rich.markup import escape
from rich.table import Table

from pencli.commands.common import DbOption, PenTyper, console, db_path, print_json
from pencli.errors import ParameterError
from pencli.fit import SNOW_OVERLAP as OVERLAP
from pencli.fit import SNOW_WINDOW_MM as WINDOW_MM
from pencli.lazy import lazy

api = lazy("pencli.api")  # loaded when a command runs, not for --help

PROFILES_HELP = ("SnowMicroPen files (.pnt, plain or .gz), or record ids of the workspace (pen records; a quoted "
                 "pattern such as 'SNEX*' matches ids).")

snow_app = PenTyper(help="SnowMicroPen profiles (.pnt files): read them, estimate the snow's micro-mechanics "
                         "(Löwe and van Herwijnen 2012) and pen's strength term per window and per layer.")


@snow_app.command("show")
def show(
    files: List[str] = typer.Argument(..., help=PROFILES_HELP),
    json_out: bool = typer.Option(False, "--json", help='Print [{"file", "name", "samples", ...}].'),
    db: Optional[Path] = DbOption,
) -> None:
    """One line per profile: samples, step [µm], length [mm], where the snow starts [mm], the largest force [N],
    samples at the sensor's range, push rate [mm/s] and cone diameter [mm].

    Example: pen snow show examples/field/snowex-smp/*.pnt.gz
    """
    import numpy as np

    from pencli.fit.shot_noise import surface_mm

    records = []
    for profile in api.read_snow_profiles(files, db_path(db)):
        surface = surface_mm(profile.force_n, profile.step_mm)
        records.append({"file": profile.source, "name": profile.name, "samples": int(profile.force_n.size),
                        "step_mm": profile.step_mm, "length_mm": float(profile.depth_mm[-1]),
                        "surface_mm": surface, "max_force_n": float(np.max(profile.force_n)),
                        "at_range": int(np.sum(profile.force_n >= profile.overload_n)),
                        "overload_n": profile.overload_n, "speed_mm_s": profile.speed_mm_s,
                        "tip_diameter_mm": profile.tip_diameter_mm})
    if json_out:
        print_json(records)
        return
    table = Table(header_style="bold")
    for column in ("file", "profile", "samples", "step [µm]", "length [mm]", "surface [mm]", "max [N]",
                   "at range", "rate [mm/s]", "cone [mm]"):
        table.add_column(escape(column), justify="left" if column in ("file", "profile") else "right")
    for r in records:
        table.add_row(escape(Path(r["file"]).name), escape(r["name"]), str(r["samples"]),
                      f"{r['step_mm'] * 1e3:.2f}", f"{r['length_mm']:.0f}",
                      "–" if r["surface_mm"] is None else f"{r['surface_mm']:.0f}", f"{r['max_force_n']:.1f}",
                      str(r["at_range"]), f"{r['speed_mm_s']:g}", f"{r['tip_diameter_mm']:g}")
    console.print(table)


def _layer(text: str) -> tuple[float, float]:
    top, sep, bottom = text.partition(":")
    try:
        bounds = (float(top), float(bottom))
    except ValueError:
        bounds = None
    if not sep or bounds is None or not bounds[0] < bounds[1]:
        raise ParameterError(f"--layer {text!r}: expected TOP:BOTTOM in mm below the surface, top above bottom "
                                 "(e.g. 100:250)")
    return bounds


@snow_app.command("estimate")
def estimate(
    file: str = typer.Argument(..., help="A SnowMicroPen file (.pnt, plain or .gz), or a record id of the "
                                         "workspace."),
    window_mm: float = typer.Option(WINDOW_MM, "--window-mm", min=0.05, help="Window of each estimate [mm]."),
    overlap: float = typer.Option(OVERLAP, "--overlap", min=0.0, max=0.95,
                                  help="Share of a window the next one overlaps [–]."),
    surface: Optional[float] = typer.Option(None, "--surface-mm", help="Where the snow starts, from the motor's "
                                            "start [mm] (default: found in the force)."),
    bottom: Optional[float] = typer.Option(None, "--bottom-mm", help="Where the snow ends, from the motor's start "
                                           "[mm] (default: the profile's end)."),
    layers: List[str] = typer.Option([], "--layer", help="A layer TOP:BOTTOM [mm below the surface]; its windows' "
                                     "medians are printed (repeatable)."),
    out: Optional[Path] = typer.Option(None, "--out", help="Write every window's estimates to this CSV file."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Draw the strength term and element size against "
                                        "depth to this PNG, SVG or PDF file."),
    json_out: bool = typer.Option(False, "--json", help='Print {"name", "surface_mm", "windows", "layers", ...}.'),
    db: Optional[Path] = DbOption,
) -> None:
    """Per window below the snow surface: the mean force and pen's strength term (mean force over the cone's
    frontal area [kPa]), and the shot-noise estimates of Löwe and van Herwijnen (2012): deflection at rupture δ
    [mm], rupture force f₀ [N], rupture intensity λ [mm⁻¹], element size L [mm]. Windows with a sample at the
    sensor's range are flagged and left out of the layers' medians.

    Example: pen snow estimate examples/field/snowex-smp/SNEX20_SMP_S19M1255_2S7_20200208.pnt.gz --layer 0:150 --layer 150:500
    """
    bounds = [_layer(text) for text in layers]
    for target, option in ((out, "--out"), (plot, "--plot")):
        if target is not None:
            api.check_output(target, db_path(db), option)  # never onto the workspace
    result = api.estimate_snow_profile(file, window_mm=window_mm, overlap=overlap, surface_mm=surface,
                                       bottom_mm=bottom, layers=bounds, db=db_path(db))
    est = result.estimates
    columns = {"depth_mm": est.depth_mm, "mean_force_n": est.mean_force_n, "strength_kpa": est.strength_kpa,
               "deflection_mm": est.deflection_mm, "rupture_force_n": est.rupture_force_n,
               "intensity_per_mm": est.intensity_per_mm, "element_size_mm": est.element_size_mm,
               "clipped": est.clipped}
    if out is not None:
        api.write_columns_csv(out, columns)
    caption = api.plot_snow_profile(result, plot) if plot is not None else None
    layer_records = [vars(layer) for layer in result.layers]
    if json_out:
        print_json({"name": result.profile.name, "file": result.profile.source, "surface_mm": result.surface_mm,
                    "bottom_mm": result.bottom_mm, "windows": int(est.depth_mm.size),
                    "clipped_windows": int(est.clipped.sum()), "window_mm": window_mm, "overlap": overlap,
                    "layers": layer_records, "out": str(out) if out else None, "plot": str(plot) if plot else None,
                    "caption": caption})
        return
    console.print(f"{escape(result.profile.name)}: snow from {result.surface_mm:.1f} to {result.bottom_mm:.1f} mm "
                  f"after the motor's start; {est.depth_mm.size} windows of {window_mm:g} mm "
                  f"({int(est.clipped.sum())} at the sensor's range)")
    if layer_records:
        table = Table(header_style="bold")
        for column in ("layer [mm]", "windows", "strength [kPa]", "f₀ [N]", "δ [mm]", "λ [1/mm]", "L [mm]"):
            table.add_column(escape(column), justify="right")
        for layer in result.layers:
            table.add_row(f"{layer.top_mm:g}–{layer.bottom_mm:g}", str(layer.windows), f"{layer.strength_kpa:.1f}",
                          f"{layer.rupture_force_n:.3f}", f"{layer.deflection_mm:.3f}",
                          f"{layer.intensity_per_mm:.2f}", f"{layer.element_size_mm:.3f}")
        console.print(table)
    if out is not None:
        console.print(f"windows written to {escape(str(out))}")
    if caption is not None:
        console.print(f"figure written to {escape(str(plot))}: {escape(caption)}")


@snow_app.command("report")
def report(
    files: List[str] = typer.Argument(..., help=PROFILES_HELP),
    out: Path = typer.Option(..., "--out", help="The report to write (.html; a PDF is written beside it)."),
    layers: List[str] = typer.Option([], "--layer", help="A layer TOP:BOTTOM [mm below the surface] whose medians "
                                     "each profile's section gives (repeatable)."),
    window_mm: float = typer.Option(WINDOW_MM, "--window-mm", min=0.05, help="Window of each estimate [mm]."),
    overlap: float = typer.Option(OVERLAP, "--overlap", min=0.0, max=0.95,
                                  help="Share of a window the next one overlaps [–]."),
    pdf: bool = typer.Option(True, "--pdf/--no-pdf", help="Also write the report as PDF beside the HTML."),
    db: Optional[Path] = DbOption,
) -> None:
    """A report of SnowMicroPen profiles: per profile, where its snow is, the shot-noise estimates' medians of each
    layer and the profile's figure, as one self-contained HTML file (and a PDF).

    Example: pen snow report examples/field/snowex-smp/*.pnt.gz --layer 0:150 --layer 150:500 --out smp.html
    """
    bounds = [_layer(text) for text in layers]
    if out.suffix.lower() not in (".html", ".htm"):
        raise typer.BadParameter(f"'{out}' must end in .html", param_hint="--out")
    api.check_output(out, db_path(db), "--out")  # never onto the workspace
    for written in api.report_snow(files, out, layers=bounds, pdf=pdf, window_mm=window_mm, overlap=overlap,
                                   db=db_path(db)):
        console.print(f"wrote {escape(str(written))}")
