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
    """Baseline and verdict-effect held-out residuals of every run; shaded: where the gap was located."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(11, 7), sharey="row", constrained_layout=True)
    effect = diagnosis.verdict_effects[0] if diagnosis.verdict_effects else None
    for row, (key, label) in enumerate((("baseline_residual_n", "baseline (Eq. 9)"),
                                        ("effect_residual_n", f"with {effect}" if effect else "no effect added"))):
        for s in diagnosis.series:
            residual = s[key]
            if residual is None:
                continue
            inside = s["depth_m"] > 0
            axes[row, 0].plot(s["depth_m"][inside] * 1e3, residual[inside], lw=0.7, label=s["run_id"])
            axes[row, 1].plot(s["time_since_contact_s"] * 1e3, residual, lw=0.7)
        axes[row, 0].set_ylabel(f"held-out residual [N]\n{label}")
    for item in diagnosis.where[:1]:
        if item.get("depth_mm"):
            for ax in axes[:, 0]:
                ax.axvspan(*item["depth_mm"], color="orange", alpha=0.2, lw=0)
        if item.get("time_since_contact_ms"):
            for ax in axes[:, 1]:
                ax.axvspan(*item["time_since_contact_ms"], color="orange", alpha=0.2, lw=0)
    axes[1, 0].set_xlabel("depth [mm]")
    axes[1, 1].set_xlabel("time since contact [ms]")
    axes[0, 0].legend(fontsize=7, ncol=2)
    fig.suptitle(f"pen diagnose: verdict {diagnosis.verdict} (shaded: where the gap lies)")
    return fig
