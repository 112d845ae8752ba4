"""The figures of pen's reports (paper Figs. 11–18), drawn from result objects and arrays only.

Each function returns a matplotlib Figure and never reads files; ``report.build``
places them.  matplotlib is imported inside, so importing this module is cheap.
"""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

TERM_COLOURS = {"strength": "#4C72B0", "friction": "#DD8452", "damping": "#55A868", "inertia": "#C44E52"}


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def raw_channels(run_id: str, raw: Mapping[str, np.ndarray], events: Mapping[str, float]):
    """Fig. 11: raw position and forces, the stored span and the analysed window marked."""
    plt = _plt()
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True, constrained_layout=True)
    t = raw["time_s"] * 1e3
    ax1.plot(t, raw["position_mm"], lw=0.8, color="k")
    ax1.set_ylabel("position [mm]")
    for name in ("fx_n", "fy_n", "fz_n"):
        ax2.plot(t, raw[name], lw=0.6, label=name)
    ax2.set_ylabel("force [N]")
    ax2.set_xlabel("time since release [ms]")
    ax2.legend(fontsize=7)
    for ax in (ax1, ax2):
        ax.axvline(t[0], color="tab:green", lw=1.5)
        ax.axvline(t[-1], color="tab:green", lw=1.5)
        ax.axvspan(events["window_start_s"] * 1e3, events["window_end_s"] * 1e3, color="tab:orange", alpha=0.2)
    fig.suptitle(f"{run_id}: raw channels (green: stored span; shaded: analysed window)")
    return fig


def kinematics_panels(run_id: str, stage: Mapping[str, np.ndarray], events: Mapping[str, float]):
    """Fig. 12: depth, force/resistance, speed and acceleration against time around the penetration."""
    plt = _plt()
    fig, axes = plt.subplots(2, 2, figsize=(10, 6), sharex=True, constrained_layout=True)
    t = stage["time_s"]
    near = (t > events["motion_start_s"] - 0.01) & (t < events["stop_s"] + 0.02)
    tm = t[near] * 1e3
    axes[0, 0].plot(tm, stage["depth_m"][near] * 1e3, color="k", lw=0.8)
    axes[0, 0].set_ylabel("depth [mm]")
    axes[0, 1].plot(tm, stage["force_n"][near], lw=0.6, label="load cell F")
    axes[0, 1].plot(tm, stage["resistance_n"][near], lw=0.8, label="resistance R = F − m·a")
    axes[0, 1].set_ylabel("force [N]")
    axes[0, 1].legend(fontsize=7)
    axes[1, 0].plot(tm, stage["velocity_m_s"][near], color="tab:blue", lw=0.8)
    axes[1, 0].set_ylabel("speed [m/s]")
    axes[1, 1].plot(tm, stage["acceleration_m_s2"][near], color="tab:red", lw=0.8)
    axes[1, 1].set_ylabel("acceleration [m/s²]")
    for ax in axes.ravel():
        ax.axvline(events["contact_s"] * 1e3, color="grey", ls="--", lw=0.8)
        ax.axvline(events["stop_s"] * 1e3, color="grey", ls=":", lw=0.8)
    for ax in axes[1]:
        ax.set_xlabel("time since release [ms]")
    fig.suptitle(f"{run_id}: measurements (dashed: contact, dotted: stop)")
    return fig


