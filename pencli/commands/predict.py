"""``pen predict``: one design through the reference dynamic model."""

from __future__ import annotations

import math
from pathlib import Path
from typing import List, Optional

import typer
from rich.markup import escape
from rich.table import Table

from pencli.lazy import lazy
from pencli.commands.common import DbOption, PenTyper, console, db_path, err_console, print_json, usage_check
from pencli.model.resistance import TERMS, parse_terms
from pencli.labels import DRIVE_WORK, FIGURES
from pencli.params.overrides import parse_overrides

api = lazy("pencli.api")  # loaded when a command runs, not for --help

app = PenTyper()

PLOT_SUFFIXES = (".png", ".svg", ".pdf")
"""The figure formats --plot writes."""
SUMMARY_FORMATS = (
    ("contact_speed_m_s", "{:.4f}"), ("contact_time_s", "{:.3f}"), ("penetration_time_s", "{:.3f}"),
    ("final_depth_mm", "{:.2f}"), ("full_penetration", "{}"), ("peak_resistance_n", "{:.1f}"),
    ("peak_resistance_depth_mm", "{:.2f}"), ("residual_ke_j", "{:.2f}"), ("spring_energy_j", "{:.2f}"),
    ("gravity_work_j", "{:.2f}"), ("energy_strength_j", "{:.2f}"), ("energy_friction_j", "{:.2f}"),
    ("energy_damping_j", "{:.2f}"), ("energy_inertia_j", "{:.2f}"), ("energy_other_j", "{:.2f}"),
)
"""The rows of the summary table and their number formats (names and units: :data:`pencli.labels.FIGURES`)."""


@app.command("predict")
def predict(
    penetrator: str = typer.Option(..., "--penetrator", "-p", help="Penetrator preset name or YAML file."),
    material: str = typer.Option(..., "--material", "-m", help="Material preset name or YAML file."),
    energizing: str = typer.Option(..., "--energizing", "-e", help="Energizing (launcher) preset name or YAML file."),
    set_: Optional[List[str]] = typer.Option(
        None, "--set", metavar="KEY=VALUE", callback=usage_check(parse_overrides),
        help="Override any CONTRACT §1 key in its file's unit, e.g. blade_width_mm=150 or "
             "coefficients.inertia_coefficient=40. Repeatable. `pen params keys` lists them."),
    terms: str = typer.Option(",".join(TERMS), "--terms", callback=usage_check(parse_terms),
                              help="Eq. 9 terms switched on, comma-separated: strength,friction,damping,inertia."),
    speed_at_contact: Optional[float] = typer.Option(
        None, "--speed-at-contact", min=0.0,
        help="Start at the surface with this speed [m/s] instead of simulating the flight (BAM's option)."),
    allow_out_of_range: bool = typer.Option(False, "--allow-out-of-range",
                                            help="Accept values outside a parameter's documented range."),
    json_out: bool = typer.Option(False, "--json", help="Print the CONTRACT §5 record as JSON."),
    out: Optional[Path] = typer.Option(None, "--out", help="Write the trajectory (t, x, v, a, each term, "
                                                           "load-cell force) to this Parquet file."),
    rate: float = typer.Option(50_000.0, "--rate", min=1.0, help="Trajectory sampling rate for --out [Hz]."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Draw the run (depth and speed against time, force "
                                                             "by term against depth, energy) to a PNG, SVG or PDF."),
    db: Optional[Path] = DbOption,
) -> None:
    """Predict a blade's penetration with the reference model (CONTRACT §2).

    Example: pen predict -p al6061_1mm -m mpacs_c -e springs_4 --set blade_width_mm=150 --json
    """
    if out is not None:
        api.check_output(out, db_path(db), "--out")
    if out is not None and out.suffix.lower() != ".parquet":
        raise typer.BadParameter(f"'{out}' must end in .parquet", param_hint="--out")
    if plot is not None:
        api.check_output(plot, db_path(db), "--plot")
        if plot.suffix.lower() not in PLOT_SUFFIXES:
            raise typer.BadParameter(f"'{plot}' must end in {', '.join(PLOT_SUFFIXES)}", param_hint="--plot")
    prediction = api.predict(penetrator, material, energizing, overrides=set_ or (), terms=terms,
                             speed_at_contact_m_s=speed_at_contact, allow_out_of_range=allow_out_of_range,
                             output_rate_hz=rate)
    if out is not None:
        api.write_prediction_trajectory(prediction, out)
    if plot is not None:
        caption = api.plot_prediction(prediction, plot)
        err_console.print(f"wrote {escape(str(plot))}: {escape(caption)}", highlight=False, soft_wrap=True)
    for warning in prediction.warnings:
        err_console.print(f"[yellow]warning:[/yellow] {escape(warning)}", highlight=False, soft_wrap=True)
    if json_out:
        print_json(prediction.to_dict())
        return
    render(prediction, out)


def render(prediction: api.Prediction, out: Path | None) -> None:
    """A rich summary table with units."""
    record = prediction.to_dict()
    drive = prediction.energizing.drive
    title = f"{prediction.penetrator.name} ({prediction.penetrator.geometry.replace('_', ' ')}) · " \
            f"{prediction.material.name} · {prediction.energizing.name}" + \
            ("" if drive == "springs" else f" ({drive.replace('_', ' ')})")
    table = Table(title=title, caption=f"terms: {', '.join(prediction.result.terms)}", show_header=True,
                  header_style="bold")
    table.add_column("figure")
    table.add_column("value", justify="right")
    table.add_column("unit")
    for key, fmt in SUMMARY_FORMATS:
        if key == "energy_other_j" and not record[key]:
            continue  # every joule booked by Eq. 9's terms (a blade)
        shown = DRIVE_WORK[prediction.energizing.drive] if key == "spring_energy_j" else FIGURES[key]
        value = record[key] * shown.scale if shown.scale != 1.0 else record[key]
        finite = not isinstance(value, float) or math.isfinite(value)
        table.add_row(shown.name, fmt.format(value) if finite else "not defined", shown.unit)
    console.print(table)
    end = record["end"]
    console.print(f"ended by: [bold]{end.replace('_', ' ')}[/bold]; energy balance error "
                  f"{record['energy_balance_error_j']:.2e} J")
    if record["overrides"]:
        console.print("overrides: " + ", ".join(f"{k}={v:g}" for k, v in record["overrides"].items()))
    if prediction.result.message:
        console.print(f"[yellow]note:[/yellow] {escape(prediction.result.message)}")
    if out is not None:
        console.print(f"trajectory written to {out}")
