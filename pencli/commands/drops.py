"""``pen drops``: free-fall penetrometer records (BlueDrop ``.bin``): integrate them, fit the bed across them."""

from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer
from rich.markup import escape
from rich.table import Table

from pencli.commands.common import DbOption, PenTyper, console, db_path, print_json
from pencli.diagnose import FALSE_ALARM, SHUFFLES
from pencli.lazy import lazy

api = lazy("pencli.api")  # loaded when a command runs, not for --help

drops_app = PenTyper(help="Free-fall penetrometer drops (BlueDrop .bin records): release, impact, speed and depth "
                          "from the stitched accelerometers; the bed's resistance fitted across drops.")

DROPS = typer.Argument(..., help="BlueDrop records (.bin, with --calibration), or record ids of the workspace "
                                 "(pen records; a quoted pattern such as 'drop-*' matches ids).")
CALIBRATION = typer.Option(None, "--calibration", help="The probe's calibration sheet (CSV channel,offset,scale,"
                                                       "unit), for .bin files (an ingested record is calibrated).")
PROBE = typer.Option("freefall_cone", "--penetrator", "-p", help="The probe: a cone penetrator preset or file "
                                                                 "(mass, cone).")
FALL = typer.Option("drop_water", "--energizing", "-e", help="The fall: a free-fall launcher preset or file (fluid "
                                                             "density, drag and added-mass coefficients, volume).")


def _drop_record(drop) -> dict:
    m = drop.motion
    t = m.time_s
    return {"file": str(drop.record.source), "name": drop.name, "samples": int(t.size),
            "rate_hz": float((t.size - 1) / (t[-1] - t[0])), "release_s": float(t[m.release]),
            "impact_s": float(m.impact_s), "impact_speed_m_s": float(m.impact_speed_m_s),
            "penetration_mm": 1e3 * float(m.penetration_m), "stop_s": float(t[m.stop]),
            "peak_deceleration_g": drop.motion.peak_deceleration_g,
            "bias_g": {name: list(pair) for name, pair in m.bias_g.items()},
            "rest_speed_m_s": float(m.rest_speed_m_s)}  # NaN (no rest after the stop) is written as null


@drops_app.command("show")
def show(
    refs: List[str] = DROPS,
    calibration: Optional[Path] = CALIBRATION,
    json_out: bool = typer.Option(False, "--json", help='Print [{"name", "impact_speed_m_s", "penetration_mm", ...}].'),
    db: Optional[Path] = DbOption,
) -> None:
    """One line per drop: when it was released and met the bed [s], its speed at impact [m/s], how deep it went
    [mm] and its largest deceleration [g], from the accelerometers stitched (the finest in range), their biases
    taken out at rest before the release and after the stop, and integrated.

    Example: pen drops show drop-01.bin --calibration calibration.csv
    """
    records = [_drop_record(d) for d in api.read_drops(refs, db_path(db), calibration)]
    if json_out:
        print_json(records)
        return
    table = Table(header_style="bold")
    for column in ("drop", "samples", "release [s]", "impact [s]", "impact speed [m/s]", "penetration [mm]",
                   "peak deceleration [g]"):
        table.add_column(escape(column), justify="left" if column == "drop" else "right")
    for r in records:
        table.add_row(escape(r["name"]), str(r["samples"]), f"{r['release_s']:.3f}", f"{r['impact_s']:.4f}",
                      f"{r['impact_speed_m_s']:.3f}", f"{r['penetration_mm']:.1f}", f"{r['peak_deceleration_g']:.1f}")
    console.print(table)


