"""``pen soundings``: field records of constant-rate pushes (CPTu, total soundings): read, fit a rate effect, diagnose."""

from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer
from rich.markup import escape
from rich.table import Table

from pencli.commands.common import DbOption, PenTyper, console, db_path, print_json
from pencli.diagnose import SOUNDING_FALSE_ALARM, SOUNDING_SHUFFLES
from pencli.fit import LAYER_MIN_THICKNESS_M as MIN_THICKNESS_M
from pencli.lazy import lazy

api = lazy("pencli.api")  # loaded when a command runs, not for --help

soundings_app = PenTyper(help="Field soundings (SGF, GEF and AGS4 files): read and draw them, find their layers, fit a "
                              "rate effect across a site's soundings, diagnose whether the push rate matters.")

SOUNDINGS_HELP = ("Sounding files (SGF: .cpt, .std, .tot, .sgf; GEF: .gef; AGS4: .ags; plain or .gz), or record ids "
                  "of the workspace (pen records; a quoted pattern such as 'HALS*' matches ids).")
MIN_THICKNESS = typer.Option(MIN_THICKNESS_M, "--min-thickness", min=0.02, max=50.0,
                             help="Thinnest layer kept [m]; the default is about eight diameters of a 10 cm² cone.")
UNITS_FILE = typer.Argument(..., help="Soil-units file (JSON): a site's units, soundings and depth warps.")
SITE = typer.Option(..., "--site", help="The site of the units file whose soundings are taken.")
QUANTITY = typer.Option("qt", "--quantity", help="qt (cone resistance corrected by u₂ on the net area ratio), qc, "
                                                 "fs or u2, in kPa; push_force (a total sounding's), in kN.")


@soundings_app.command("show")
def show(
    files: List[str] = typer.Argument(..., help=SOUNDINGS_HELP),
    json_out: bool = typer.Option(False, "--json", help='Print [{"file", "name", "kind", "rows", ...}].'),
    db: Optional[Path] = DbOption,
) -> None:
    """One line per sounding: its kind, depth range, rows, the push rate from its clock [mm/s] and the logger's
    (an AGS4 test's nominal rate, which its file states instead).

    Example: pen soundings show examples/field/ntnu-cptu-rate/soundings/TILC5*.cpt.gz
    """
    import numpy as np

    from pencli.filter.rate import push_rate_mm_s

    records = []
    for path in files:
        for sounding in api.read_soundings([path], db_path(db)):
            depth = sounding.columns["depth_m"]
            logger = sounding.columns.get("rate_mm_s")
            nominal = sounding.header_number("push_rate_mm_s")
            if logger is None and nominal is not None:
                logger = np.array([nominal])
            moving = logger[logger > 0] if logger is not None else np.array([])
            records.append({"file": sounding.source, "name": sounding.name, "kind": sounding.kind, "rows": int(depth.size),
                            "top_m": float(depth[0]), "bottom_m": float(depth[-1]),
                            "rate_mm_s": (push_rate_mm_s(depth, sounding.time_s) if sounding.time_s is not None
                                          else None),
                            "logger_rate_mm_s": float(np.median(moving)) if moving.size else None,
                            "columns": sorted(sounding.columns)})
    if json_out:
        print_json(records)
        return
    table = Table(header_style="bold")
    for column in ("file", "sounding", "kind", "rows", "depth [m]", "rate [mm/s]", "logger's [mm/s]"):
        table.add_column(escape(column), justify="left" if column in ("file", "sounding", "kind") else "right")
    for r in records:
        table.add_row(escape(Path(r["file"]).name), escape(r["name"]), r["kind"], str(r["rows"]),
                      f"{r['top_m']:.2f}–{r['bottom_m']:.2f}",
                      "–" if r["rate_mm_s"] is None or not np.isfinite(r["rate_mm_s"]) else f"{r['rate_mm_s']:.1f}",
                      "–" if r["logger_rate_mm_s"] is None else f"{r['logger_rate_mm_s']:.0f}")
    console.print(table)


