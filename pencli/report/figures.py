"""The figures of pen's reports (paper Figs. 11–18), drawn from result objects and arrays only.

Each function returns a matplotlib Figure and never reads files; ``report.build``
places them.  matplotlib is imported inside, so importing this module is cheap.
"""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from pencli.labels import label, quantity

TERM_COLOURS = {"strength": "#4C72B0", "friction": "#DD8452", "damping": "#55A868", "inertia": "#C44E52"}


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


MEASURED, EQ9, DYNAMIC = "k", "tab:blue", "tab:orange"
"""One colour per source in every figure: the measurement, Eq. 9 on the measured motion, the fully predicted run."""
WINDOW_SHADE = {"color": "tab:green", "alpha": 0.12, "lw": 0}
"""How the analysis window is shaded wherever it is drawn."""


THIN_POINTS = 1500
"""A line of more samples than twice this is drawn from each of this many equal bins' lowest and highest sample:
every peak a screen or page can show is kept, and a 13,000-sample record's figure stays small. [–]"""


OVERLAY_THIN_POINTS = 500
""":data:`THIN_POINTS` for a figure that overlays many runs: each line a third as fine, the figure as light as one
run's. [–]"""


def _thin(x: np.ndarray, *ys: np.ndarray, bins: int = THIN_POINTS) -> tuple[np.ndarray, ...]:
    """(x, *ys) with each of ``bins`` equal bins reduced to its samples at the lowest and highest value of the
    first y (in time order), or as they are when short."""
    n = len(x)
    if n <= 2 * bins:
        return (x, *ys)
    edges = np.linspace(0, n, bins + 1).astype(int)
    keep = []
    ref = ys[0]
    for a, b in zip(edges[:-1], edges[1:]):
        lo, hi = a + int(np.argmin(ref[a:b])), a + int(np.argmax(ref[a:b]))
        keep.extend(sorted({lo, hi}))
    keep = np.asarray(keep)
    return (x[keep], *(y[keep] for y in ys))


def raw_channels(run_id: str, raw: Mapping[str, np.ndarray], events: Mapping[str, float]):
    """Fig. 11: raw position and forces over the stored span, the analysed window shaded.

    Returns the figure and its caption (the window and the peak axial force, with numbers)."""
    plt = _plt()
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True, constrained_layout=True)
    t = raw["time_s"] * 1e3
    ax1.plot(*_thin(t, raw["position_mm"]), lw=0.8, color=MEASURED)
    ax1.set_ylabel(label("position_mm"))
    for name in ("fx_n", "fy_n", "fz_n"):
        ax2.plot(*_thin(t, raw[name]), lw=0.6, label=quantity(name).name)
    ax2.set_ylabel("force [N]")
    ax2.set_xlabel(label("time_s"))
    ax2.legend(fontsize=7)
    start, end = events["window_start_s"] * 1e3, events["window_end_s"] * 1e3
    for ax in (ax1, ax2):
        ax.axvspan(start, end, **WINDOW_SHADE)
    inside = int(np.count_nonzero((t >= start) & (t <= end)))
    caption = (f"{run_id}: raw channels over the stored {t[-1] - t[0]:.0f} ms; the analysis window (shaded) runs "
               f"{start:.1f}–{end:.1f} ms after the release, {inside} of {t.size} samples; peak axial force "
               f"{float(np.max(raw['fz_n'])):.0f} N.")
    return fig, caption


def kinematics_panels(run_id: str, stage: Mapping[str, np.ndarray], events: Mapping[str, float],
                      shape: str = "blade"):
    """Fig. 12: depth, force and resistance, speed and acceleration against time around the penetration.

    Returns the figure and its caption (contact, speed at contact, how and where the motion stopped)."""
    plt = _plt()
    fig, axes = plt.subplots(2, 2, figsize=(10, 6), sharex=True, constrained_layout=True)
    t = stage["time_s"]
    near = (t > events["motion_start_s"] - 0.01) & (t < events["stop_s"] + 0.02)
    tm = t[near] * 1e3
    axes[0, 0].plot(tm, stage["depth_m"][near] * 1e3, color=MEASURED, lw=0.8)
    axes[0, 0].set_ylabel(label("depth_m"))
    axes[0, 1].plot(tm, stage["force_n"][near], lw=0.6, color="0.55", label=quantity("force_n").name)
    axes[0, 1].plot(tm, stage["resistance_n"][near], lw=0.8, color=MEASURED, label="resistance R = F − m·a")
    axes[0, 1].set_ylabel("force [N]")
    axes[0, 1].legend(fontsize=7)
    axes[1, 0].plot(tm, stage["velocity_m_s"][near], color=MEASURED, lw=0.8)
    axes[1, 0].set_ylabel(label("velocity_m_s"))
    axes[1, 1].plot(tm, stage["acceleration_m_s2"][near], color=MEASURED, lw=0.8)
    axes[1, 1].set_ylabel(label("acceleration_m_s2"))
    for ax in axes.ravel():
        ax.axvspan(events["window_start_s"] * 1e3, events["window_end_s"] * 1e3, **WINDOW_SHADE)
        ax.axvline(events["contact_s"] * 1e3, color="grey", ls="--", lw=0.8)
        ax.axvline(events["stop_s"] * 1e3, color="grey", ls=":", lw=0.8)
    for ax in axes[1]:
        ax.set_xlabel(label("time_s"))
    how = "was arrested" if events.get("end") == "arrest" else "reached the hard stops"
    caption = (f"{run_id}: contact (dashed) at {events['contact_s'] * 1e3:.1f} ms at "
               f"{events['contact_speed_m_s']:.2f} m/s; the {shape.replace('_', ' ')} {how} (dotted) at "
               f"{events['stop_s'] * 1e3:.1f} ms, "
               f"{events['final_depth_m'] * 1e3:.1f} mm deep; shaded: the analysis window.")
    return fig, caption


def _fit_figures(measured: np.ndarray, model: np.ndarray) -> tuple[float, float]:
    """(RMS [N], R²) of ``model`` against ``measured``."""
    residual = measured - model
    rms = float(np.sqrt(np.mean(residual ** 2))) if residual.size else float("nan")
    spread = float(np.sum((measured - measured.mean()) ** 2)) if measured.size else 0.0
    return rms, (1.0 - float(np.sum(residual ** 2)) / spread) if spread > 0 else float("nan")