@drops_app.command("fit")
def fit(
    refs: List[str] = DROPS,
    penetrator: str = PROBE,
    energizing: str = FALL,
    calibration: Optional[Path] = CALIBRATION,
    hold_drag: bool = typer.Option(False, "--hold-drag", help="Take the launcher file's drag and added-mass "
                                                              "coefficients instead of fitting them."),
    json_out: bool = typer.Option(False, "--json", help='Print {"strength_kpa", "gradient_kpa_m", ...}.'),
    db: Optional[Path] = DbOption,
) -> None:
    """Fit the bed's pressure on the cone, q = σ + b·z + c·v [kPa, kPa/m, kPa·s/m], across the drops: the bed's
    force at each sample is what the probe's weight, buoyancy, drag and added mass leave of its measured
    deceleration. Drops from several heights separate b from c (in one drop, depth and speed move together). The
    drag and added-mass coefficients are fitted too, from the fall through the water (--hold-drag: the file's).

    Example: pen drops fit 'drop-*' -p freefall_cone -e drop_water
    """
    probe = api.free_fall_probe(penetrator, energizing)
    drops = api.read_drops(refs, db_path(db), calibration)
    result = api.fit_drops(drops, probe, nuisances=not hold_drag)
    record = {"drops": result.drops, "samples": result.samples, "strength_kpa": result.strength_kpa,
              "gradient_kpa_m": result.gradient_kpa_m, "damping_kpa_s_m": result.damping_kpa_s_m,
              "drag_coefficient": result.drag_coefficient, "added_mass_coefficient": result.added_mass_coefficient,
              "standard_errors": list(result.standard_errors), "relative_rms": result.relative_rms}
    if json_out:
        print_json(record)
        return
    se = result.standard_errors
    console.print(f"bed over {result.drops} drops ({result.samples} samples): σ = {result.strength_kpa:.2f} ± "
                  f"{se[0]:.2f} kPa, b = {result.gradient_kpa_m:.1f} ± {se[1]:.1f} kPa/m, c = "
                  f"{result.damping_kpa_s_m:.2f} ± {se[2]:.2f} kPa·s/m; residual RMS "
                  f"{100 * result.relative_rms:.1f} % of the bed's mean force (least-squares errors: too small where "
                  f"the residuals are correlated)")
    if result.drag_coefficient is not None:
        console.print(f"the probe in the water: drag coefficient {result.drag_coefficient:.3f}, added-mass "
                      f"coefficient {result.added_mass_coefficient:.3f} (the file says {probe.drag_coefficient:g} "
                      f"and {probe.added_mass_coefficient:g})")


@drops_app.command("diagnose")
def diagnose(
    refs: List[str] = DROPS,
    penetrator: str = PROBE,
    energizing: str = FALL,
    calibration: Optional[Path] = CALIBRATION,
    false_alarm: float = typer.Option(FALSE_ALARM, "--false-alarm", min=1e-4, max=0.5,
                                      help="Probability that drops into a bed without a layer get a verdict other "
                                           "than 'none' [–]."),
    shuffles: int = typer.Option(SHUFFLES, "--shuffles", min=19, max=9999,
                                 help="Rotations of each drop's misfit that make the null."),
    seed: int = typer.Option(0, "--seed", help="Seed of the rotations (the same seed, the same verdict)."),
    json_out: bool = typer.Option(False, "--json", help='Print {"verdict", "layer_depth_m", "p_value", ...}.'),
    db: Optional[Path] = DbOption,
) -> None:
    """Is there a layer in the bed the drops share, or a bias in the accelerometers? First the sensors: the speed
    integrated over the rest after each stop must be 0 [m/s]; beyond what the integration and the noise leave, the
    verdict is 'accelerometer_bias' (and a bias stepping at the impact is tried in its place). Then the bed: its
    straight law q = σ + b·z + c·v is fitted across the drops; a step in q below a depth is tried at every depth two
    drops cross, and the largest share of the misfit it removes is set against the same with each drop's misfit
    rotated along its own samples. Verdict 'layer' (its depth [mm] and step [kPa]), 'unexplained' (the misfit lines
    up across drops but a step removes less than half of it) or 'none'.

    Example: pen drops diagnose 'drop-*' -p freefall_cone -e drop_water
    """
    probe = api.free_fall_probe(penetrator, energizing)
    drops = api.read_drops(refs, db_path(db), calibration)
    result = api.diagnose_drops(drops, probe, false_alarm=false_alarm, shuffles=shuffles, seed=seed)
    record = {"verdict": result.verdict, "layer_depth_m": result.layer_depth_m if result.verdict == "layer" else None,
              "layer_step_kpa": result.layer_step_kpa if result.verdict == "layer" else None,
              "best_step": {"depth_m": result.layer_depth_m, "step_kpa": result.layer_step_kpa,
                            "share": result.share},
              "p_value": result.p_value, "false_alarm": result.false_alarm,
              "reference": dict(zip(("strength_kpa", "gradient_kpa_m", "damping_kpa_s_m"), result.reference)),
              "heldout_rms_reference_kpa": result.heldout_rms_reference_kpa,
              "heldout_rms_layer_kpa": result.heldout_rms_layer_kpa, "drops": result.drops,
              "bed_verdict": result.bed_verdict, "accelerometer": _accelerometer_record(result.accelerometer),
              "notes": list(result.notes)}
    if json_out:
        print_json(record)
        return
    said = (f"layer at {1e3 * result.layer_depth_m:.0f} mm, q {'rises' if result.layer_step_kpa > 0 else 'falls'} by "
            f"{abs(result.layer_step_kpa):.1f} kPa below it" if result.verdict == "layer" else
            f"accelerometer_bias in {', '.join(result.accelerometer.biased)} (the bed: {result.bed_verdict})"
            if result.verdict == "accelerometer_bias" else result.verdict)
    console.print(f"{result.drops} drops: {said}  (p = {result.p_value:.3f} against {shuffles} rotations; a "
                  f"layer's step removes {100 * result.share:.0f} % of the straight law's misfit; held-out RMS "
                  f"{result.heldout_rms_reference_kpa:.2f} kPa without, {result.heldout_rms_layer_kpa:.2f} kPa with)")
    for note in result.notes:
        console.print(f"  note: {escape(note)}")