def model_vs_data(run_id: str, data: Mapping[str, np.ndarray]):
    """Fig. 13: measured and modelled resistance against time and depth, and depth against time, both modes."""
    plt = _plt()
    fig, axes = plt.subplots(1, 3, figsize=(13, 4), constrained_layout=True)
    t = data["time_s"] * 1e3
    axes[0].plot(t, data["resistance_n"], color="k", lw=0.7, label="measured")
    axes[0].plot(t, data["resistance_model_n"], lw=1.0, label="Eq. 9 with measured x, v")
    axes[0].plot(t, data["resistance_dynamic_n"], lw=1.0, ls="--", label="fully predicted")
    axes[0].set_xlabel("time since release [ms]")
    axes[0].set_ylabel("resistance [N]")
    axes[0].legend(fontsize=7)
    inside = data["depth_m"] > 0
    axes[1].plot(data["depth_m"][inside] * 1e3, data["resistance_n"][inside], color="k", lw=0.7)
    axes[1].plot(data["depth_m"][inside] * 1e3, data["resistance_model_n"][inside], lw=1.0)
    axes[1].set_xlabel("depth [mm]")
    axes[1].set_ylabel("resistance [N]")
    axes[2].plot(t, data["depth_m"] * 1e3, color="k", lw=0.8, label="measured")
    axes[2].plot(t, data["depth_dynamic_m"] * 1e3, ls="--", lw=1.0, label="fully predicted")
    axes[2].set_xlabel("time since release [ms]")
    axes[2].set_ylabel("depth [mm]")
    axes[2].legend(fontsize=7)
    fig.suptitle(f"{run_id}: model against data")
    return fig