def model_vs_data(run_id: str, data: Mapping[str, np.ndarray]):
    """Fig. 13: measured resistance against depth with Eq. 9 on the measured motion and the fully predicted run,
    the residual beneath, and depth against time; over the analysis window, RMS and R² in the legends.

    Returns the figure and its caption (what each model leaves, and where the predicted run ends)."""
    plt = _plt()
    fig = plt.figure(figsize=(12, 6), constrained_layout=True)
    grid = fig.add_gridspec(2, 2, height_ratios=[2.2, 1])
    force, residual, motion = fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[1, 0]), fig.add_subplot(grid[:, 1])
    residual.sharex(force)
    window = np.asarray(data["in_window"], dtype=bool)
    depth = np.asarray(data["depth_m"])[window] * 1e3
    measured = np.asarray(data["resistance_n"])[window]
    eq9, dyn = np.asarray(data["resistance_model_n"])[window], np.asarray(data["resistance_dynamic_n"])[window]
    rms, r2 = _fit_figures(measured, eq9)
    rms_d, r2_d = _fit_figures(measured, dyn)
    force.plot(depth, measured, color=MEASURED, lw=0.7, label="measured")
    force.plot(depth, eq9, color=EQ9, lw=1.2, label=f"Eq. 9 on the measured x, v: RMS {rms:.1f} N, R² {r2:.4f}")
    force.plot(depth, dyn, color=DYNAMIC, lw=1.2, ls="--",
               label=f"fully predicted from the launch: RMS {rms_d:.1f} N, R² {r2_d:.4f}")
    force.set_ylabel(label("resistance_n"))
    force.legend(fontsize=7)
    force.tick_params(labelbottom=False)
    residual.axhline(0.0, color="0.4", lw=0.6)
    residual.plot(depth, measured - eq9, color=EQ9, lw=0.7)
    residual.plot(depth, measured - dyn, color=DYNAMIC, lw=0.7, ls="--")
    residual.set_ylabel("measured − model [N]")
    residual.set_xlabel(label("depth_m"))
    t = np.asarray(data["time_s"]) * 1e3
    x_measured, x_predicted = np.asarray(data["depth_m"]) * 1e3, np.asarray(data["depth_dynamic_m"]) * 1e3
    motion.plot(t, x_measured, color=MEASURED, lw=0.8, label="measured")
    motion.plot(t, x_predicted, color=DYNAMIC, lw=1.2, ls="--", label="fully predicted")
    if window.any():
        motion.axvspan(t[window][0], t[window][-1], **WINDOW_SHADE)
    motion.set_xlabel(label("time_s"))
    motion.set_ylabel(label("depth_m"))
    motion.legend(fontsize=7)
    caption = (f"{run_id}: over the analysis window (shaded on the right) Eq. 9 with the measured depth and speed "
               f"leaves {rms:.1f} N RMS (R² {r2:.4f}) and the fully predicted run {rms_d:.1f} N; the predicted "
               f"run ends {float(x_predicted[-1]):.1f} mm deep against {float(x_measured[-1]):.1f} mm measured.")
    return fig, caption


def energy_balance(run_id: str, balance, fit_name: str = "", shape: str = "blade"):
    """Fig. 14 (measured): where a run's energy went.  The launcher's side (what the file's launcher delivers over
    the stand-off against the kinetic energy measured at contact), then what the springs and gravity add in the
    material, each Eq. 9 term with its 95 % interval from the fit, what was left at the stop, and what the fit
    does not account for.  ``balance``: a :class:`~pencli.fit.energy.EnergyBalance`.

    Returns the figure and its caption (each term's share of the energy, and what is not accounted for)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(9, 4.2), constrained_layout=True)
    bars = [("launcher (file)", balance.launcher_j, "0.75", None),
            ("at contact", balance.contact_ke_j, "0.55", None),
            ("springs and gravity\nin the material", balance.drive_in_material_j, "0.55", None)]
    bars += [(term, value, TERM_COLOURS[term], balance.terms_interval_j.get(term))
             for term, value in balance.terms_j.items()]
    bars += [("left at the stop", balance.left_ke_j, "0.3", None),
             ("not accounted for", balance.unaccounted_j, "tab:purple", None)]
    for i, (name, value, colour, span) in enumerate(bars):
        ax.bar(i, value, color=colour)
        if span is not None:
            ax.errorbar(i, value, yerr=[[value - span[0]], [span[1] - value]], color="k", capsize=4, lw=1)
        ax.text(i, max(value, 0.0), f"{value:.1f}", ha="center", va="bottom", fontsize=8)
    ax.axhline(0.0, color="0.3", lw=0.6)
    ax.axvline(1.5, color="0.3", lw=0.8)
    ax.axvline(2.5, color="0.3", lw=0.8, ls=":")
    ax.set_xticks(range(len(bars)), [b[0] for b in bars], fontsize=8, rotation=20, ha="right")
    ax.set_ylabel("energy [J]")
    supplied = balance.supplied_j
    shares = ", ".join(f"{term} {100 * value / supplied:.0f} %" for term, value in balance.terms_j.items()) \
        if supplied > 0 else ""
    caption = (f"{run_id}: the {shape.replace('_', ' ')} reached the surface with {balance.contact_ke_j:.1f} J "
               f"(the launcher file "
               f"gives {balance.launcher_j:.1f} J) and the springs and gravity added {balance.drive_in_material_j:.1f} "
               f"J; of these {supplied:.1f} J{(' the fit ' + fit_name) if fit_name else ''} puts {shares}; "
               f"{balance.left_ke_j:.1f} J were left at the stop and {balance.unaccounted_j:+.1f} J "
               f"({100 * balance.unaccounted_j / supplied:+.1f} %) are not accounted for (bars: 95 % intervals).")
    return fig, caption


MAP_CELLS = 60
"""Cells per axis of a sweep map when a variable takes more values than that (a sampled sweep)."""


def _cells(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(cell centres, cell index of each value): the values themselves on a grid of few values, else
    MAP_CELLS equal cells over their range.  Memory: the values and one index array."""
    values = np.asarray(values, dtype=float)
    levels = np.unique(values)
    if levels.size <= MAP_CELLS:
        return levels, np.searchsorted(levels, values)
    lo, hi = float(np.min(values)), float(np.max(values))
    edges = np.linspace(lo, hi if hi > lo else lo + 1.0, MAP_CELLS + 1)
    return 0.5 * (edges[:-1] + edges[1:]), np.clip(np.searchsorted(edges, values, side="right") - 1, 0, MAP_CELLS - 1)


def _cell_means(ix: np.ndarray, iy: np.ndarray, shape: tuple[int, int], values: np.ndarray) -> np.ndarray:
    """Mean of the finite ``values`` in each (iy, ix) cell (NaN where there is none: a design not simulated has
    no figure)."""
    values = np.asarray(values, dtype=float)
    finite = np.isfinite(values)
    flat = (iy * shape[1] + ix)[finite]
    count = np.bincount(flat, minlength=shape[0] * shape[1])
    total = np.bincount(flat, weights=values[finite], minlength=shape[0] * shape[1])
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan).reshape(shape)


