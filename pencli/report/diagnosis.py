"""Figure of a diagnosis: held-out residuals against depth and time since contact, before and after."""

from __future__ import annotations

from pathlib import Path


def plot_diagnosis(diagnosis, path: str | Path) -> Path:
    """Write :func:`diagnosis_figure` to a PNG or PDF file."""
    import matplotlib.pyplot as plt

    from pencli.io.atomic import write_atomic

    fig = diagnosis_figure(diagnosis)
    suffix = Path(path).suffix or ".png"
    write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=110, format=suffix.lstrip(".")))
    plt.close(fig)
    return Path(path)


def diagnosis_figure(diagnosis):
    """Held-out residuals of every run against depth and time since contact: the baseline's, and with the
    verdict's effect; the span where the gap lies shaded only where the verdict places a gap.

    A ``none`` verdict draws the baseline's row alone and says there is no gap beyond the noise: nothing is
    drawn that the verdict denies.  ``unexplained`` draws the baseline's row with the span where the misfit
    lies, and says no catalogue effect explains it.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    named = diagnosis.verdict not in ("none", "unexplained") and bool(diagnosis.verdict_effects)
    rows = [("baseline_residual_n", "baseline (Eq. 9)")]
    if named:
        rows.append(("effect_residual_n", f"with {' + '.join(diagnosis.verdict_effects)}"))
    fig, axes = plt.subplots(len(rows), 2, figsize=(11, 3.6 * len(rows) + 0.4), sharey="row",
                             constrained_layout=True, squeeze=False)
    for row, (key, label) in enumerate(rows):
        for s in diagnosis.series:
            residual = s[key]
            if residual is None:
                continue
            inside = s["depth_m"] > 0
            axes[row, 0].plot(s["depth_m"][inside] * 1e3, residual[inside], lw=0.7, label=s["run_id"])
            axes[row, 1].plot(s["time_since_contact_s"] * 1e3, residual, lw=0.7)
        axes[row, 0].set_ylabel(f"held-out residual [N]\n{label}")
    if diagnosis.verdict != "none":
        for item in [w for w in diagnosis.where if w.get("above_noise")][:1]:
            if item.get("depth_mm"):
                for ax in axes[:, 0]:
                    ax.axvspan(*item["depth_mm"], color="orange", alpha=0.2, lw=0)
            if item.get("time_since_contact_ms"):
                for ax in axes[:, 1]:
                    ax.axvspan(*item["time_since_contact_ms"], color="orange", alpha=0.2, lw=0)
    axes[-1, 0].set_xlabel("depth below the surface [mm]")
    axes[-1, 1].set_xlabel("time since contact [ms]")
    axes[0, 0].legend(fontsize=7, ncol=2)
    fig.suptitle(diagnosis_caption(diagnosis), fontsize=10)
    return fig


def diagnosis_caption(diagnosis) -> str:
    """The figure's answer in one sentence, with numbers."""
    base = diagnosis.baseline
    rms, floor = base.get("heldout_rms_n", float("nan")), base.get("null_rms_n", float("nan"))
    if diagnosis.verdict == "none":
        return (f"Verdict none: no gap beyond the noise (held-out RMS {rms:.1f} N against {floor:.1f} N that noise "
                f"and the sensor chain alone leave).")
    if diagnosis.verdict == "unexplained":
        return (f"Verdict unexplained: a misfit of {rms:.1f} N held-out RMS (noise alone {floor:.1f} N) that no "
                f"catalogue effect removes half of; shaded: where it lies.")
    first = next((e for e in diagnosis.effects if e.name == diagnosis.verdict_effects[0]), None)
    shrink = f"; it shrinks the held-out RMS by {first.shrink_pct:.0f} %" if first is not None else ""
    return (f"Verdict {' + '.join(diagnosis.verdict_effects)}: held-out RMS {rms:.1f} N (noise alone {floor:.1f} N)"
            f"{shrink}; shaded: where the gap lies.")