@soundings_app.command("plot")
def plot(
    file: str = typer.Argument(..., help="A sounding file (SGF: .cpt, .std, .tot, .sgf; GEF: .gef; AGS4: .ags; "
                                         "plain or .gz), or a record id of the workspace."),
    out: Path = typer.Option(..., "--out", help="Figure to write (PNG, SVG or PDF); a file of several soundings "
                                                "gets one figure each, numbered."),
    layers: bool = typer.Option(False, "--layers", help="Draw the layers `pen soundings layers` finds."),
    min_thickness: float = MIN_THICKNESS,
    db: Optional[Path] = DbOption,
) -> None:
    """Draw a sounding against depth: qc (and qt where u₂ and the net area ratio correct it) [MPa], fs [kPa],
    u₂ [kPa]; with --layers, the layers of its resistance.

    Example: pen soundings plot examples/field/gef/cpt.gef --out cpt.png
    """
    api.check_output(out, db_path(db), "--out")  # never onto the workspace
    soundings = api.read_soundings([file], db_path(db))
    for k, sounding in enumerate(soundings):
        target = out if len(soundings) == 1 else out.with_name(f"{out.stem}-{k + 1}{out.suffix}")
        resistance = api.sounding_resistance(sounding)
        cut = api.sounding_layers(sounding, min_thickness_m=min_thickness, resistance=resistance) if layers else None
        caption = api.plot_sounding(sounding, target, cut, resistance)
        console.print(f"figure written to {escape(str(target))}: {escape(caption)}")


@soundings_app.command("layers")
def layers_command(
    files: List[str] = typer.Argument(..., help=SOUNDINGS_HELP),
    min_thickness: float = MIN_THICKNESS,
    json_out: bool = typer.Option(False, "--json", help='Print [{"file", "name", "layers": [...], ...}].'),
    db: Optional[Path] = DbOption,
) -> None:
    """The layers of each sounding: where its resistance (a cone's qt, or qc without u₂, in MPa; a total
    sounding's push force, in kN) changes from one straight line in depth to another, by optimal partitioning
    with a penalty set from the sounding's own scatter. Per layer: its top and bottom [m], the resistance at both
    and the mean sleeve friction [kPa].

    Example: pen soundings layers examples/field/ags/HKZ_20161114_FEBV_HKZ1-CPT01_AGS4.0_V03_F.ags.gz
    """

    records = []
    for path in files:
        for sounding in api.read_soundings([path], db_path(db)):
            resistance = _, quantity, unit = api.sounding_resistance(sounding)
            cut = api.sounding_layers(sounding, min_thickness_m=min_thickness, resistance=resistance)
            fs = sounding.columns.get("fs_kpa")
            records.append({"file": sounding.source, "name": sounding.name, "quantity": quantity, "unit": unit,
                            "scatter": cut.scatter, "correlation": cut.correlation, "penalty": cut.penalty,
                            "layers": [{"top_m": layer.top_m, "bottom_m": layer.bottom_m,
                                        "q_top": layer.q_top, "q_bottom": layer.q_bottom,
                                        "fs_mean_kpa": layer.mean_of(fs)}
                                       for layer in cut.layers]})
    if json_out:
        print_json(records)
        return
    for r in records:
        table = Table(header_style="bold", title=escape(f"{r['name']} ({Path(r['file']).name}): {len(r['layers'])} "
                                                        f"layers of {r['quantity']}"),
                      caption=f"scatter about the layers' lines {100 * r['scatter']:.1f} % (row to row "
                              f"correlation {r['correlation']:.2f})")
        for column in ("top [m]", "bottom [m]", f"{r['quantity']} top [{r['unit']}]",
                       f"{r['quantity']} bottom [{r['unit']}]", "fs mean [kPa]"):
            table.add_column(escape(column), justify="right")
        for layer in r["layers"]:
            table.add_row(f"{layer['top_m']:.2f}", f"{layer['bottom_m']:.2f}", f"{layer['q_top']:.3g}",
                          f"{layer['q_bottom']:.3g}",
                          "–" if layer["fs_mean_kpa"] is None else f"{layer['fs_mean_kpa']:.1f}")
        console.print(table)


@soundings_app.command("report")
def report(
    files: List[str] = typer.Argument(..., help=SOUNDINGS_HELP),
    out: Path = typer.Option(..., "--out", help="The report to write (.html; a PDF is written beside it)."),
    pdf: bool = typer.Option(True, "--pdf/--no-pdf", help="Also write the report as PDF beside the HTML."),
    min_thickness: float = MIN_THICKNESS,
    db: Optional[Path] = DbOption,
) -> None:
    """A report of field soundings: per sounding, what it is, its file's header, its layers and its profile with
    them, as one self-contained HTML file (and a PDF).

    Example: pen soundings report examples/field/gef/cpt.gef examples/field/ags/*.ags.gz --out soundings.html
    """
    if out.suffix.lower() not in (".html", ".htm"):
        raise typer.BadParameter(f"'{out}' must end in .html", param_hint="--out")
    api.check_output(out, db_path(db), "--out")  # never onto the workspace
    for written in api.report_soundings(files, out, pdf=pdf, min_thickness_m=min_thickness, db=db_path(db)):
        console.print(f"wrote {escape(str(written))}")