def held_level(values: np.ndarray) -> float | None:
    """The value a map holds another varied parameter at: its middle level on a grid (at most
    :data:`MAP_CELLS` levels), None where the map averages over it instead."""
    levels = np.unique(np.asarray(values, dtype=float))
    return float(levels[(levels.size - 1) // 2]) if levels.size <= MAP_CELLS else None


def _held_at(table: Mapping[str, np.ndarray], others: Sequence[str]) -> tuple[np.ndarray, str]:
    """Which designs a map of two variables shows when others varied too: on a grid (each other variable takes
    at most :data:`MAP_CELLS` values) the slice at each other variable's middle value, said so; on a sample, every
    design, each cell the mean over the others, said so.  (mask, what the caption says about it)."""
    n = len(next(iter(table.values())))
    keep = np.ones(n, dtype=bool)
    held, averaged = [], []
    for key in others:
        middle = held_level(table[key])
        if middle is not None:
            keep &= np.asarray(table[key], dtype=float) == middle
            shown = quantity(key)
            held.append(f"{shown.name} held at {middle * shown.scale:.4g}{(' ' + shown.unit) if shown.unit else ''}")
        else:
            averaged.append(quantity(key).name)
    said = "; ".join(held + ([f"each cell the mean over {', '.join(averaged)}"] if averaged else []))
    return keep, said


def full_depth_mm(table: Mapping[str, np.ndarray]) -> float | None:
    """The final depth of the designs that reach full depth (their penetration depth), else None. [mm]"""
    full = np.asarray(table["full_penetration"], dtype=bool)
    if not full.any() or "final_depth_mm" not in table:
        return None
    return float(np.median(np.asarray(table["final_depth_mm"], dtype=float)[full]))


def sweep_map(table: Mapping[str, np.ndarray], x: str, y: str, value: str = "final_depth_mm",
              others: Sequence[str] = (), boundary: np.ndarray | None = None):
    """Fig. 14: a figure over two varied parameters as a labelled contour map, with the full-penetration boundary.

    On a grid each node is one design; a sampled sweep is binned into :data:`MAP_CELLS` cells per axis of mean
    values (memory: the table's, whatever the sweep's size).  Other varied parameters (``others``) are held at
    their middle value on a grid, or averaged over in a sample, and the caption says which.  The boundary is
    drawn at ``boundary`` ((k, 2) points (x, y), file units: where each grid line crosses it, found on the
    simulator, :func:`pencli.predict.sweep.boundary_roots`), else where the final depth reaches the penetration
    depth, interpolated between cells (a sample).

    Returns the figure and its caption (the value's range, the share of designs reaching full depth)."""
    plt = _plt()
    keep, said = _held_at(table, others)
    part = {k: np.asarray(v)[keep] for k, v in table.items() if k in (x, y, value, "full_penetration",
                                                                       "final_depth_mm")}
    xs, ix = _cells(part[x])
    ys, iy = _cells(part[y])
    shown = quantity(value)
    grid = _cell_means(ix, iy, (ys.size, xs.size), part[value]) * shown.scale
    binned = ix.size > xs.size * ys.size
    fig, ax = plt.subplots(figsize=(7, 5), constrained_layout=True)
    if xs.size > 1 and ys.size > 1 and np.isfinite(grid).sum() >= 4:
        filled = ax.contourf(xs, ys, grid, levels=12, cmap="viridis")
        lines = ax.contour(xs, ys, grid, levels=filled.levels[1:-1:2], colors="k", linewidths=0.5)
        ax.clabel(lines, fontsize=7, fmt="%.4g")
        fig.colorbar(filled, ax=ax, label=shown.label + (" (cell mean)" if binned else ""))
    else:  # one value along an axis: no contours to draw
        mesh = ax.pcolormesh(xs, ys, grid, shading="nearest", cmap="viridis")
        fig.colorbar(mesh, ax=ax, label=shown.label)
    depth = full_depth_mm(part)
    drawn = ""
    if boundary is not None and len(boundary):
        ax.plot(boundary[:, 0], boundary[:, 1], "o", color="w", ms=3.5, mec="k", mew=0.4,
                label="full-penetration boundary")
        drawn = (f" (white dots: the full-penetration boundary where it crosses the grid's lines, {len(boundary)} "
                 f"crossings found on the simulator).")
    elif depth is not None and xs.size > 1 and ys.size > 1:
        final = _cell_means(ix, iy, (ys.size, xs.size), part["final_depth_mm"])
        if np.nanmin(final) < depth * FULL_DEPTH_SHARE <= np.nanmax(final):
            ax.contour(xs, ys, final, levels=[depth * FULL_DEPTH_SHARE], colors="w", linewidths=2.2)
            drawn = " (white line: the full-penetration boundary, interpolated between cells)."
    ax.set_xlabel(label(x))
    ax.set_ylabel(label(y))
    v = np.asarray(part[value], dtype=float) * shown.scale
    ran = np.isfinite(np.asarray(part["final_depth_mm"], dtype=float))  # designs not simulated have no figures
    share = 100.0 * float(np.mean(np.asarray(part["full_penetration"], dtype=float)[ran])) if ran.any() else 0.0
    caption = (f"{shown.name} over {quantity(x).name} and {quantity(y).name}: {np.nanmin(v):.4g}–{np.nanmax(v):.4g}"
               f"{(' ' + shown.unit) if shown.unit else ''} over {int(ran.sum())} designs"
               + (f" ({xs.size} × {ys.size} cells of means)" if binned else "")
               + (f" ({said})" if said else "")
               + (f", {int((~ran).sum())} more not simulated (blank)" if not ran.all() else "")
               + f"; {share:.0f} % of those simulated reach full depth"
               + (drawn or "."))
    return fig, caption


FULL_DEPTH_SHARE = 0.999
"""A design's final depth at this share of the penetration depth or more is at full depth: where the boundary is
drawn on the final-depth field. [–]"""


CATEGORIES = 6
"""A varied parameter of at most this many values (a list, ``blade_thickness_mm=1,1.5,2``) is drawn as categories
with the spread at each, not as a continuous band. [–]"""


def sweep_partial(table: Mapping[str, np.ndarray], keys: Sequence[str], value: str = "penetration_time_s"):
    """Partial dependence: each varied parameter against ``value`` (median and 10–90 % band over the other
    parameters) and the share of designs reaching full depth.

    Returns the figure and its caption (which parameter moves the median most, and by how much)."""
    plt = _plt()
    keys = list(keys)
    shown = quantity(value)
    fig, axes = plt.subplots(1, len(keys), figsize=(3.2 * len(keys) + 1, 3.6), constrained_layout=True,
                             squeeze=False)
    v = np.asarray(table[value], dtype=float) * shown.scale
    full = np.asarray(table["full_penetration"], dtype=float)
    spread = {}
    for ax, key in zip(axes[0], keys):
        centres, idx = _cells(table[key])
        order = np.argsort(idx, kind="stable")
        bounds = np.searchsorted(idx[order], np.arange(centres.size + 1))
        stats = np.full((centres.size, 3), np.nan)
        for c in range(centres.size):
            part = v[order[bounds[c]:bounds[c + 1]]]
            part = part[np.isfinite(part)]  # designs not simulated have no figure
            if part.size:
                stats[c] = np.quantile(part, [0.1, 0.5, 0.9])
        spread[key] = float(np.nanmax(stats[:, 1]) - np.nanmin(stats[:, 1]))
        share = np.bincount(idx, weights=full, minlength=centres.size) / np.maximum(
            np.bincount(idx, minlength=centres.size), 1)
        twin = ax.twinx()
        if centres.size <= CATEGORIES:  # a list of values: categories, not a continuous band
            at = np.arange(centres.size)
            ax.errorbar(at, stats[:, 1], yerr=[stats[:, 1] - stats[:, 0], stats[:, 2] - stats[:, 1]], fmt="o",
                        color="tab:blue", capsize=4, label="median, 10–90 %")
            ax.set_xticks(at, [f"{c * quantity(key).scale:.4g}" for c in centres])
            ax.set_xlim(-0.5, centres.size - 0.5)
            twin.plot(at, share, "kD", ms=4, label="share at full depth")
        else:
            ax.fill_between(centres, stats[:, 0], stats[:, 2], color="tab:blue", alpha=0.25, label="10–90 %")
            ax.plot(centres, stats[:, 1], color="tab:blue", label="median")
            twin.plot(centres, share, color="k", ls="--", lw=1, label="share at full depth")
        ax.set_xlabel(label(key))
        twin.set_ylim(-0.02, 1.02)
    axes[0][0].set_ylabel(shown.label)
    axes[0][0].legend(fontsize=7, loc="upper left")
    first = max(spread, key=spread.get)
    caption = (f"{shown.name} against each varied parameter (median and 10–90 % band over the others; dashed, right "
               f"axis: share of designs at full depth, 0–1): {quantity(first).name} moves the median most, by "
               f"{spread[first]:.3g} {shown.unit}.")
    return fig, caption


def sweep_scatter(table: Mapping[str, np.ndarray], keys: Sequence[str]):
    """Fig. 15: three varied parameters on axes, residual kinetic energy as colour (a sweep of three or more
    variables; the first three are drawn).

    Returns the figure and its caption (how many designs are drawn and the residual energy's range)."""
    plt = _plt()
    keys = list(keys)[:3]
    if len(keys) < 3:
        raise ValueError("a 3-D scatter needs three varied parameters")
    fig = plt.figure(figsize=(7, 5.5), constrained_layout=True)
    ax = fig.add_subplot(projection="3d")
    n = len(table["residual_ke_j"])
    pick = np.random.default_rng(0).choice(n, min(n, 5000), replace=False)
    energy = np.asarray(table["residual_ke_j"], dtype=float)[pick]
    points = ax.scatter(*(np.asarray(table[c])[pick] for c in keys), c=energy, cmap="plasma", s=6)
    fig.colorbar(points, ax=ax, label=label("residual_ke_j"), shrink=0.7)
    ax.set_xlabel(label(keys[0]), fontsize=8)
    ax.set_ylabel(label(keys[1]), fontsize=8)
    ax.set_zlabel(label(keys[2]), fontsize=8)
    caption = (f"{pick.size} of {n} designs over {', '.join(quantity(k).name for k in keys)}, coloured by the "
               f"kinetic energy left at full depth ({np.nanmin(energy):.3g}–{np.nanmax(energy):.3g} J; 0 where the "
               f"blade stops in the material).")
    return fig, caption


def estimates_comparison(run_id: str, depth_mm: np.ndarray, resistance_n: np.ndarray, frontal_area_m2: float,
                         cone_mpa: tuple[float, float] | None, ucs_kpa: tuple[float, float] | None):
    """Fig. 16: the model's resistance against cone-penetration and compressive-strength × area estimates.

    Returns the figure and its caption (the model's mean resistance against each estimate's band)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7, 4.5), constrained_layout=True)
    ax.plot(depth_mm, resistance_n, color=DYNAMIC, lw=1.2, label="pen model (Eq. 9, fully predicted)")
    bands = []
    for name, span, scale, colour in (("cone penetration resistance × area", cone_mpa, 1e6, "tab:blue"),
                                      ("unconfined compressive strength × area", ucs_kpa, 1e3, "tab:green")):
        if span:
            lo, hi = span[0] * scale * frontal_area_m2, span[1] * scale * frontal_area_m2
            ax.axhspan(lo, hi, color=colour, alpha=0.3, label=name)
            bands.append(f"{name} {lo:.0f}–{hi:.0f} N")
    ax.set_xlabel(label("depth_m"))
    ax.set_ylabel(label("resistance_n"))
    ax.legend(fontsize=7)
    mean = float(np.mean(resistance_n)) if len(resistance_n) else float("nan")
    caption = (f"{run_id}: the model's resistance averages {mean:.0f} N over the penetration"
               + (f", against {'; '.join(bands)}." if bands else " (no published estimate for this material)."))
    return fig, caption


def fit_intervals(material: str, fit: Mapping):
    """Each fitted coefficient on its own axis in its unit: the value, its 95 % interval held to the coefficient's
    bound (every coefficient is ≥ 0) and, where run, the bootstrap's; and the correlation matrix with its numbers.

    Returns the figure and its caption (the coefficients with intervals, and the strongest correlation)."""
    plt = _plt()
    names = [n for n, ci in fit["ci95"].items() if ci]
    fig = plt.figure(figsize=(11, 1.1 * max(len(names), 3) + 1.2), constrained_layout=True)
    grid = fig.add_gridspec(max(len(names), 1), 2, width_ratios=[1.25, 1])
    parts = []
    for i, n in enumerate(names):
        ax = fig.add_subplot(grid[i, 0])
        shown = quantity(n)
        value = fit["coefficients"][n]
        lo, hi = fit["ci95"][n]
        held = lo < 0
        lo = max(lo, 0.0)
        ax.plot([lo, hi], [0, 0], color="tab:blue", lw=5, alpha=0.6, solid_capstyle="butt",
                label="95 % (normal, held at ≥ 0)" if held else "95 % (normal)")
        boot = (fit.get("bootstrap_ci95") or {}).get(n)
        if boot:
            ax.plot(boot, [0.35, 0.35], color="tab:orange", lw=2, label="95 % (bootstrap over runs)")
        ax.plot([value], [0], "ko", ms=4)
        ax.set_yticks([])
        ax.set_ylim(-0.8, 0.8)
        ax.set_xlabel(shown.label, fontsize=8)
        ax.tick_params(labelsize=7)
        ax.ticklabel_format(axis="x", useOffset=False)
        if held:
            ax.annotate("held at its bound 0", (lo, 0), (4, 8), textcoords="offset points", fontsize=7)
        if i == 0:
            ax.legend(fontsize=6, loc="upper right")
        parts.append(f"{_symbol(n)} = {_with_interval(value, lo, hi)}{(' ' + shown.unit) if shown.unit else ''}")
    corr = fit["correlation"]
    keys = list(corr)
    matrix = np.array([[corr[a][b] if corr[a][b] is not None else np.nan for b in keys] for a in keys])
    ax2 = fig.add_subplot(grid[:, 1])
    im = ax2.imshow(matrix, vmin=-1, vmax=1, cmap="coolwarm")
    for (r, c), v in np.ndenumerate(matrix):
        if np.isfinite(v):
            ax2.text(c, r, f"{v:+.2f}", ha="center", va="center", fontsize=8,
                     color="white" if abs(v) > 0.6 else "black")
    symbols = [_symbol(k) for k in keys]
    ax2.set_xticks(range(len(keys)), symbols)
    ax2.set_yticks(range(len(keys)), symbols)
    fig.colorbar(im, ax=ax2, label="correlation [–]", shrink=0.8)
    off = [(abs(matrix[r, c]), r, c) for r in range(len(keys)) for c in range(r + 1, len(keys))
           if np.isfinite(matrix[r, c])]
    strongest = max(off) if off else None
    caption = (f"{material} ({fit.get('mode', 'resistance')} fit, {len(fit.get('runs', []))} runs): "
               + "; ".join(parts) + " (95 %)"
               + (f"; strongest correlation {symbols[strongest[1]]}–{symbols[strongest[2]]} "
                  f"{matrix[strongest[1], strongest[2]]:+.2f}." if strongest else "."))
    return fig, caption


def _with_interval(value: float, lo: float, hi: float) -> str:
    """``0.6001 [0.5999, 0.6003]``: as many digits as the interval's width needs to show it."""
    import math

    width = hi - lo
    if not (math.isfinite(width) and width > 0):
        return f"{value:.4g} [{lo:.4g}, {hi:.4g}]"
    if max(abs(value), abs(hi)) < 1e-3:
        return f"{value:.2g} [{lo:.2g}, {hi:.2g}]"
    decimals = max(0, 1 - math.floor(math.log10(width)))
    return f"{value:.{decimals}f} [{lo:.{decimals}f}, {hi:.{decimals}f}]"


def _symbol(key: str) -> str:
    """A coefficient's symbol (Cs, P, C, K) from its one definition, else the key."""
    from pencli.params.definitions import BY_KEY

    param = BY_KEY.get(f"coefficients.{key}") or BY_KEY.get(key)
    return param.symbol if param is not None and param.symbol else key


def campaign_fit(material: str, data: Mapping[str, np.ndarray], fitted_runs: int | None = None,
                 colours: Mapping[str, tuple] | None = None):
    """Paper Figs. 13–14 for a whole fit: every run's measured resistance against depth with its Eq. 9 model
    (measured x, v) on one axis, and each run's residual beneath, over the analysis window (``data``: the fit's
    model-vs-data table, or the rows of some of its runs; ``fitted_runs``: how many runs the fit used, when
    ``data`` holds fewer; ``colours``: each run's, when the report's other figures hold more runs).

    Returns the figure and its caption, which states the answer: the RMS the model leaves per run.
    """
    plt = _plt()
    runs = list(dict.fromkeys(np.asarray(data["run_id"]).tolist()))
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6.4), sharex=True, constrained_layout=True,
                                      gridspec_kw={"height_ratios": [2.2, 1]})
    colours = colours or run_colours(runs)
    rms_all = []
    for run_id in runs:
        mine = (np.asarray(data["run_id"]) == run_id) & np.asarray(data["in_window"], dtype=bool)
        depth = np.asarray(data["depth_m"])[mine] * 1e3
        measured = np.asarray(data["resistance_n"])[mine]
        model = np.asarray(data["resistance_model_n"])[mine]
        residual = measured - model
        rms = float(np.sqrt(np.mean(residual ** 2)))
        r2 = 1.0 - float(np.sum(residual ** 2) / np.sum((measured - measured.mean()) ** 2))
        rms_all.append(rms)
        colour = colours[run_id]
        top.plot(depth, measured, color=colour, lw=0.6, alpha=0.55)
        top.plot(depth, model, color=colour, lw=1.4, label=f"{run_id}: RMS {rms:.1f} N, R² {r2:.4f}")
        bottom.plot(depth, residual, color=colour, lw=0.6)
    top.set_ylabel("resistance [N]")
    top.legend(fontsize=7, title="thin: measured; thick: Eq. 9 with measured depth and speed", title_fontsize=7)
    bottom.axhline(0.0, color="0.4", lw=0.6)
    bottom.set_ylabel("measured − model [N]")
    bottom.set_xlabel("depth below the surface [mm]")
    from pencli.filter.windows import FIT_EDGE_MARGINS_S, WINDOW_TRIM_S

    trim, (after, before) = 1e3 * WINDOW_TRIM_S, (1e3 * m for m in FIT_EDGE_MARGINS_S)
    over = (f"fitted over {fitted_runs} runs leaves, on these {len(runs)}," if fitted_runs not in (None, len(runs))
            else f"fitted over {len(runs)} runs leaves")
    caption = (f"{material}: Eq. 9 {over} {min(rms_all):.1f}–{max(rms_all):.1f} N RMS "
               f"per run within the analysis window (contact + {trim:g} ms to stop − {trim:g} ms; a resistance fit "
               f"leaves out {after:g} ms after contact and {before:g} ms before the stop, where the encoder's "
               f"derivatives are least reliable).")
    return fig, caption


