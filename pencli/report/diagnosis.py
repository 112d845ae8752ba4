"""Figure of a diagnosis: held-out residuals against depth and time since contact, before and after."""

from __future__ import annotations

import textwrap
from pathlib import Path


def plot_diagnosis(diagnosis, path: str | Path) -> Path:
    """Write :func:`diagnosis_figure` to a PNG or PDF file."""
    import matplotlib.pyplot as plt

    from pencli.io.atomic import write_atomic

    fig = diagnosis_figure(diagnosis)
    suffix = Path(path).suffix or ".png"
    write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=200, format=suffix.lstrip(".").lower()))
    plt.close(fig)
    return Path(path)


def diagnosis_figure(diagnosis):
    """Held-out residuals of every run against depth and time since contact: the baseline's (and, dashed, the
    force at rest after the stop less what holds the blade, when the gap lies there), and with the verdict's
    effect; the span where the gap lies shaded only where the verdict places a gap, on the rows that draw
    residuals there.

    A ``none`` verdict draws the baseline's row alone and says there is no gap beyond the noise: nothing is
    drawn that the verdict denies.  ``unexplained`` draws the baseline's row with the span where the misfit
    lies, and says no catalogue effect explains it.
    """
    import matplotlib
    import numpy as np

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    named = diagnosis.verdict not in ("none", "unexplained") and bool(diagnosis.verdict_effects)
    rows = [("baseline_residual_n", "baseline (Eq. 9)")]
    if named:
        rows.append(("effect_residual_n", f"with {' + '.join(diagnosis.verdict_effects)}"))
    fig, axes = plt.subplots(len(rows), 2, figsize=(11, 3.6 * len(rows) + 0.4), sharey="row",
                             constrained_layout=True, squeeze=False)
    profile_key = {"baseline_residual_n": "baseline_n", "effect_residual_n": "effect_n"}
    located = next((w for w in diagnosis.where if w.get("above_noise")), None) if diagnosis.verdict != "none" else None
    at_rest = located is not None and located.get("phase") == "rest"  # the gap lies after the stop: draw the rest
    for row, (key, label) in enumerate(rows):
        for s in diagnosis.series:
            residual = s[key]
            if residual is None:
                continue
            inside = s["depth_m"] > 0
            axes[row, 0].plot(s["depth_m"][inside] * 1e3, residual[inside], lw=0.5, alpha=0.45, label=s["run_id"])
            line, = axes[row, 1].plot(s["time_since_contact_s"] * 1e3, residual, lw=0.5, alpha=0.45)
            if at_rest and key == "baseline_residual_n" and s.get("rest_residual_n") is not None:
                axes[row, 1].plot(s["rest_time_since_contact_s"] * 1e3, s["rest_residual_n"], lw=0.5, alpha=0.45,
                                  color=line.get_color(), ls="--")
        for col, axis in enumerate(("depth_mm", "time_since_contact_ms")):
            profile = (diagnosis.profiles or {}).get(axis)
            if not profile or profile_key[key] not in profile:
                continue
            ax = axes[row, col]
            ax.fill_between(profile["centres"], profile["null_low_n"], profile["null_high_n"], color="0.6",
                            alpha=0.35, lw=0, label="95 % of the null replicates' binned means")
            ax.plot(profile["centres"], profile[profile_key[key]], color="k", lw=1.6, marker="o", ms=3,
                    label="binned mean, all runs")
            if key == "effect_residual_n":  # what the effect takes out: its fitted force along the axis
                ax.plot(profile["centres"], np.asarray(profile["baseline_n"]) - np.asarray(profile["effect_n"]),
                        color="tab:red", lw=1.4, ls="--", label="the effect's fitted force (before − after)")
                if "force_low_n" in profile:
                    ax.fill_between(profile["centres"], profile["force_low_n"], profile["force_high_n"],
                                    color="tab:red", alpha=0.15, lw=0,
                                    label="its range over the held-out runs (lowest to highest run)")
                ax.legend(fontsize=6, loc="upper right")
        axes[row, 0].set_ylabel(f"held-out residual [N]\n{label}")
    for effect in diagnosis.effects:
        depth = effect.params.get("depth_mm") if effect.name in diagnosis.verdict_effects else None
        if isinstance(depth, (int, float)):
            for ax in axes[:, 0]:
                ax.axvline(float(depth), color="tab:red", lw=1.0, ls=":")
            axes[-1, 0].annotate(f"{effect.name} at {float(depth):.0f} mm", (float(depth), 0.0),
                                 xycoords=("data", "axes fraction"), xytext=(3, 4), textcoords="offset points",
                                 fontsize=7, color="tab:red")
    if located is not None:
        for col, key in ((0, "depth_mm"), (1, "time_since_contact_ms")):
            if not located.get(key):
                continue
            lo, hi = located[key]
            for ax in axes[:, col]:  # only where the row draws residuals: a span over nothing says nothing
                drawn = [np.asarray(line.get_xdata(), dtype=float) for line in ax.get_lines()]
                if any(np.any((x >= lo) & (x <= hi)) for x in drawn):
                    ax.axvspan(lo, hi, color="orange", alpha=0.2, lw=0)
    axes[-1, 0].set_xlabel("depth below the surface [mm]")
    axes[-1, 1].set_xlabel("time since contact [ms]")
    axes[0, 0].legend(fontsize=6, ncol=2)
    for ax in axes.ravel():
        ax.axhline(0.0, color="0.3", lw=0.6)
    fig.suptitle(textwrap.fill(diagnosis_caption(diagnosis), 150), fontsize=9)
    return fig


