"""``pen tare`` and ``pen subtract-inertia``: conditioning stages."""

from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer
from rich.markup import escape

from pencli.lazy import lazy
from pencli.commands.common import (DbOption, PenTyper, console, db_path, err_console, number_pair, print_json,
                                    progress_bar)
from pencli.filter.derivatives import CORNER_METHOD, DEFAULT_METHOD, METHODS

api = lazy("pencli.api")  # loaded when a command runs, not for --help

app = PenTyper()


def _report(outcomes: list[api.StageOutcome], json_out: bool, describe) -> None:
    if json_out:
        print_json([{"run": o.run, "status": o.status, "id": o.run_id, "stage_no": o.stage_no,
                     **({"error": o.message} if o.message else {}), **o.details,
                     "warnings": list(o.warnings)} for o in outcomes])
    else:
        for o in outcomes:
            if o.status == "rejected":
                err_console.print(f"[red]rejected[/red] {escape(o.message)}", highlight=False, soft_wrap=True)
            else:
                console.print(f"[green]done[/green] {o.run_id} → stage {o.stage_no}: {describe(o)}", highlight=False)
            for warning in o.warnings:
                err_console.print(f"[yellow]warning:[/yellow] {escape(warning)}", highlight=False, soft_wrap=True)
    if any(o.status == "rejected" for o in outcomes):
        raise typer.Exit(1)


@app.command("tare")
def tare(
    runs: List[str] = typer.Argument(..., help="Run ids or run folders (runs/*), or 'all'."),
    window: Optional[str] = typer.Option(None, "--window", metavar="START_MS,END_MS",
                                         help="Analysis window by hand, time since release [ms] "
                                              "(default: contact to stop)."),
    json_out: bool = typer.Option(False, "--json", help="Print one record per run as JSON."),
    db: Optional[Path] = DbOption,
) -> None:
    """Tare the load cell on the pre-trigger span, compute depth, find contact and stop.

    Adds a 'tare' stage to each run: forces and torques minus their pre-trigger
    means (which also removes the blade's static weight), depth x = position −
    stand-off [m], and the events: motion start, contact, arrest or full depth,
    and the analysis window.
    Example: pen tare runs/* --json
    """
    span = number_pair(window, ",", "START_MS,END_MS", "--window")
    with progress_bar("taring", disable=json_out) as progress:
        outcomes = api.tare_runs(db_path(db), runs, window_ms=span, progress=progress)
    _report(outcomes, json_out, lambda o: (f"contact {o.details['contact_s'] * 1e3:.3f} ms at "
                                           f"{o.details['contact_speed_m_s']:.3f} m/s, {o.details['end'].replace('_', ' ')}"
                                           f" at {o.details['stop_s'] * 1e3:.3f} ms, depth "
                                           f"{o.details['final_depth_m'] * 1e3:.2f} mm"))


@app.command("subtract-inertia")
def subtract_inertia(
    runs: List[str] = typer.Argument(..., help="Run ids or run folders (runs/*), or 'all'."),
    method: Optional[str] = typer.Option(None, "--method", help=f"Derivative method: {', '.join(METHODS)} "
                                         f"[default: {DEFAULT_METHOD}; {CORNER_METHOD} joined at the corners of a "
                                         f"resistance that has some, such as a cone's shoulder]."),
    mass_from: str = typer.Option("file", "--mass-from", help="Load-cell mass to subtract: 'file' (penetrator "
                                                              "file) or 'flight' (estimated from free flight)."),
    json_out: bool = typer.Option(False, "--json", help="Print one record per run as JSON."),
    db: Optional[Path] = DbOption,
) -> None:
    """Velocity and acceleration from the encoder, then R = F − m_lc·a.

    Adds an 'inertia' stage: velocity [m/s], acceleration [m/s²] and
    resistance [N]. Also estimates the load-cell mass from the free flight
    (where R = 0) and warns when it disagrees with the penetrator file.
    Example: pen subtract-inertia runs/* --mass-from file
    """
    if method is not None and method not in METHODS:
        raise typer.BadParameter(f"'{method}' is not one of {', '.join(METHODS)}", param_hint="--method")
    if mass_from not in ("file", "flight"):
        raise typer.BadParameter(f"'{mass_from}' is not file or flight", param_hint="--mass-from")
    with progress_bar("subtracting inertia", disable=json_out) as progress:
        outcomes = api.subtract_inertia_runs(db_path(db), runs, method=method, use_flight_mass=mass_from == "flight",
                                             progress=progress)

    def describe(o):
        est = o.details.get("mass_estimate")
        return ("load-cell mass from flight " + (f"{est['value_kg']:.4f} ± {est['stderr_kg']:.4f} kg" if est
                                                  else "not measurable (flight too short)"))

    _report(outcomes, json_out, describe)