def run_colours(run_ids: Sequence[str]) -> dict[str, tuple]:
    """One colour per run, the same in every figure of a report (tab10 up to ten runs, tab20 beyond, then
    repeating)."""
    plt = _plt()
    colours = plt.get_cmap("tab10" if len(run_ids) <= 10 else "tab20").colors
    return {run_id: colours[k % len(colours)] for k, run_id in enumerate(run_ids)}


def _run_legend(fig, colours: Mapping[str, tuple]) -> None:
    """One legend of the runs' colours, beside the figure's panels."""
    from matplotlib.lines import Line2D

    fig.legend([Line2D([], [], color=c, lw=1.5) for c in colours.values()], list(colours), fontsize=7,
               loc="outside right upper", title="run", title_fontsize=7)


def campaign_raw(runs: Sequence[tuple[str, Mapping[str, np.ndarray], Mapping[str, float]]]):
    """Fig. 11 for a campaign: every run's raw position and axial force against time since its contact, on one
    pair of axes (``runs``: (run id, raw channels, events) each).

    Returns the figure and its caption (the runs' peak axial forces and how long they were in the material)."""
    plt = _plt()
    colours = run_colours([r[0] for r in runs])
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(10, 5.5), sharex=True, layout="constrained")
    peaks, spans = [], []
    for run_id, raw, events in runs:
        t = (raw["time_s"] - events["contact_s"]) * 1e3
        near = (t > -15.0) & (t < (events["stop_s"] - events["contact_s"]) * 1e3 + 15.0)
        ax1.plot(*_thin(t[near], raw["position_mm"][near], bins=OVERLAY_THIN_POINTS), lw=0.8, color=colours[run_id])
        ax2.plot(*_thin(t[near], raw["fz_n"][near], bins=OVERLAY_THIN_POINTS), lw=0.6, color=colours[run_id])
        peaks.append(float(np.max(raw["fz_n"])))
        spans.append((events["stop_s"] - events["contact_s"]) * 1e3)
    ax1.set_ylabel(label("position_mm"))
    ax2.set_ylabel(label("fz_n"))
    ax2.set_xlabel("time since contact [ms]")
    for ax in (ax1, ax2):
        ax.axvline(0.0, color="grey", ls="--", lw=0.8)
    _run_legend(fig, colours)
    caption = (f"{len(runs)} runs: raw position and axial force from 15 ms before contact (dashed) to 15 ms after "
               f"the stop; peak axial force {min(peaks):.0f}–{max(peaks):.0f} N, {min(spans):.1f}–{max(spans):.1f} "
               f"ms from contact to the stop.")
    return fig, caption