def outside_band(profile: dict, key: str = "baseline_n") -> tuple[int, int]:
    """(bins whose binned mean lies outside the null replicates' 95 % band, bins with samples)."""
    import numpy as np

    value = np.asarray(profile.get(key, []), dtype=float)
    low, high = np.asarray(profile["null_low_n"], dtype=float), np.asarray(profile["null_high_n"], dtype=float)
    seen = np.isfinite(value) & np.isfinite(low) & np.isfinite(high)
    return int(np.sum(seen & ((value < low) | (value > high)))), int(np.sum(seen))


def _bands_sentence(diagnosis, key: str) -> str:
    profile = (diagnosis.profiles or {}).get("depth_mm")
    if not profile or key not in profile:
        return ""
    out, bins = outside_band(profile, key)
    return f"{out} of {bins} depth bins outside the null replicates' 95 % band (grey)"


def diagnosis_caption(diagnosis) -> str:
    """The figure's answer in one sentence, with numbers."""
    base = diagnosis.baseline
    rms, floor = base.get("heldout_rms_n", float("nan")), base.get("null_rms_n", float("nan"))
    before = _bands_sentence(diagnosis, "baseline_n")
    if diagnosis.verdict == "none":
        return (f"Verdict none: no gap beyond the noise (held-out RMS {rms:.1f} N against {floor:.1f} N that noise "
                f"and the sensor chain alone leave" + (f"; {before}" if before else "") + ").")
    if diagnosis.verdict == "unexplained":
        return (f"Verdict unexplained: a misfit of {rms:.1f} N held-out RMS (noise alone {floor:.1f} N) that no "
                f"catalogue effect removes half of" + (f"; {before}" if before else "") + "; shaded: where it lies.")
    first = next((e for e in diagnosis.effects if e.name == diagnosis.verdict_effects[0]), None)
    shrink = f"; it shrinks the held-out RMS by {first.shrink_pct:.0f} %" if first is not None else ""
    after = _bands_sentence(diagnosis, "effect_n")
    bands = f"; before it {before}, after it {after.split(' depth bins')[0]}" if before and after else ""
    alike = "".join(f" or {a['effects'][1]}" for a in diagnosis.ambiguities)
    alike = f" ({diagnosis.verdict_effects[0]}{alike}: these runs cannot tell them apart)" if alike else ""
    return (f"Verdict {' + '.join(diagnosis.verdict_effects)}{alike}: held-out RMS {rms:.1f} N (noise alone "
            f"{floor:.1f} N){shrink}{bands}; shaded: where the gap lies.")
