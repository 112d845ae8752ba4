"""``pen diagnose``: where the model and the runs part, which unmodelled effect, how far it closes."""

from __future__ import annotations

import json
from pathlib import Path
from typing import List, Optional

import typer
from rich.markup import escape
from rich.table import Table

from pencli.lazy import lazy
from pencli.commands.common import DbOption, PenTyper, console, db_path, progress_bar
from pencli.diagnose.effects import EFFECTS
from pencli.diagnose import BOOTSTRAP, FALSE_ALARM, MAX_WORKERS, WORKERS, params_text

api = lazy("pencli.api")  # loaded when a command runs, not for --help

app = PenTyper()


@app.command("diagnose")
def diagnose(
    runs: List[str] = typer.Argument(..., help="Run ids, run folders or id patterns, or 'all'; each tared and "
                                               "inertia-subtracted (at least 3 runs)."),
    json_file: Optional[Path] = typer.Option(None, "--json", help="Write the CONTRACT §4 report to this file "
                                                                  "('-' for stdout)."),
    effects: Optional[str] = typer.Option(None, "--effects", help="Only these catalogue effects, comma-separated "
                                                                  f"(default all: {', '.join(EFFECTS)})."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Draw held-out residuals against depth and time, "
                                                             "before and after the verdict's effect, against the "
                                                             "null replicates' band (PNG, SVG or PDF)."),
    false_alarm: float = typer.Option(FALSE_ALARM, "--false-alarm", min=1e-4, max=0.5,
                                      help="Probability that a campaign with no effect gets any verdict but 'none' "
                                           "[–]."),
    bootstrap: int = typer.Option(BOOTSTRAP, "--bootstrap", min=20, max=2000,
                                  help="Null replicates of the campaign that calibrate every decision."),
    seed: int = typer.Option(0, "--seed", help="Seed of the null replicates (the same seed, the same verdict)."),
    suggest: int = typer.Option(0, "--suggest", min=0, max=3,
                                help="Propose this many next runs (spring count, blade thickness and width, "
                                     "sampling rate: the rig's bundled blades and launchers and the runs' own) "
                                     "that best tell the verdict's "
                                     "effect from those that fit as well, with the separation each would give "
                                     "in units of the force noise [–]."),
    workers: Optional[int] = typer.Option(None, "--workers", min=1, max=MAX_WORKERS,
                                          help="Processes (and compiled threads) the diagnosis uses; the verdict "
                                               f"does not depend on it [default: PEN_WORKERS, else {WORKERS}]."),
    db: Optional[Path] = DbOption,
) -> None:
    """Diagnose the sim-to-real gap: where it lies, which effect causes it, how far it shrinks.

    Fits the reference model (a strength factor per run for block scatter,
    shared P, C, K), then adds each catalogue effect family in turn, refits on
    the other runs and scores on the run left out. Every decision is
    calibrated on null replicates of this campaign (its own noise, encoder and
    derivative chain) at the stated false-alarm rate. Verdict: an effect,
    'none' (nothing beyond what the null makes) or 'unexplained' (a gap no
    effect or pair removes half of).
    Example: pen diagnose 'mc-*' --json diagnosis.json --false-alarm 0.01 --suggest 2
    """
    if json_file is not None and str(json_file) != "-":
        api.check_output(json_file, db_path(db), "--json")
    if plot is not None:
        api.check_output(plot, db_path(db), "--plot")
    if plot is not None and plot.suffix.lower() not in (".png", ".svg", ".pdf"):
        raise typer.BadParameter(f"'{plot}' must end in .png, .svg or .pdf", param_hint="--plot")
    chosen = [e.strip() for e in effects.split(",")] if effects else None
    with progress_bar("diagnosing") as progress:
        result = api.diagnose(db_path(db), runs, effects=chosen, false_alarm=false_alarm, bootstrap=bootstrap,
                              seed=seed, suggest=suggest, workers=workers,
                              progress=lambda stage, done: progress(stage, done, 1))
    if plot is not None:
        from pencli.report.diagnosis import plot_diagnosis

        plot_diagnosis(result, plot)
    report = result.to_dict()
    if json_file is not None:
        text = json.dumps(report, indent=2, default=float)
        if str(json_file) == "-":
            typer.echo(text)
            return
        from pencli.io.atomic import write_atomic

        write_atomic(json_file, lambda tmp: tmp.write_text(text + "\n", encoding="utf-8"))
    base = report["baseline"]
    colour = {"none": "green", "unexplained": "red"}.get(result.verdict, "yellow")
    alike = "".join(f" or {a['effects'][1]}" for a in result.ambiguities)
    console.print(f"[bold]verdict: [{colour}]{result.verdict}{alike}[/{colour}][/bold]"
                  + (": this campaign cannot tell them apart (see the notes)" if alike else "")
                  + (f"  (with {', '.join(result.verdict_effects[1:])})" if len(result.verdict_effects) > 1 else "")
                  + f"   over {len(result.runs)} runs")
    decision = result.decision
    console.print(f"baseline held-out RMS {base['heldout_rms_n']:.1f} N (NRMSE {base['heldout_nrmse']:.3f}); its null "
                  f"replicates {base['null_rms_n']:.1f} N (gap z {base['gap_z']:.1f}, threshold "
                  f"{decision['gap_threshold_z']:.1f}); contact speed {100 * base['contact_speed_error_mean']:+.2f} % "
                  f"of prediction (t {base['drive_t']:.1f}, threshold {decision['drive_threshold_t']:.1f})")
    console.print(f"false-alarm rate {decision['false_alarm']:g} per campaign, {decision['bootstrap']} null replicates; "
                  f"an effect needs z > {decision['effect_threshold_z']:.1f}")
    if result.verdict == "none":
        console.print("where: no gap beyond the noise")
    for item in (result.where[:3] if result.verdict != "none" else ()):
        depth = f", depth {item['depth_mm'][0]:g}–{item['depth_mm'][1]:g} mm" if item.get("depth_mm") else ""
        share = f", {100 * item['share_of_gap']:.0f} % of the gap" if item.get("share_of_gap") is not None else ""
        console.print(f"where: {item['phase']}{depth}, t {item['time_ms'][0]:g}–{item['time_ms'][1]:g} ms{share}"
                      + ("" if item.get("above_noise") else " (within noise)"))
    if result.axes:
        follows = ", ".join(f"{k.replace('_', ' ')} {v:.2f}" for k, v in result.axes.items()
                            if k not in ("flight_share", "run"))
        runs_apart = (f"; {100 * result.axes['run']:.0f} % of it differs from run to run"
                      if "run" in result.axes else "")
        console.print(f"the baseline's misfit follows (share explained by its mean along each axis): {follows}"
                      f"{runs_apart}; flight holds {100 * result.axes['flight_share']:.0f} % of it")
    table = Table(header_style="bold", title="effects, best first")
    for col in ("effect", "held-out RMS [N]", "shrink", "z", "significant", "parameters", "trajectory change"):
        table.add_column(escape(col), justify="right" if col in ("held-out RMS [N]", "shrink", "z") else "left")
    for e in result.effects[:6]:
        change = e.trajectory_change
        text = ""
        if change.get("penetration_time_pct") is not None:
            text = (f"t_pen {change['penetration_time_pct']:+.1f} %, depth {change['final_depth_mm']:+.1f} mm, "
                    f"peak {change['peak_resistance_pct']:+.1f} %")
        elif change.get("note"):
            text = "none (measurement)"
        table.add_row(e.name, f"{e.heldout_rms_n:.1f}", f"{e.shrink_pct:.0f} %", f"{e.z:.1f}", "yes" if e.significant else "",
                      escape(params_text(e.params)), text)
    console.print(table)
    for note in result.notes:
        console.print(f"note: {escape(note)}", highlight=False)
    _print_suggestions(result.suggestions)
    if json_file is not None:
        console.print(f"report written to {json_file}")
    if plot is not None:
        from pencli.report.diagnosis import diagnosis_caption

        console.print(f"figure written to {plot}: {diagnosis_caption(result)}")


def _print_suggestions(plan: dict) -> None:
    """The proposed next runs, one line each, best first."""
    if not plan:
        return
    if plan.get("note"):
        console.print(f"plan: {escape(plan['note'])}", highlight=False)
    for k, run in enumerate(plan["runs"], 1):
        console.print(f"next run {k}: {run['spring_count']} springs, blade {run['blade_thickness_mm']:g} × "
                      f"{run['blade_width_mm']:g} mm, {run['sampling_rate_hz'] / 1e3:g} kHz: "
                      f"{run['candidates'][0]} and {run['candidates'][1]} predicted "
                      f"{run['separation_sigma']:.1f} noise units apart (the campaign's own runs: at most "
                      f"{plan['own_runs_separation_sigma']:.1f})", highlight=False)