def campaign_kinematics(runs: Sequence[tuple[str, Mapping[str, np.ndarray], Mapping[str, float]]]):
    """Fig. 12 for a campaign: every run's depth, resistance R = F − m·a and speed against time since its
    contact (``runs``: (run id, conditioned columns, events) each).

    Returns the figure and its caption (contact speeds and final depths, with how many runs were arrested)."""
    plt = _plt()
    colours = run_colours([r[0] for r in runs])
    fig, axes = plt.subplots(3, 1, figsize=(10, 7), sharex=True, layout="constrained")
    for run_id, stage, events in runs:
        t = (stage["time_s"] - events["contact_s"]) * 1e3
        near = (t > -5.0) & (t < (events["stop_s"] - events["contact_s"]) * 1e3 + 5.0)
        colour = colours[run_id]
        axes[0].plot(*_thin(t[near], stage["depth_m"][near] * 1e3, bins=OVERLAY_THIN_POINTS), color=colour, lw=0.8)
        axes[1].plot(*_thin(t[near], stage["resistance_n"][near], bins=OVERLAY_THIN_POINTS), color=colour, lw=0.6)
        axes[2].plot(*_thin(t[near], stage["velocity_m_s"][near], bins=OVERLAY_THIN_POINTS), color=colour, lw=0.8)
    axes[0].set_ylabel(label("depth_m"))
    axes[1].set_ylabel("resistance R = F − m·a [N]")
    axes[2].set_ylabel(label("velocity_m_s"))
    axes[2].set_xlabel("time since contact [ms]")
    for ax in axes:
        ax.axvline(0.0, color="grey", ls="--", lw=0.8)
    _run_legend(fig, colours)
    speeds = [e["contact_speed_m_s"] for _, _, e in runs]
    depths = [e["final_depth_m"] * 1e3 for _, _, e in runs]
    arrested = sum(1 for _, _, e in runs if e.get("end") == "arrest")
    caption = (f"{len(runs)} runs: contact (dashed) at {min(speeds):.2f}–{max(speeds):.2f} m/s; final depth "
               f"{min(depths):.1f}–{max(depths):.1f} mm; {arrested} arrested in the material, "
               f"{len(runs) - arrested} reached the hard stops.")
    return fig, caption