def _accelerometer_record(check) -> dict | None:
    """The accelerometers' check as JSON: the drops it finds biased, those a step at the impact accounts for, and
    each drop's speed at rest and its z under both bias models."""
    if check is None:
        return None
    return {"biased": list(check.biased), "stepped_at_impact": list(check.stepped), "threshold_z": check.threshold_z,
            "untested": list(check.untested),
            "rest_speed": {name: {"ramp_m_s": check.ramp[name].speed_m_s, "ramp_z": check.ramp[name].z,
                                  "step_m_s": check.step[name].speed_m_s, "step_z": check.step[name].z}
                           for name in check.ramp}}


@drops_app.command("report")
def report(
    refs: List[str] = DROPS,
    out: Path = typer.Option(..., "--out", help="The report to write (.html; a PDF is written beside it)."),
    penetrator: Optional[str] = typer.Option(None, "--penetrator", "-p", help="With --energizing: also fit the "
                                             "bed across the drops for this probe (a cone preset or file)."),
    energizing: Optional[str] = typer.Option(None, "--energizing", "-e", help="The fall (a free-fall launcher "
                                             "preset or file) for the bed's fit."),
    calibration: Optional[Path] = CALIBRATION,
    pdf: bool = typer.Option(True, "--pdf/--no-pdf", help="Also write the report as PDF beside the HTML."),
    db: Optional[Path] = DbOption,
) -> None:
    """A report of free-fall drops: per drop, its release, impact, penetration, the sensors' biases and its
    figure; with -p and -e, the bed fitted across them first. One self-contained HTML file (and a PDF).

    Example: pen drops report 'drop-*' -p freefall_cone -e drop_water --out drops.html
    """
    if out.suffix.lower() not in (".html", ".htm"):
        raise typer.BadParameter(f"'{out}' must end in .html", param_hint="--out")
    if (penetrator is None) != (energizing is None):
        raise typer.BadParameter("give both --penetrator and --energizing to fit the bed, or neither",
                                 param_hint="--penetrator/--energizing")
    api.check_output(out, db_path(db), "--out")  # never onto the workspace
    probe = api.free_fall_probe(penetrator, energizing) if penetrator is not None else None
    drops = api.read_drops(refs, db_path(db), calibration)
    for written in api.report_drops(drops, out, pdf=pdf, probe=probe):
        console.print(f"wrote {escape(str(written))}")


