"""What each report shows: the sections for a run, a fitted material version, a sweep and a diagnosis.

The API finds the workspace rows and runs the analyses; these functions turn them into
:class:`~pencli.report.build.Section` objects (tables, figures, provenance).  Reading only: nothing here
writes to the workspace.
"""

from __future__ import annotations

import json
from typing import Any, Mapping, Sequence

import numpy as np

from pencli.report.build import Section

REFERENCE_ESTIMATES = {  # paper Table 1, "other mechanical properties for reference"
    "grill_brick": ((0.5, 0.75), (1000.0, 1000.0)),
    "mpacs_b": ((0.75, 2.0), (100.0, 125.0)),
    "mpacs_c": ((5.0, 8.0), (200.0, 250.0)),
    "mpacs_d": ((20.0, 25.0), (700.0, 850.0)),
}
"""Cone index [MPa] and unconfined compressive strength [kPa] ranges per material (Fig. 16's estimates)."""

SWEEP_FIGURES = ("penetration_time_s", "peak_resistance_n", "residual_ke_j", "final_depth_mm")
"""The CONTRACT §5 figures a sweep report summarises and maps."""


def parameter_rows(mapping: Mapping[str, Any]) -> list[list[Any]]:
    """(parameter, value, unit, file key) rows of one parameter mapping: names and units from the parameter
    definitions (:mod:`pencli.labels`), the key as the file spells it last."""
    from pencli.labels import quantity
    from pencli.params.definitions import BY_KEY

    flat: dict[str, Any] = {}
    for key, value in mapping.items():  # in the file's order, coefficients where the file has them
        if key == "coefficients" and isinstance(value, dict):
            flat.update({f"coefficients.{sub}": v for sub, v in value.items()})
        else:
            flat[key] = value
    return [[quantity(key).name, value, BY_KEY[key].unit, key] for key, value in flat.items() if key in BY_KEY]


def latest_fit_with(versions: Sequence[dict], run_id: str) -> dict | None:
    """The newest fitted material version (of ``versions``, oldest first) that used ``run_id``."""
    used = [v for v in versions if run_id in (v["source_runs"] or [])]
    return used[-1] if used else None


def _design_with_fit(run, coefficients: Mapping[str, float]):
    """A run's design with the fit's coefficients, and its material set."""
    from pencli.fit.resistance import with_coefficients

    return with_coefficients(run.design, coefficients), run.material


class _RunData:
    """What a run's section and a campaign's figures read from the workspace: the parameters, stages, raw
    channels, events, the conditioned (inertia) stage and the newest fit that used the run."""

    def __init__(self, ws, run_id: str, versions: Sequence[dict]):
        self.run_id = run_id
        self.params = ws.run_parameters(run_id)
        self.stages = ws.stages(run_id)
        self.row = ws.run_row(run_id)
        self.raw = ws.load_run(run_id, "raw")
        tares = [s for s in self.stages if s.stage == "tare"]
        self.events = tares[-1].parameters["events"] if tares else self.raw.tared().events.to_dict()
        inertia = [s for s in self.stages if s.stage == "inertia"]
        self.conditioned = ws.load_run(run_id, inertia[-1].stage_no) if inertia else None
        self.fit = latest_fit_with(versions, run_id)

    def balance(self):
        """The measured energy balance with the fit's coefficients (None without a fit or a conditioned stage)."""
        from pencli.fit.energy import measured_energy

        if self.fit is None or self.conditioned is None:
            return None
        return measured_energy(self.conditioned, json.loads(self.fit["coefficients"]),
                               json.loads(self.fit["fit"])["ci95"])


def _event_value(key: str, value: float) -> tuple[float, str]:
    """An event as a report shows it: times in ms, speeds in m/s, depths in mm."""
    if key.endswith("_m_s"):
        return value, "m/s"
    if key.endswith("_s"):
        return value * 1e3, "ms"
    if key.endswith("_m"):
        return value * 1e3, "mm"
    return value, ""