@soundings_app.command("fit")
def fit(
    units: Path = UNITS_FILE,
    site: str = SITE,
    quantity: str = QUANTITY,
    json_out: bool = typer.Option(False, "--json", help='Print {"site", "quantity", "per_decade", ...}.'),
) -> None:
    """Fit q = q_u·(1 + K·log10(v/v_ref)) across a site's soundings: K, the change per decade of push rate, of
    either sign, shared by the units; q_u, each unit's value at the reference rate.

    Example: pen soundings fit examples/field/ntnu-cptu-rate/units.json --site Tiller-Flotten
    """
    effect = api.fit_soundings(units, site, quantity)
    record = {"site": site, "quantity": quantity, "per_decade": effect.per_decade,
              "per_decade_se": effect.per_decade_se, "reference_rate_mm_s": effect.reference_rate_mm_s,
              f"reference_values_{api.QUANTITY_UNITS[quantity].lower()}": {str(u): v for u, v in
                                                                          effect.reference_values.items()},
              "residual_sd": effect.residual_sd, "unit_means": effect.samples}
    if json_out:
        print_json(record)
        return
    console.print(f"{escape(site)}: {quantity} changes by K = {effect.per_decade:+.4f} ± {effect.per_decade_se:.4f} "
                  f"per decade of rate ({effect.samples} unit means, relative scatter {effect.residual_sd:.3f}); "
                  + ("faster is stronger" if effect.per_decade > 0 else "faster is weaker"))
    table = Table(header_style="bold")
    table.add_column("unit")
    unit = api.QUANTITY_UNITS[quantity]
    table.add_column(escape(f"{quantity} at {effect.reference_rate_mm_s:g} mm/s [{unit}]"), justify="right")
    for u, v in effect.reference_values.items():
        table.add_row(str(u), f"{v:.1f}")
    console.print(table)


@soundings_app.command("diagnose")
def diagnose(
    units: Path = UNITS_FILE,
    site: str = SITE,
    quantity: str = QUANTITY,
    permutations: int = typer.Option(SOUNDING_SHUFFLES, "--permutations", min=19, max=99999,
                                     help="Shuffles of the rates among the soundings that make the null (a site "
                                          "with no more orderings of its rates is tested on all of them)."),
    false_alarm: float = typer.Option(SOUNDING_FALSE_ALARM, "--false-alarm", min=1e-4, max=0.5,
                                      help="Probability that a site without a rate effect gets the verdict "
                                           "'rate_effect' [–]."),
    seed: int = typer.Option(0, "--seed", help="Seed of the shuffles (the same seed, the same verdict)."),
    json_out: bool = typer.Option(False, "--json", help='Print {"verdict", "direction", "p_value", ...}.'),
) -> None:
    """Does the push rate change the resistance at this site, and which way? Each sounding is left out in turn and
    predicted with and without the rate effect; the improvement is set against the same with the soundings' rates
    shuffled among them. Verdict 'rate_effect' or 'none'.

    Example: pen soundings diagnose examples/field/ntnu-cptu-rate/units.json --site Halsen
    """
    result = api.diagnose_soundings(units, site, quantity, permutations=permutations, false_alarm=false_alarm,
                                    seed=seed)
    record = {"site": site, "quantity": quantity, "verdict": result.verdict,
              "direction": result.direction if result.verdict == "rate_effect" else None,
              "per_decade": result.effect.per_decade, "per_decade_se": result.effect.per_decade_se,
              "p_value": result.p_value, "false_alarm": result.false_alarm,
              "heldout_rms_reference": result.heldout_rms_reference, "heldout_rms_effect": result.heldout_rms_effect,
              "soundings": result.soundings, "null_orderings": result.null_orderings, "exact_null": result.exact,
              "notes": list(result.notes)}
    if json_out:
        print_json(record)
        return
    said = (f"rate_effect: {result.direction}, K = {result.effect.per_decade:+.3f} ± "
            f"{result.effect.per_decade_se:.3f} per decade" if result.verdict == "rate_effect" else "none")
    console.print(f"{escape(site)} ({result.soundings} soundings, {quantity}): {said}  "
                  f"(p = {result.p_value:.2g} against {result.null_orderings} "
                  f"{'orderings' if result.exact else 'shuffles'} of the rates; held-out relative RMS "
                  f"{result.heldout_rms_reference:.3f} without, {result.heldout_rms_effect:.3f} with)")
    for note in result.notes:
        console.print(f"  note: {escape(note)}")