@drops_app.command("simulate")
def simulate(
    out: Path = typer.Option(..., "--out", help="The BlueDrop record to write (.bin)."),
    height_m: float = typer.Option(1.5, "--height-m", help="Release height above the bed [m]."),
    bed: str = typer.Option("20,100,5", "--bed", metavar="SIGMA,B,C",
                            help="The bed's q = σ + b·z + c·v: σ [kPa], b [kPa/m], c [kPa·s/m]."),
    layer: Optional[str] = typer.Option(None, "--layer", metavar="DEPTH_M:STEP_KPA",
                                        help="A layer: q changes by STEP [kPa] below DEPTH [m] into the bed."),
    bias_g: float = typer.Option(0.02, "--bias-g", help="Each accelerometer's bias drawn within ± this [g]."),
    impact_shift_g: float = typer.Option(0.0, "--impact-shift-g", help="Each accelerometer's bias shifts by this "
                                         "at the impact (a shock's zero offset, hidden from the rests) [g]."),
    rest_tilt_deg: float = typer.Option(0.0, "--rest-tilt-deg", help="The angle the probe leans to from the "
                                        "vertical once it has stopped, towards a random side (its tilt channels "
                                        "read it) [°]."),
    bed_density: float = typer.Option(0.0, "--bed-density", help="The bed's bulk density, which buoys the "
                                      "cone's volume below its surface (1,900 a saturated sand; 0: none) "
                                      "[kg/m³]."),
    seed: int = typer.Option(0, "--seed", help="Seed of the biases and the sensors' noise."),
    calibration_out: Optional[Path] = typer.Option(None, "--calibration-out", help="Where the calibration sheet "
                                                   "goes (CSV; default calibration.csv beside --out)."),
    json_out: bool = typer.Option(False, "--json", help='Print the truth: {"impact_speed_m_s", "penetration_mm", '
                                                        '...}.'),
    db: Optional[Path] = DbOption,
) -> None:
    """Simulate a drop of a BlueDrop-sized probe (the freefall_cone preset in drop_water) through seawater into a
    bed, read by its five accelerometers (each with its own bias, noise, range and counts), pore pressure and tilt,
    and write it as a BlueDrop record with its calibration sheet: synthetic truth for pen drops.

    Example: pen drops simulate --height-m 1.5 --bed 20,100,5 --out drop-01.bin
    """
    if out.suffix.lower() != ".bin":
        raise typer.BadParameter(f"'{out}' must end in .bin", param_hint="--out")
    try:
        values = tuple(float(v) for v in bed.split(","))
    except ValueError:
        values = ()
    if len(values) != 3:
        raise typer.BadParameter(f"'{bed}': expected three numbers SIGMA,B,C (kPa, kPa/m, kPa·s/m)",
                                 param_hint="--bed")
    if layer is not None:
        try:
            depth, _, step = layer.partition(":")
            values = (*values, float(depth), float(step))
        except ValueError:
            raise typer.BadParameter(f"'{layer}': expected DEPTH_M:STEP_KPA, e.g. 0.15:10", param_hint="--layer")
    api.check_output(out, db_path(db), "--out")
    if calibration_out is not None:
        api.check_output(calibration_out, db_path(db), "--calibration-out")
    truth, sheet, biases = api.simulate_drop_file(out, height_m=height_m, bed=values, bias_g=bias_g, seed=seed,
                                                  calibration_out=calibration_out, impact_shift_g=impact_shift_g,
                                                  rest_tilt_deg=rest_tilt_deg, bed_density_kg_m3=bed_density)
    record = {"out": str(out), "calibration": str(sheet), "release_s": truth.release_s, "impact_s": truth.impact_s,
              "impact_speed_m_s": truth.impact_speed_m_s, "penetration_mm": 1e3 * truth.penetration_m,
              "stop_s": truth.stop_s, "bias_g": biases}
    if json_out:
        print_json(record)
        return
    console.print(f"wrote {escape(str(out))} and {escape(str(sheet))}: the truth is impact at "
                  f"{truth.impact_speed_m_s:.3f} m/s, {1e3 * truth.penetration_m:.1f} mm into the bed")