def run_section(ws, run_id: str, versions: Sequence[dict], figures: bool = True, data: _RunData | None = None
                ) -> Section:
    """A run: parameters, stages, events and, with ``figures``, raw channels (Fig. 11), measurements (Fig. 12),
    model against data (Fig. 13) and energy per term (Fig. 14) with the newest fit that used it."""
    from pencli.report import figures as draw

    run = data or _RunData(ws, run_id, versions)
    events = run.events
    section = Section(f"run {run_id}", provenance={"run": {k: str(v) for k, v in run.row.items()}})
    rows = [r for kind in ("penetrator", "material", "energizing") for r in parameter_rows(run.params[kind])]
    section.tables.append(("parameters", ["parameter", "value", "unit", "file key"], rows))
    section.tables.append(("stages", ["#", "stage", "command", "pen", "created (UTC)"],
                           [[s.stage_no, s.stage, s.command, s.pen_version, str(s.created_at)] for s in run.stages]))
    section.tables.append(("events (times since the release)", ["event", "value", "unit"],
                           [[k, *_event_value(k, v)] for k, v in events.items() if isinstance(v, (int, float))]))
    if not figures:
        section.text = (f"This run is drawn with the others above; pen report {run_id} draws its own raw channels, "
                        f"measurements, model against data and energy balance.")
        return section
    section.add_figure(*draw.raw_channels(run_id, run.raw.columns, events), paper="Fig. 11")
    if run.conditioned is not None:
        section.add_figure(*draw.kinematics_panels(run_id, run.conditioned.columns, events,
                                                   run.raw.penetrator.geometry), paper="Fig. 12")
    fit = run.fit
    if fit is not None and fit["model_data_path"]:
        table = ws.read_table(fit["model_data_path"], "fit's model-vs-data table",
                              filters=[("run_id", "=", run_id)]).to_pydict()
        section.add_figure(*draw.model_vs_data(run_id, {k: np.asarray(v) for k, v in table.items()}),
                           paper="Fig. 13")
        balance = run.balance()
        if balance is not None:
            fig, caption = draw.energy_balance(run_id, balance, f"{fit['material']} v{fit['version']}",
                                               run.raw.penetrator.geometry)
            section.add_figure(fig, caption, paper="Fig. 14")
    return section


def campaign_sections(ws, run_ids: Sequence[str], versions: Sequence[dict]) -> list[Section]:
    """Several runs: one section that draws them together (raw channels, Fig. 11; measurements, Fig. 12; model
    against data per fit, Figs. 13–14; where the energy went, Fig. 14), then each run's tables."""
    from pencli.report import figures as draw

    runs = [_RunData(ws, run_id, versions) for run_id in run_ids]
    section = Section(f"{len(runs)} runs together")
    section.tables.append(("runs", ["run", "material", "blade thickness [mm]", "springs", "speed at contact [m/s]",
                                    "final depth [mm]", "end", "newest fit"],
                           [[r.run_id, r.row["material"], r.row["blade_thickness_mm"], r.row["spring_count"],
                             r.events.get("contact_speed_m_s"), 1e3 * r.events.get("final_depth_m", float("nan")),
                             r.events.get("end"), f"{r.fit['material']} v{r.fit['version']}" if r.fit else "none"]
                            for r in runs]))
    section.add_figure(*draw.campaign_raw([(r.run_id, r.raw.columns, r.events) for r in runs]), paper="Fig. 11")
    conditioned = [(r.run_id, r.conditioned.columns, r.events) for r in runs if r.conditioned is not None]
    if conditioned:
        section.add_figure(*draw.campaign_kinematics(conditioned), paper="Fig. 12")
    colours = draw.run_colours(run_ids)
    by_fit: dict[tuple, list[_RunData]] = {}
    for r in runs:
        if r.fit is not None and r.fit["model_data_path"]:
            by_fit.setdefault((r.fit["material"], r.fit["version"]), []).append(r)
    for (material, version), mine in by_fit.items():
        fit = mine[0].fit
        ids = [r.run_id for r in mine]
        table = ws.read_table(fit["model_data_path"], "fit's model-vs-data table",
                              filters=[("run_id", "in", ids)]).to_pydict()
        section.add_figure(*draw.campaign_fit(f"{material} v{version}", {k: np.asarray(v) for k, v in table.items()},
                                              fitted_runs=len(fit["source_runs"] or []), colours=colours),
                           paper="Figs. 13–14")
    balances = [(r.run_id, b) for r in runs if (b := r.balance()) is not None]
    if balances:
        section.add_figure(*draw.campaign_energy(balances), paper="Fig. 14")
    return [section, *(run_section(ws, r.run_id, versions, figures=False, data=r) for r in runs)]


