"""``pen sweep``: design spaces on the batch simulator (BAM's analysis panel, any number of variables)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import List, Optional

import typer
from rich.markup import escape
from rich.table import Table

from pencli.lazy import lazy
from pencli.commands.common import DbOption, PenTyper, console, db_path, number_pair, print_json, progress_bar

api = lazy("pencli.api")  # loaded when a command runs, not for --help

app = PenTyper()


@app.command("sweep")
def sweep(
    penetrator: str = typer.Option("appendix_c", "--penetrator", "-p", help="Penetrator preset or YAML file."),
    material: str = typer.Option("grill_brick", "--material", "-m", help="Material preset or YAML file."),
    energizing: str = typer.Option("appendix_c", "--energizing", "-e", help="Energizing preset or YAML file."),
    vary: Optional[List[str]] = typer.Option(
        None, "--vary", metavar="KEY=SPEC",
        help="A swept variable: KEY=+20%,-50% (BAM's ± deltas about the base value), KEY=LO:HI (range) or "
             "KEY=V1,V2,... (list); KEY is any CONTRACT §1 key or speed_at_contact [m/s]. Repeatable."),
    resolution: int = typer.Option(20, "--resolution", help="Points per variable for deltas and ranges."),
    sample: Optional[str] = typer.Option(None, "--sample", help="Instead of the full grid: 'lhs' (Latin "
                                                                "hypercube) or 'random' within the variables' ranges."),
    n: int = typer.Option(1000, "--n", min=1, help="Designs to sample with --sample."),
    seed: int = typer.Option(0, "--seed", help="Seed of --sample."),
    set_: Optional[List[str]] = typer.Option(None, "--set", metavar="KEY=VALUE", help="Override a base value "
                                                                                      "(file units). Repeatable."),
    speed_at_contact: Optional[float] = typer.Option(None, "--speed-at-contact", min=0.0,
                                                     help="Base speed at contact [m/s] (BAM's option): start at the "
                                                          "surface instead of simulating the flight."),
    sensitivity: bool = typer.Option(False, "--sensitivity", help="Print the Appendix C one-at-a-time table "
                                                                  "(blank where full depth is not reached)."),
    solve: Optional[str] = typer.Option(None, "--solve", metavar="max|min:KEY",
                                        help="Inverse question: the largest/least value of KEY for which --until "
                                             "holds, e.g. max:microstructure_strength_kpa."),
    until: str = typer.Option("full_penetration", "--until", help="With --solve: full_penetration, "
                                                                  "depth_mm>=VALUE or peak_n<=VALUE."),
    search: Optional[str] = typer.Option(None, "--range", metavar="LO:HI", help="With --solve: where to search "
                                                                                "(file units)."),
    out: Optional[Path] = typer.Option(None, "--out", help="Write the table (one column per varied parameter and "
                                                           "per CONTRACT §5 figure) to this Parquet file."),
    engine: str = typer.Option("local", "--engine", help="local (threads on this machine) or dask."),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help="With --engine dask: the scheduler address "
                                                                      "(default: a LocalCluster)."),
    workers: int = typer.Option(2, "--workers", min=1, help="Local threads (or LocalCluster workers)."),
    allow_out_of_range: bool = typer.Option(False, "--allow-out-of-range",
                                            help="Accept base values outside a parameter's documented range."),
    json_out: bool = typer.Option(False, "--json", help="Print the summary (or table, or answer) as JSON."),
    db: Optional[Path] = DbOption,
) -> None:
    """Sweep a design space: every combination or a sample of designs through the batch simulator.

    Without --out the result is Parquet under sweeps/ beside the workspace catalog, indexed in it.
    Example: pen sweep -p figure10 -m figure10 -e figure10 --speed-at-contact 7.155133 --vary speed_at_contact=+20%,-50% --vary friction_coefficient=+40%,-30% --resolution 20
    """
    if out is not None:
        api.check_output(out, db_path(db), "--out")
    if out is not None and out.suffix.lower() != ".parquet":
        raise typer.BadParameter(f"'{out}' must end in .parquet", param_hint="--out")
    if sensitivity:
        rows = api.sensitivity(penetrator, material, energizing, overrides=set_ or (),
                               allow_out_of_range=allow_out_of_range)
        if json_out:
            print_json([r.__dict__ for r in rows])
            return
        table = Table(title="one variable at a time (Appendix C); blank: full depth not reached", header_style="bold")
        for col in ("variable", "step", "value", "penetration time [ms]", "peak resistance [N]",
                    "residual energy [J]"):
            table.add_column(escape(col), justify="left" if col == "variable" else "right")
        for r in rows:
            table.add_row(r.key, f"{r.step:+.0%}" if r.key != "(default)" else "", f"{r.value:g} {r.unit}",
                          "invalid design" if r.end == "invalid" else
                          "" if r.penetration_time_s is None else f"{r.penetration_time_s * 1e3:.2f}",
                          "" if r.peak_resistance_n is None else f"{r.peak_resistance_n:.0f}",
                          "" if r.residual_ke_j is None else f"{r.residual_ke_j:.1f}")
        console.print(table)
        return
    if solve is not None:
        answer = api.solve(penetrator, material, energizing, target=solve, until=until,
                           search=number_pair(search, ":", "LO:HI", "--range"), overrides=set_ or (),
                           allow_out_of_range=allow_out_of_range)
        if json_out:
            print_json(answer.__dict__)
            return
        if answer.value is None:
            console.print(f"no {answer.key} in the range satisfies {answer.condition}")
        else:
            console.print(f"{answer.want} {answer.key} with {answer.condition}: {answer.value:.5g} {answer.unit} "
                          f"(± {answer.resolution / 2:.2g})")
        return
    with progress_bar("sweeping", disable=json_out) as progress:
        outcome = api.sweep(penetrator, material, energizing, vary=vary or (), resolution=resolution, sample=sample,
                            n=n, seed=seed, overrides=set_ or (), out=out, db=None if out else db_path(db),
                            engine=engine, scheduler=scheduler, workers=workers, speed_at_contact_m_s=speed_at_contact,
                            allow_out_of_range=allow_out_of_range,
                            progress=lambda done, total: progress("sweeping", done, total))
    record = {"n_designs": outcome.n_designs, "variables": outcome.variables, "summary": outcome.summary,
              "path": str(outcome.path) if outcome.path else None, "sweep_id": outcome.sweep_id,
              "seconds": outcome.seconds}
    if json_out:
        print_json(record)
        return
    s = outcome.summary
    console.print(f"{outcome.n_designs} designs in {outcome.seconds:.2f} s ({s['designs_per_s']:.0f} designs/s); "
                  f"{100 * s['full_penetration_share']:.1f} % reach full depth")
    if s["near_critical"]:
        console.print(f"{s['near_critical']} arrests damped within a hair of critical: their penetration time is "
                      f"round-off (column near_critical)")
    if s["not_simulated"]:
        console.print("not simulated (NaN figures in the table): " + ", ".join(
            f"{count} {end}" for end, count in s["not_simulated"].items()))
    table = Table(header_style="bold")
    for col in ("figure", "min", "max", "unit"):
        table.add_column(col)
    for key, label, unit, scale, digits in (("penetration_time_s", "penetration time", "ms", 1e3, 2),
                                            ("final_depth_mm", "final depth", "mm", 1.0, 1),
                                            ("peak_resistance_n", "peak resistance", "N", 1.0, 0)):
        table.add_row(label, *(f"{v * scale:.{digits}f}" if math.isfinite(v) else "not defined" for v in s[key]),
                      unit)
    console.print(table)
    console.print(f"table: {outcome.path}" + (f" (sweep {outcome.sweep_id} in {db_path(db)})" if outcome.sweep_id else ""))
