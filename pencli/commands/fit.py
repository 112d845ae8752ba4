"""``pen fit``: the Eq. 9 coefficients of a material over many runs."""

from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer
from rich.markup import escape
from rich.table import Table

from pencli.lazy import lazy
from pencli.commands.common import (DbOption, PenTyper, console, db_path, err_console, print_json, progress_bar,
                                    usage_check)
from pencli.model.resistance import TERMS, parse_terms

api = lazy("pencli.api")  # loaded when a command runs, not for --help

app = PenTyper()

UNITS = {"strength_factor": "–", "sidewall_pressure_kpa": "kPa", "damping_kpa_s_m": "kPa·s/m",
         "inertia_coefficient": "–"}


@app.command("fit")
def fit(
    runs: List[str] = typer.Argument(..., help="Run ids or run folders (runs/*), or 'all'; each needs an inertia "
                                               "stage (pen tare, pen subtract-inertia)."),
    material: str = typer.Option(..., "--material", "-m", help="Name of the material being fitted (recorded as a "
                                                               "new version of it in the catalog)."),
    mode: str = typer.Option("resistance", "--mode", help="resistance: Eq. 9 against measured resistance with "
                                                          "measured x, v (linear); dynamic: simulate each run from "
                                                          "its launch and fit force and position against time."),
    terms: str = typer.Option(",".join(TERMS), "--terms", callback=usage_check(parse_terms), help="Eq. 9 terms switched on, comma-separated."),
    fix: Optional[List[str]] = typer.Option(None, "--fix", metavar="TERM=VALUE",
                                            help="Hold a coefficient, file units (damping=0; friction=31.6 [kPa]). "
                                                 "Single-run fits hold damping at 0 unless told."),
    all_subsets: bool = typer.Option(False, "--all-subsets", help="Also fit every combination of the terms "
                                                                  "(BAM's table) with AIC, BIC and leave-one-run-out "
                                                                  "error."),
    bootstrap: int = typer.Option(200, "--bootstrap", min=0, help="Refits on runs resampled with replacement, each "
                                                                          "run's samples resampled in blocks."),
    out: Optional[Path] = typer.Option(None, "--out", help="Write a CONTRACT §1 material file (YAML) that pen "
                                                           "predict takes as is."),
    json_out: bool = typer.Option(False, "--json", help='Print {"material", "coefficients", "stderr", ...}.'),
    db: Optional[Path] = DbOption,
) -> None:
    """Fit Cs, P, C, K simultaneously over runs of any mix of blades, springs and masses.

    Resistance mode fits each run's analysis window less 2 ms after contact
    and 3 ms before the stop, where the encoder's derivatives are least
    reliable. Reports each coefficient with its standard error, 95 % interval
    and a bootstrap interval over runs, their correlation, per-run RMS, NRMSE and
    R², and names any coefficient the runs do not determine with the run that
    would.
    Example: pen fit --material mpacs_c runs/mc-* --out mpacs_c_fit.yaml
    """
    if out is not None:
        api.check_output(out, db_path(db), "--out")
    if out is not None and out.suffix.lower() not in (".yaml", ".yml"):
        raise typer.BadParameter(f"'{out}' must end in .yaml", param_hint="--out")
    with progress_bar("fitting", disable=json_out) as progress:
        outcome = api.fit(db_path(db), material, runs, mode=mode, terms=terms, fix=fix or (),
                          all_subsets=all_subsets, bootstrap=bootstrap, out=out, progress=progress)
    result = outcome.result
    if json_out:
        record = result.to_dict()
        record["version"] = outcome.version
        record["notes"] = list(outcome.warnings)
        if outcome.subsets:
            record["subsets"] = [{"terms": list(s.terms), "coefficients": s.to_dict()["coefficients"], "aic": s.aic,
                                  "bic": s.bic, "loro_rms_n": s.loro_rms_n} for s in outcome.subsets]
        print_json(record)
        return
    table = Table(title=f"{material} — {result.mode} fit over {len(result.runs)} run(s)"
                        + (f", catalog version {outcome.version}" if outcome.version else ""),
                  header_style="bold")
    for col in ("coefficient", "value", "std. error", "95 % interval", "bootstrap 95 %", "unit"):
        table.add_column(col, justify="right" if col not in ("coefficient", "unit") else "left")
    for name, c in result.coefficients.items():
        fmt = lambda v: f"{v:.4g}"  # noqa: E731
        table.add_row(name, fmt(c.value), "fixed" if not c.vary else fmt(c.stderr),
                      "" if not c.ci95 else f"{fmt(c.ci95[0])} … {fmt(c.ci95[1])}",
                      "" if not c.bootstrap_ci95 else f"{fmt(c.bootstrap_ci95[0])} … {fmt(c.bootstrap_ci95[1])}",
                      UNITS[name])
    console.print(table)
    runs_table = Table(header_style="bold")
    cols = ["run", "samples", "RMS [N]", "NRMSE", "R²"]
    if result.mode == "dynamic":
        cols += ["t_pen meas. [ms]", "t_pen model [ms]", "depth RMS [mm]"]
    for col in cols:
        runs_table.add_column(escape(col), justify="left" if col == "run" else "right")
    for r in result.runs:
        row = [r.run_id, str(r.n_samples), f"{r.rms_n:.1f}", f"{r.nrmse:.3f}", f"{r.r2:.4f}"]
        if result.mode == "dynamic":
            row += [f"{r.penetration_time_s * 1e3:.2f}", f"{r.model_penetration_time_s * 1e3:.2f}",
                    f"{r.position_rms_mm:.2f}"]
        runs_table.add_row(*row)
    console.print(runs_table)
    console.print(f"effective samples {result.n_effective:.0f} of {result.n_samples}; AIC {result.aic:.1f}, "
                  f"BIC {result.bic:.1f}" + (f"; leave-one-run-out RMS {result.loro_rms_n:.1f} N"
                                             if result.loro_rms_n is not None else ""))
    if outcome.subsets:
        sub = Table(title="every combination of terms (resistance mode; S strength, F friction, D damping, "
                          "I inertia), best AIC first", header_style="bold")
        for col in ("terms", "Cs", "P [kPa]", "C [kPa·s/m]", "K", "AIC", "BIC", "LORO RMS [N]"):
            sub.add_column(escape(col), justify="left" if col == "terms" else "right")
        for s in sorted(outcome.subsets, key=lambda s: s.aic):
            v = s.values()
            sub.add_row("+".join(t[0].upper() for t in s.terms), f"{v['strength_factor']:.4g}", f"{v['sidewall_pressure_kpa']:.4g}",
                        f"{v['damping_kpa_s_m']:.4g}", f"{v['inertia_coefficient']:.4g}", f"{s.aic:.1f}",
                        f"{s.bic:.1f}", f"{s.loro_rms_n:.1f}" if s.loro_rms_n is not None else "")
        console.print(sub)
    for note in (*outcome.warnings, *result.warnings):
        err_console.print(f"[yellow]warning:[/yellow] {escape(note)}", highlight=False, soft_wrap=True)
    if outcome.out is not None:
        console.print(f"material file written to {outcome.out}")