def energy_per_term(title: str, energies: Mapping[str, float], supplied: Mapping[str, float] | None = None):
    """Figs. 14/17: energy dissipated by each Eq. 9 term (and, optionally, what was supplied)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7, 4), constrained_layout=True)
    names = list(energies)
    ax.bar(names, [energies[n] for n in names], color=[TERM_COLOURS.get(n, "grey") for n in names])
    for i, n in enumerate(names):
        ax.text(i, energies[n], f"{energies[n]:.1f}", ha="center", va="bottom", fontsize=8)
    if supplied:
        text = ", ".join(f"{k} {v:.1f} J" for k, v in supplied.items())
        ax.set_title(text, fontsize=8)
    ax.set_ylabel("energy [J]")
    fig.suptitle(title)
    return fig


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
    """Mean of ``values`` in each (iy, ix) cell (NaN where empty)."""
    flat = iy * shape[1] + ix
    count = np.bincount(flat, minlength=shape[0] * shape[1])
    total = np.bincount(flat, weights=np.asarray(values, dtype=float), minlength=shape[0] * shape[1])
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan).reshape(shape)


def sweep_map(table: Mapping[str, np.ndarray], x: str, y: str, value: str = "penetration_time_s"):
    """Fig. 14: a figure over two varied parameters as a heat map, with the full-penetration boundary.

    On a grid of two variables each cell is one design; with more variables, or a sampled sweep, a cell
    shows the mean over the designs that fall in it (so memory is the table's, whatever the sweep's size),
    and the boundary is where half of a cell's designs reach full depth.
    """
    plt = _plt()
    xs, ix = _cells(table[x])
    ys, iy = _cells(table[y])
    grid = _cell_means(ix, iy, (ys.size, xs.size), table[value])
    full = _cell_means(ix, iy, (ys.size, xs.size), np.asarray(table["full_penetration"], dtype=float))
    fig, ax = plt.subplots(figsize=(7, 5), constrained_layout=True)
    mesh = ax.pcolormesh(xs, ys, grid, shading="nearest", cmap="viridis")
    fig.colorbar(mesh, ax=ax, label=value + (" (cell mean)" if ix.size > xs.size * ys.size else ""))
    filled = np.nan_to_num(full, nan=0.0)
    if 0 < np.nanmean(full) < 1 and xs.size > 1 and ys.size > 1:
        ax.contour(xs, ys, filled, levels=[0.5], colors="w", linewidths=2)
    ax.set_xlabel(x)
    ax.set_ylabel(y)
    fig.suptitle(f"{value} over {x} × {y}\n(white line: full-penetration boundary)", fontsize=10)
    return fig


def sweep_partial(table: Mapping[str, np.ndarray], keys: Sequence[str], value: str = "penetration_time_s"):
    """Partial dependence: each varied parameter against ``value`` (cell mean and 10–90 % band over the
    other parameters) and the share of designs reaching full depth."""
    plt = _plt()
    keys = list(keys)
    fig, axes = plt.subplots(1, len(keys), figsize=(3.2 * len(keys) + 1, 3.6), constrained_layout=True,
                             squeeze=False)
    v = np.asarray(table[value], dtype=float)
    full = np.asarray(table["full_penetration"], dtype=float)
    for ax, key in zip(axes[0], keys):
        centres, idx = _cells(table[key])
        order = np.argsort(idx, kind="stable")
        bounds = np.searchsorted(idx[order], np.arange(centres.size + 1))
        stats = np.full((centres.size, 3), np.nan)
        for c in range(centres.size):
            part = v[order[bounds[c]:bounds[c + 1]]]
            if part.size:
                stats[c] = np.quantile(part, [0.1, 0.5, 0.9])
        ax.fill_between(centres, stats[:, 0], stats[:, 2], color="tab:blue", alpha=0.25, label="10–90 %")
        ax.plot(centres, stats[:, 1], color="tab:blue", label=f"median {value}")
        ax.set_xlabel(key)
        twin = ax.twinx()
        share = np.bincount(idx, weights=full, minlength=centres.size) / np.maximum(
            np.bincount(idx, minlength=centres.size), 1)
        twin.plot(centres, share, color="k", ls="--", lw=1, label="share at full depth")
        twin.set_ylim(-0.02, 1.02)
    axes[0][0].set_ylabel(value)
    axes[0][0].legend(fontsize=7, loc="upper left")
    fig.suptitle(f"{value} against each varied parameter (dashed: share of designs at full depth)", fontsize=10)
    return fig


def sweep_scatter(table: Mapping[str, np.ndarray], keys: Sequence[str]):
    """Fig. 15: three varied parameters on axes, residual kinetic energy as colour."""
    plt = _plt()
    fig = plt.figure(figsize=(7, 5.5), constrained_layout=True)
    ax = fig.add_subplot(projection="3d")
    k = list(keys)[:3] + [None] * (3 - len(list(keys)[:3]))
    n = len(table["residual_ke_j"])
    pick = np.random.default_rng(0).choice(n, min(n, 5000), replace=False)
    cols = [np.asarray(table[c])[pick] if c else np.zeros(pick.size) for c in k]
    points = ax.scatter(*cols, c=np.asarray(table["residual_ke_j"])[pick], cmap="plasma", s=6)
    fig.colorbar(points, ax=ax, label="residual kinetic energy [J]", shrink=0.7)
    ax.set_xlabel(k[0] or "")
    ax.set_ylabel(k[1] or "")
    ax.set_zlabel(k[2] or "")
    fig.suptitle("designs coloured by residual energy at full depth")
    return fig


def estimates_comparison(title: str, depth_mm: np.ndarray, resistance_n: np.ndarray, frontal_area_m2: float,
                         cone_mpa: tuple[float, float] | None, ucs_kpa: tuple[float, float] | None):
    """Fig. 16: the model's resistance against cone-penetration and compressive-strength × area estimates."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7, 4.5), constrained_layout=True)
    ax.plot(depth_mm, resistance_n, color="k", lw=1.2, label="pen model (Eq. 9, dynamic)")
    if cone_mpa:
        ax.axhspan(cone_mpa[0] * 1e6 * frontal_area_m2, cone_mpa[1] * 1e6 * frontal_area_m2, color="tab:blue",
                   alpha=0.25, label="cone penetration resistance × area")
    if ucs_kpa:
        ax.axhspan(ucs_kpa[0] * 1e3 * frontal_area_m2, ucs_kpa[1] * 1e3 * frontal_area_m2, color="tab:green",
                   alpha=0.35, label="unconfined compressive strength × area")
    ax.set_xlabel("depth [mm]")
    ax.set_ylabel("resistance [N]")
    ax.legend(fontsize=7)
    fig.suptitle(title)
    return fig