def campaign_energy(balances: Sequence[tuple[str, object]]):
    """Fig. 14 (measured) for a campaign: for each run, where the energy supplied in the material (kinetic at
    contact plus the springs' and gravity's work) went, as shares: each Eq. 9 term with its fit's coefficients,
    what was left at the stop, and what the fit does not account for (``balances``: (run id,
    :class:`~pencli.fit.energy.EnergyBalance`) each).

    Returns the figure and its caption (each term's share over the runs, and the largest unaccounted share)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(10, 1.2 + 0.32 * len(balances)), layout="constrained")
    names = [run_id for run_id, _ in balances]
    terms = list(TERM_COLOURS)
    shares: dict[str, list[float]] = {name: [] for name in (*terms, "left at the stop", "not accounted for")}
    for _, b in balances:
        supplied = b.supplied_j if b.supplied_j > 0 else float("nan")
        for term in terms:
            shares[term].append(100.0 * b.terms_j.get(term, 0.0) / supplied)
        shares["left at the stop"].append(100.0 * b.left_ke_j / supplied)
        shares["not accounted for"].append(100.0 * b.unaccounted_j / supplied)
    y = np.arange(len(names))[::-1]
    left = np.zeros(len(names))
    colours = {**TERM_COLOURS, "left at the stop": "0.3", "not accounted for": "tab:purple"}
    for name, values in shares.items():
        if name in terms and max(values) <= 0.0:
            continue  # a term the fits set to 0 (damping, mostly): no bar, no legend entry
        width = np.asarray(values)  # the last, "not accounted for", is signed: it may run back from the end
        ax.barh(y, width, left=left, color=colours[name], height=0.6, label=name)
        left = left + width
    ax.axvline(100.0, color="k", lw=0.8, ls=":")
    ax.set_yticks(y, names, fontsize=7)
    ax.set_xlabel("share of the energy supplied in the material [%]")
    fig.legend(fontsize=7, loc="outside right upper")
    spans = {t: (min(v), max(v)) for t, v in shares.items()}
    worst = max(range(len(names)), key=lambda k: abs(shares["not accounted for"][k]))
    caption = (f"{len(names)} runs: of the energy supplied in the material, "
               + ", ".join(f"{t} {lo:.0f}–{hi:.0f} %" for t, (lo, hi) in spans.items()
                           if t in terms and hi > 0.5)
               + f", {spans['left at the stop'][0]:.0f}–{spans['left at the stop'][1]:.0f} % left at the stop; "
               f"the most the fits leave unaccounted is {shares['not accounted for'][worst]:+.1f} % "
               f"({names[worst]}); dotted: 100 %.")
    return fig, caption


OUTSIDE_TERMS = "resistance, not by term"
"""The label of a resistance the simulator does not book by Eq. 9 term (a geometry whose law is not Eq. 9's
form, such as a cone's growing frontal area)."""


def prediction(title: str, trajectory, summary, band=None, shape: str = "blade", drive_work: str = "springs"):
    """A predicted run (``pen predict --plot``): depth and speed against time, the force of each Eq. 9 term against
    depth (stacked), and where the energy goes (``drive_work`` names the drive's bar); with ``band`` (:class:`~pencli.predict.band.Band`, from a fitted
    material's covariance), the spread of depth, speed and resistance over the fit's uncertainty.

    ``trajectory`` and ``summary`` are a :class:`~pencli.model.dynamics.SimulationResult`'s.  Returns the figure
    and its caption (how the run ends, the largest term's share of the energy, and the band's interval of the
    penetration time).  ``shape`` names the penetrator's geometry in the caption; a resistance not booked by
    term (:data:`OUTSIDE_TERMS`) is drawn and counted as one more term."""
    plt = _plt()
    fig, (motion, force, energy) = plt.subplots(1, 3, figsize=(14, 4.2), constrained_layout=True,
                                                gridspec_kw={"width_ratios": [1.1, 1.1, 1]})
    t = trajectory.time_s * 1e3
    motion.plot(t, trajectory.depth_m * 1e3, color=DYNAMIC, lw=1.2)
    motion.set_xlabel(label("time_s"))
    motion.set_ylabel(label("depth_m"), color=DYNAMIC)
    speed = motion.twinx()
    speed.plot(t, trajectory.velocity_m_s, color="0.35", lw=1.0, ls="--")
    speed.set_ylabel(label("velocity_m_s") + " (dashed)")
    inside = trajectory.phase == 1
    depth = trajectory.depth_m[inside] * 1e3
    terms = ("strength", "friction", "damping", "inertia")
    layers = [getattr(trajectory, f"{n}_n")[inside] for n in terms]
    colours = {**TERM_COLOURS, OUTSIDE_TERMS: "tab:brown"}
    if summary.energy_other_j > 0.0:  # the terms that book nothing are not drawn
        kept = [k for k, n in enumerate(terms) if getattr(summary, f"energy_{n}_j") > 0.0 or np.any(layers[k])]
        layers = [layers[k] for k in kept] + [trajectory.resistance_n[inside] - sum(layers)]
        terms = (*(terms[k] for k in kept), OUTSIDE_TERMS)
    force.stackplot(depth, *layers, colors=[colours[n] for n in terms], labels=terms, alpha=0.85)
    if band is not None:
        share = f"{100 * band.level:.0f} % of {band.draws} runs drawn from the fit's covariance"
        motion.fill_between(band.time_s * 1e3, band.depth_low_m * 1e3, band.depth_high_m * 1e3, color=DYNAMIC,
                            alpha=0.25, lw=0, label=share)
        speed.fill_between(band.time_s * 1e3, band.velocity_low_m_s, band.velocity_high_m_s, color="0.35",
                           alpha=0.2, lw=0)
        motion.legend(fontsize=7, loc="lower right")
        force.fill_between(band.depth_m * 1e3, band.resistance_low_n, band.resistance_high_n, facecolor="none",
                           edgecolor="k", hatch="////", lw=0.6, label=f"total, {share}")
    force.set_xlabel(label("depth_m"))
    force.set_ylabel("resistance by term [N]")
    force.legend(fontsize=7, loc="lower right")
    spent = {n: getattr(summary, f"energy_{n}_j") if n != OUTSIDE_TERMS else summary.energy_other_j for n in terms}
    spent["left as kinetic"] = summary.residual_ke_j
    supplied = {drive_work: summary.spring_energy_j, "gravity": summary.gravity_work_j}
    bars = [*supplied.items(), *spent.items()]
    energy.bar(range(len(bars)), [v for _, v in bars],
               color=["0.55"] * len(supplied) + [colours.get(n, "0.3") for n in spent])
    energy.set_xticks(range(len(bars)), [k for k, _ in bars], rotation=30, ha="right", fontsize=8)
    energy.axvline(len(supplied) - 0.5, color="0.3", lw=0.8)
    energy.set_ylabel("energy [J]")
    total = sum(supplied.values())
    largest = max(terms, key=spent.get)
    how = (f"reaches full depth ({summary.final_depth_mm:.1f} mm) in {summary.penetration_time_s * 1e3:.2f} ms with "
           f"{summary.residual_ke_j:.1f} J left" if summary.full_penetration else
           f"stops {summary.final_depth_mm:.1f} mm deep after {summary.penetration_time_s * 1e3:.2f} ms")
    share = f"; {largest} takes {100 * spent[largest] / total:.0f} % of the {total:.1f} J supplied" if total > 0 else ""
    spread = ""
    if band is not None:
        lo, hi = band.figures["penetration_time_s"]
        spread = (f"; over the fit's uncertainty ({100 * band.level:.0f} % of {band.draws} draws) the penetration "
                  f"takes {lo * 1e3:.2f}–{hi * 1e3:.2f} ms")
    caption = (f"{title}: contact at {summary.contact_speed_m_s:.2f} m/s; the {shape.replace('_', ' ')} "
               f"{how}{share}{spread}.")
    return fig, caption


def snow_profile(name: str, estimates, layers: Sequence = ()):
    """A SnowMicroPen profile's shot-noise estimates (:class:`pencli.fit.shot_noise.ShotNoise`, depths below the
    surface) against depth: the strength term and the element size, layers' medians drawn as steps.

    Returns the figure and its caption (the strength term's range and the layers' medians)."""
    plt = _plt()
    depth = estimates.depth_mm
    fig, (left, right) = plt.subplots(1, 2, figsize=(8.0, 5.5), sharey=True)
    kept = ~estimates.clipped
    left.plot(estimates.strength_kpa[kept], depth[kept], lw=0.6, color="0.35", label="per window")
    right.plot(estimates.element_size_mm[kept], depth[kept], lw=0.6, color="0.35")
    if (~kept).any():
        left.plot(estimates.strength_kpa[~kept], depth[~kept], "x", color="C3", ms=3,
                  label="window at the sensor's range")
    for layer in layers:
        left.plot([layer.strength_kpa] * 2, [layer.top_mm, layer.bottom_mm], color="C0", lw=2.5)
        right.plot([layer.element_size_mm] * 2, [layer.top_mm, layer.bottom_mm], color="C0", lw=2.5)
    left.set_xscale("log")
    left.set_xlabel("strength term, mean force / frontal area [kPa]")
    right.set_xlabel("element size L [mm]")
    left.set_ylabel("depth below the snow surface [mm]")
    left.invert_yaxis()
    left.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    strength = estimates.strength_kpa[kept]
    said = "; ".join(f"{layer.top_mm:.0f}–{layer.bottom_mm:.0f} mm: {layer.strength_kpa:.0f} kPa, "
                     f"L {layer.element_size_mm:.2f} mm" for layer in layers)
    caption = (f"{name}: the strength term spans {np.nanpercentile(strength, 5):.0f}–"
               f"{np.nanpercentile(strength, 95):.0f} kPa (5–95 % of {strength.size} windows) over "
               f"{depth[-1] - depth[0]:.0f} mm of snow" + (f"; layer medians (blue) {said}" if said else "")
               + (f"; {int((~kept).sum())} windows reached the sensor's range (crosses)" if (~kept).any() else "")
               + ".")
    return fig, caption


def drop_motion(name: str, motion):
    """A free-fall drop (:class:`pencli.filter.freefall.DropMotion`): its deceleration against time around the
    impact, and its speed against depth below the bed's surface.  Returns the figure and its caption."""
    plt = _plt()
    from pencli.filter.freefall import G

    t, m = motion.time_s, motion
    fig, (left, right) = plt.subplots(1, 2, figsize=(9.0, 3.8))
    lead = max(m.release, int(np.searchsorted(t, m.impact_s - 0.05)))
    rows = slice(lead, min(t.size, m.stop + (m.stop - m.impact) // 2 + 2))
    left.plot(1e3 * (t[rows] - m.impact_s), -m.accel_m_s2[rows] / G, lw=0.8, color="0.25")
    left.axvline(0.0, color="C3", lw=0.8, ls="--")
    left.set_xlabel("time from impact [ms]")
    left.set_ylabel("deceleration [g]")
    at_hit = float(np.interp(m.impact_s, t, m.travel_m))
    bed = slice(m.impact, m.stop + 1)
    right.plot(m.speed_m_s[bed], 1e3 * (m.travel_m[bed] - at_hit), lw=1.0, color="C0")
    right.set_xlabel("speed [m/s]")
    right.set_ylabel("depth below the bed's surface [mm]")
    right.invert_yaxis()
    right.set_xlim(left=0.0)
    fig.tight_layout()
    caption = (f"{name}: the probe met the bed at {m.impact_speed_m_s:.2f} m/s (dashed line) and stopped "
               f"{1e3 * m.penetration_m:.0f} mm into it {1e3 * (t[m.stop] - m.impact_s):.0f} ms later, "
               f"decelerating by up to {m.peak_deceleration_g:.1f} g.")
    return fig, caption


def sounding_profile(name: str, depth_m: np.ndarray, qc_mpa: np.ndarray, fs_kpa: np.ndarray | None = None,
                     u2_kpa: np.ndarray | None = None, qt_mpa: np.ndarray | None = None, layers=None,
                     resistance: tuple[str, str, str] = ("cone resistance", "MPa", "qc")):
    """A sounding against depth: cone resistance (qc, and qt where u₂ corrects it), sleeve friction, pore
    pressure u₂, each in a panel where the sounding has it; with ``layers`` (a :class:`pencli.fit.layers.Cut` of
    the resistance drawn), each layer's line on the resistance and its boundaries across every panel.
    ``resistance``: (what, unit, symbol) of the first panel's ``qc_mpa`` (a total sounding's push force [kN]).

    Returns the figure and its caption (the depth range, the largest resistance and where; the layers)."""
    what, unit, symbol = resistance
    plt = _plt()
    panels = [p for p, values in (("q", qc_mpa), ("fs", fs_kpa), ("u2", u2_kpa)) if values is not None]
    fig, axes = plt.subplots(1, len(panels), figsize=(3.0 * len(panels) + 1.0, 6.0), sharey=True, squeeze=False)
    axes = axes[0]
    for ax, panel in zip(axes, panels):
        if panel == "q":
            ax.plot(qc_mpa, depth_m, lw=0.7, color="0.3", label=symbol)
            if qt_mpa is not None:
                ax.plot(qt_mpa, depth_m, lw=0.7, color="C0", label="qt = qc + (1 − a)·u₂")
                ax.legend(loc="upper right", fontsize=8)
            ax.set_xlabel(f"{what} [{unit}]")
        elif panel == "fs":
            ax.plot(fs_kpa, depth_m, lw=0.7, color="C1")
            ax.set_xlabel("sleeve friction fs [kPa]")
        else:
            ax.plot(u2_kpa, depth_m, lw=0.7, color="C2")
            ax.set_xlabel("pore pressure u₂ [kPa]")
    if layers is not None:
        for layer in layers.layers:
            axes[0].plot([layer.q_top, layer.q_bottom], [layer.top_m, layer.bottom_m], color="k", lw=1.4,
                         label="layers" if layer is layers.layers[0] else None)
        for ax in axes:
            for boundary in layers.boundaries_m:
                ax.axhline(boundary, color="0.5", lw=0.6, ls="--")
        axes[0].legend(loc="upper right", fontsize=8)
    axes[0].set_ylabel("depth [m]")
    axes[0].invert_yaxis()
    fig.tight_layout()
    q = qt_mpa if qt_mpa is not None else qc_mpa
    k = int(np.nanargmax(q))
    thickness = [layer.bottom_m - layer.top_m for layer in layers.layers] if layers is not None else []
    caption = (f"{name}: {depth_m[0]:.2f}–{depth_m[-1]:.2f} m; the {what} peaks at {q[k]:.1f} {unit} at "
               f"{depth_m[k]:.2f} m" + ("" if qt_mpa is None else
                                      f" (qt; u₂ adds up to {np.nanmax(qt_mpa - qc_mpa) * 1e3:.0f} kPa to qc)")
               + ("" if layers is None else f"; {len(layers.layers)} layers of {min(thickness):.2f}–"
                  f"{max(thickness):.2f} m (dashed: their boundaries)") + ".")
    return fig, caption