def material_section(ws, row: Mapping[str, Any]) -> Section:
    """A fitted material version (its catalogue row): coefficients, intervals, runs, Fig. 13 per run (first
    12), and the model against simpler estimates on the median run (Fig. 16)."""
    from pencli.model.dynamics import simulate
    from pencli.model.resistance import TERMS, coefficient_of
    from pencli.report import figures

    material = row["material"]
    fit = json.loads(row["fit"])
    units = {coefficient_of(t).key.removeprefix("coefficients."): coefficient_of(t).unit for t in TERMS}
    section = Section(f"material {material} v{row['version']} ({fit['mode']} fit over {len(fit['runs'])} runs)",
                      text=" ".join(fit.get("warnings", [])), provenance={"catalog": {k: str(v) for k, v in row.items()
                                                                                    if k not in ("fit",)}})
    section.tables.append(("coefficients", ["coefficient", "value", "std. error", "95 % low", "95 % high", "unit"],
                           [[n, v, fit["stderr"][n], *(fit["ci95"][n] or [None, None]), units[n]]
                            for n, v in fit["coefficients"].items()]))
    section.tables.append(("runs", ["run", "samples", "RMS [N]", "NRMSE", "R²"],
                           [[r["run_id"], r["n_samples"], r["rms_n"], r["nrmse"], r["r2"]] for r in fit["runs"]]))
    section.add_figure(*figures.fit_intervals(material, fit))
    if row["model_data_path"]:
        table = ws.read_table(row["model_data_path"], "fit's model-vs-data table").to_pydict()
        ids = np.asarray(table["run_id"])
        section.add_figure(*figures.campaign_fit(material, {k: np.asarray(v) for k, v in table.items()}),
                           paper="Figs. 13–14")
        for run_id in list(dict.fromkeys(table["run_id"]))[:12]:
            sel = ids == run_id
            section.add_figure(*figures.model_vs_data(run_id, {k: np.asarray(v)[sel] for k, v in table.items()}),
                               paper="Fig. 13")
    runs = row["source_runs"]
    median_run = runs[len(runs) // 2]
    median = ws.load_run(median_run, "raw")
    design, m = _design_with_fit(median, fit["coefficients"])
    tr = simulate(design, output_rate_hz=20_000.0, geometry=median.geometry).trajectory
    inside = tr.phase == 1
    cone, ucs = REFERENCE_ESTIMATES.get(m.name, (None, None))
    section.add_figure(*figures.estimates_comparison(
        f"{median_run} (the fit's median run)", tr.depth_m[inside] * 1e3, tr.resistance_n[inside],
        design.frontal_area_m2, cone, ucs), paper="Fig. 16")
    return section


def sweep_section(ws, record: Mapping[str, Any]) -> Section:
    """A sweep (its catalogue row): variables, ranges of the figures, heat maps with the full-penetration
    boundary (Fig. 14), 4-D scatter (Fig. 15), partial dependence."""
    from pencli.labels import quantity
    from pencli.predict.batch import ENDS, NOT_SIMULATED
    from pencli.report import figures

    sweep_id = record["sweep_id"]
    variables = json.loads(record["variables"])
    keys = list(variables)
    wanted = list(dict.fromkeys([*keys, *SWEEP_FIGURES, "full_penetration", "end"]))  # what the figures need
    arrow = ws.read_table(record["path"], f"sweep {sweep_id}'s table", columns=wanted)
    table = {name: arrow.column(name).to_numpy(zero_copy_only=False) for name in wanted}
    base = json.loads((arrow.schema.metadata or {}).get(b"pen:base", b"null"))
    del arrow
    section = Section(f"sweep {sweep_id}: {record['penetrator']} · {record['material']} · {record['energizing']}",
                      provenance={k: str(v) for k, v in record.items()})
    grid = int(np.prod([v["points"] for v in variables.values()])) == int(record["n_designs"])
    section.tables.append(("variables", ["parameter", "unit", "min", "max", "values", "file key"],
                           [[quantity(k).name, v["unit"], v["min"], v["max"],
                             v["points"] if grid else f"sampled ({record['n_designs']} designs)", k]
                            for k, v in variables.items()]))
    section.tables.append(("figures over the sweep", ["figure", "min", "max", "unit"],
                           [[quantity(f).name, *_finite_range(table[f], quantity(f).scale), quantity(f).unit]
                            for f in SWEEP_FIGURES]))
    skipped = {end: int(n) for end, n in zip(*np.unique(np.asarray(table["end"]), return_counts=True))
               if end in ENDS[NOT_SIMULATED:]}
    if skipped:
        section.text = ("Designs not simulated (no figures; left out of every map and range): "
                        + ", ".join(f"{n} {end}" for end, n in skipped.items()) + ".")
    pairs = [(a, b) for i, a in enumerate(keys) for b in keys[i + 1:]]
    for n, (x, y) in enumerate(pairs):  # final depth for every pair; energy left and time for the first
        others = [k for k in keys if k not in (x, y)]
        for value in (("final_depth_mm", "residual_ke_j", "penetration_time_s") if n == 0 else ("final_depth_mm",)):
            section.add_figure(*figures.sweep_map(table, x, y, value, others,
                                                  sweep_boundary(table, base, x, y, others) if grid else None),
                               paper="Fig. 14")
    if len(keys) >= 3:
        section.add_figure(*figures.sweep_scatter(table, keys), paper="Fig. 15")
    section.add_figure(*figures.sweep_partial(table, keys))
    return section


def _finite_range(values: np.ndarray, scale: float) -> list[float | None]:
    """(min, max) × ``scale`` of a sweep figure over the designs that have one (None, None when none has)."""
    finite = np.asarray(values, dtype=float)
    finite = finite[np.isfinite(finite)]
    return [float(finite.min()) * scale, float(finite.max()) * scale] if finite.size else [None, None]


def sweep_boundary(table: Mapping[str, np.ndarray], base: Mapping[str, float] | None, x: str, y: str,
              others: Sequence[str]) -> np.ndarray | None:
    """Where a grid sweep's full-penetration boundary crosses the lines of its (x, y) grid, the other varied
    parameters held at their middle values (as the map holds them), found on the simulator; None without the
    sweep's base parameters (a table from an older pen) or for a sample."""
    from pencli.predict.sweep import boundary_roots
    from pencli.report.figures import held_level

    if not base:
        return None
    keep = np.ones(len(table[x]), dtype=bool)
    held = {}
    for key in others:
        middle = held_level(table[key])
        if middle is None:  # the map averages over this one: no slice to find a boundary on
            return None
        held[key] = middle
        keep &= np.asarray(table[key], dtype=float) == middle
    px, py = np.asarray(table[x], dtype=float)[keep], np.asarray(table[y], dtype=float)[keep]
    xs, ys = np.unique(px), np.unique(py)
    if xs.size < 2 or ys.size < 2 or xs.size * ys.size != px.size:
        return None
    full = np.zeros((ys.size, xs.size), dtype=bool)
    full[np.searchsorted(ys, py), np.searchsorted(xs, px)] = np.asarray(table["full_penetration"], dtype=bool)[keep]
    ran = np.zeros_like(full)  # designs not simulated have no figures
    ran[np.searchsorted(ys, py), np.searchsorted(xs, px)] = np.isfinite(
        np.asarray(table["final_depth_mm"], dtype=float))[keep]
    return boundary_roots(base, x, y, xs, ys, full, held, simulated=ran)


def diagnosis_section(result) -> Section:
    """A diagnosis: verdict, effects best first, where the gap lies, what the misfit follows, the figure."""
    from pencli.diagnose import params_text
    from pencli.report.diagnosis import diagnosis_caption, diagnosis_figure

    report = result.to_dict()
    section = Section(f"diagnosis: verdict {result.verdict}", text=" ".join(result.notes),
                      provenance={"baseline": report["baseline"], "decision": report["decision"]})
    section.tables.append(("effects, best first", ["effect", "held-out RMS [N]", "shrink [%]", "z", "significant",
                                                   "detectable RMS [N]", "parameters"],
                           [[e.name, e.heldout_rms_n, e.shrink_pct, e.z, e.significant, e.detectable_rms_n,
                             params_text(e.params)] for e in result.effects]))
    if result.verdict == "none":
        section.tables.append(("where the gap lies: no gap beyond the noise", ["phase"], []))
    else:
        section.tables.append(("where the gap lies", ["phase", "depth [mm]", "time [ms]", "share of gap"],
                               [[w["phase"], w.get("depth_mm"), w.get("time_ms"), w.get("share_of_gap")]
                                for w in result.where if w.get("above_noise")]))
    section.tables.append(("what the misfit follows (share of the baseline's held-out misfit explained by its "
                           "mean along each axis, in the material; run: the share that differs from run to run)",
                           list(result.axes), [list(result.axes.values())]))
    section.add_figure(diagnosis_figure(result), diagnosis_caption(result))
    return section


def sounding_section(sounding, cut, resistance: np.ndarray, quantity: str, unit: str, rate_mm_s: float | None,
                     described: tuple[str, str, str]) -> Section:
    """A field sounding: what it is, its header as the file gives it, its layers (``cut``, a
    :class:`pencli.fit.layers.Cut` of ``resistance``: qt or qc [MPa], or a total sounding's push force [kN]) and
    its profile with the layers drawn (``described``: the resistance's (what, unit, symbol) for the figure)."""
    from pencli.report import figures

    c = sounding.columns
    depth = c["depth_m"]
    rate = "no clock" if rate_mm_s is None else f"pushed at {rate_mm_s:.1f} mm/s (from its clock)"
    nominal = sounding.header_number("push_rate_mm_s")
    if rate_mm_s is None and nominal is not None:
        rate = f"pushed at a nominal {nominal:g} mm/s (its file's)"
    section = Section(f"sounding {sounding.name}",
                      text=f"{sounding.kind}, {depth.size} rows from {depth[0]:.2f} to {depth[-1]:.2f} m, {rate}; "
                           f"read from {sounding.source}. Its {quantity} is cut into {len(cut.layers)} layers, each "
                           f"a straight line in depth (scatter about the lines {100 * cut.scatter:.1f} %, row-to-row "
                           f"correlation {cut.correlation:.2f}).",
                      provenance={"source": sounding.source, "method": sounding.method})
    fs = c.get("fs_kpa")
    section.tables.append((f"layers of {quantity}", ["top [m]", "bottom [m]", f"{quantity} top [{unit}]",
                                                     f"{quantity} bottom [{unit}]", "fs mean [kPa]"],
                           [[layer.top_m, layer.bottom_m, layer.q_top, layer.q_bottom, layer.mean_of(fs)]
                            for layer in cut.layers]))
    section.tables.append(("the file's header", ["key", "value"], [[k, v] for k, v in sounding.header.items()]))
    section.add_figure(*figures.sounding_profile(sounding.name, depth, c.get("qc_mpa", resistance), fs,
                                                 c.get("u2_kpa"), resistance if quantity == "qt" else None, layers=cut,
                                                 resistance=described))
    return section


def snow_section(result) -> Section:
    """A SnowMicroPen profile (:class:`pencli.api.SnowProfile`): where the snow is, the shot-noise windows, each
    given layer's medians and the profile's figure."""
    from pencli.report import figures

    est = result.estimates
    section = Section(f"SnowMicroPen profile {result.profile.name}",
                      text=f"Snow from {result.surface_mm:.1f} to {result.bottom_mm:.1f} mm after the motor's start; "
                           f"{est.depth_mm.size} windows of the shot-noise estimates (Löwe and van Herwijnen 2012), "
                           f"{int(est.clipped.sum())} of them at the sensor's range and left out of the medians.",
                      provenance={"source": str(result.profile.source)})
    if result.layers:
        section.tables.append(("each layer's medians over its windows",
                               ["layer [mm below the surface]", "windows", "strength [kPa]", "f₀ [N]", "δ [mm]",
                                "λ [1/mm]", "L [mm]"],
                               [[f"{layer.top_mm:g}–{layer.bottom_mm:g}", layer.windows, layer.strength_kpa,
                                 layer.rupture_force_n, layer.deflection_mm, layer.intensity_per_mm,
                                 layer.element_size_mm] for layer in result.layers]))
    section.add_figure(*figures.snow_profile(result.profile.name, est, result.layers))
    return section


def drop_section(drop) -> Section:
    """A free-fall drop (:class:`pencli.api.Drop`): release, impact, speed at impact, penetration, the sensors'
    biases, and its figure."""
    from pencli.diagnose.drops import rest_speed
    from pencli.report import figures

    m = drop.motion
    t = m.time_s
    still = rest_speed(m)
    checked = (f" Over the rest after the stop, where the probe lies still, the integrated speed is "
               f"{still.speed_m_s:+.4f} m/s, {still.z:.1f} standard deviations of the integrated noise beyond the "
               f"{m.rest_speed_bound_m_s:.4f} m/s the integration leaves (pen drops diagnose names a bias the rests "
               f"did not show from this)." if still.speed_m_s == still.speed_m_s else
               " The record has no rest after the stop, so the bias there is not checked.")
    section = Section(f"Free-fall drop {drop.name}",
                      text=f"Released at {t[m.release]:.3f} s, met the bed at {m.impact_s:.4f} s at "
                           f"{m.impact_speed_m_s:.3f} m/s and stopped {1e3 * m.penetration_m:.1f} mm into it at "
                           f"{t[m.stop]:.3f} s; largest deceleration {m.peak_deceleration_g:.1f} g. The speed and "
                           f"depth are the stitched accelerometers integrated from the release, each sensor's bias "
                           f"taken at rest before the release and after the stop." + checked,
                      provenance={"source": str(drop.record.source)})
    section.tables.append(("each accelerometer's bias at rest", ["sensor", "before the release [g]",
                                                                 "after the stop [g]"],
                           [[name, before, after] for name, (before, after) in m.bias_g.items()]))
    section.add_figure(*figures.drop_motion(drop.name, m))
    return section


def drop_fit_section(fit, probe) -> Section:
    """The bed fitted across drops (:class:`pencli.fit.freefall.BedFit`)."""
    return Section("The bed across the drops",
                   text=f"q = σ + b·z + c·v on the cone's frontal area, fitted over {fit.samples} samples of "
                        f"{fit.drops} drops where the whole cone is in the bed and the probe moves faster than "
                        f"0.05 m/s (probe {probe.mass_kg:g} kg, {probe.volume_m3 * 1e3:g} L, C_D "
                        f"{probe.drag_coefficient:g}, C_a {probe.added_mass_coefficient:g}, fluid "
                        f"{probe.water_density:g} kg/m³)"
                        + (f"; the drag and added-mass coefficients fitted from the fall as well: "
                           f"{fit.drag_coefficient:.3f} and {fit.added_mass_coefficient:.3f}"
                           if fit.drag_coefficient is not None else "")
                        + f". Residual RMS {100 * fit.relative_rms:.1f} % of the bed's mean force. The standard "
                          f"errors are least squares' and too small where the residuals are correlated from sample "
                          f"to sample.",
                   tables=[("the bed's pressure", ["term", "value", "standard error", "unit"],
                            [["σ (at the surface)", fit.strength_kpa, fit.standard_errors[0], "kPa"],
                             ["b (per metre of depth)", fit.gradient_kpa_m, fit.standard_errors[1], "kPa/m"],
                             ["c (per m/s of speed)", fit.damping_kpa_s_m, fit.standard_errors[2], "kPa·s/m"]])])


__all__ = ["REFERENCE_ESTIMATES", "drop_fit_section", "drop_section", "campaign_sections", "diagnosis_section", "latest_fit_with", "material_section", "parameter_rows",
           "run_section", "snow_section", "sounding_section", "sweep_section"]