def fit_intervals(material: str, fit: Mapping):
    """Fitted coefficients with 95 % and bootstrap intervals (relative to the value), and their correlation."""
    plt = _plt()
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4), constrained_layout=True)
    names = [n for n, ci in fit["ci95"].items() if ci]
    for i, n in enumerate(names):
        value = fit["coefficients"][n]
        scale = abs(value) if value else 1.0
        lo, hi = fit["ci95"][n]
        ax1.plot([lo / scale, hi / scale], [i, i], color="tab:blue", lw=4, alpha=0.6)
        boot = fit.get("bootstrap_ci95", {}).get(n)
        if boot:
            ax1.plot([boot[0] / scale, boot[1] / scale], [i + 0.15, i + 0.15], color="tab:orange", lw=2)
        ax1.plot([value / scale], [i], "ko")
    ax1.set_yticks(range(len(names)), names)
    ax1.set_xlabel("value / fitted value (blue: 95 %, orange: bootstrap)")
    corr = fit["correlation"]
    keys = list(corr)
    matrix = np.array([[corr[a][b] if corr[a][b] is not None else np.nan for b in keys] for a in keys])
    im = ax2.imshow(matrix, vmin=-1, vmax=1, cmap="coolwarm")
    ax2.set_xticks(range(len(keys)), keys, rotation=30, ha="right", fontsize=7)
    ax2.set_yticks(range(len(keys)), keys, fontsize=7)
    fig.colorbar(im, ax=ax2, label="correlation")
    fig.suptitle(f"{material}: coefficients and their correlation")
    return fig


def campaign_fit(material: str, data: Mapping[str, np.ndarray]):
    """Paper Figs. 13–14 for a whole fit: every run's measured resistance against depth with its Eq. 9 model
    (measured x, v) on one axis, and each run's residual beneath, over the analysis window.

    Returns the figure and its caption, which states the answer: the RMS the model leaves per run.
    """
    plt = _plt()
    runs = list(dict.fromkeys(np.asarray(data["run_id"]).tolist()))
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6.4), sharex=True, constrained_layout=True,
                                      gridspec_kw={"height_ratios": [2.2, 1]})
    colours = plt.get_cmap("tab10").colors  # colour-blind-safe enough for ≤ 10 runs, one colour per run
    rms_all = []
    for k, run_id in enumerate(runs):
        mine = (np.asarray(data["run_id"]) == run_id) & np.asarray(data["in_window"], dtype=bool)
        depth = np.asarray(data["depth_m"])[mine] * 1e3
        measured = np.asarray(data["resistance_n"])[mine]
        model = np.asarray(data["resistance_model_n"])[mine]
        residual = measured - model
        rms = float(np.sqrt(np.mean(residual ** 2)))
        r2 = 1.0 - float(np.sum(residual ** 2) / np.sum((measured - measured.mean()) ** 2))
        rms_all.append(rms)
        colour = colours[k % len(colours)]
        top.plot(depth, measured, color=colour, lw=0.6, alpha=0.55)
        top.plot(depth, model, color=colour, lw=1.4, label=f"{run_id}: RMS {rms:.1f} N, R² {r2:.4f}")
        bottom.plot(depth, residual, color=colour, lw=0.6)
    top.set_ylabel("resistance [N]")
    top.legend(fontsize=7, title="thin: measured; thick: Eq. 9 with measured depth and speed", title_fontsize=7)
    bottom.axhline(0.0, color="0.4", lw=0.6)
    bottom.set_ylabel("measured − model [N]")
    bottom.set_xlabel("depth below the surface [mm]")
    caption = (f"{material}: Eq. 9 fitted over {len(runs)} runs leaves {min(rms_all):.1f}–{max(rms_all):.1f} N RMS "
               f"per run within the analysis window (contact + 0.5 ms to stop − 0.5 ms).")
    top.set_title(caption, fontsize=9, loc="left", wrap=True)
    return fig, caption
