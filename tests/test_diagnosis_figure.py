"""The diagnosis figure draws what the verdict says and nothing it denies: a `none` draws one row, no shaded span
and says there is no gap; an effect's verdict draws its row after the effect and shades where the gap lies."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.patches import Polygon, Rectangle

from pencli.diagnose.engine import Diagnosis, EffectReport
from pencli.report.diagnosis import diagnosis_figure


def _diagnosis(verdict: str, effects: tuple[str, ...]) -> Diagnosis:
    t = np.linspace(0.0, 0.04, 400)
    depth = np.clip((t - 0.01) * 5.0, -0.02, None)
    series = ({"run_id": "r1", "time_s": t, "depth_m": depth, "time_since_contact_s": t - 0.01,
               "baseline_residual_n": np.sin(300 * t), "effect_residual_n": 0.2 * np.sin(300 * t)},)
    where = ({"phase": "penetration", "depth_mm": [40.0, 60.0], "time_ms": [18.0, 22.0],
              "time_since_contact_ms": [8.0, 12.0], "share_of_gap": 0.9, "above_noise": True},)
    reports = tuple(EffectReport(name, "law", "resistance", {}, {}, 2.0, 75.0, True, 9.0) for name in effects)
    return Diagnosis(("r1",), {"heldout_rms_n": 8.0, "null_rms_n": 2.0}, where, reports, verdict, effects, (), 2.0,
                     series=series)


def _extent(patch) -> tuple[float, float]:
    """The horizontal extent of a shaded span (a Rectangle or, in older matplotlib, a Polygon)."""
    if isinstance(patch, Rectangle):
        return patch.get_x(), patch.get_x() + patch.get_width()
    xs = [x for x, _ in patch.get_xy()]
    return min(xs), max(xs)


def _spans(fig) -> list:
    return [p for ax in fig.axes for p in ax.patches if isinstance(p, (Polygon, Rectangle))]


def test_a_none_verdict_draws_one_row_no_span_and_says_no_gap():
    fig = diagnosis_figure(_diagnosis("none", ()))
    assert len(fig.axes) == 2  # the baseline's residuals against depth and time, nothing after an effect
    assert not _spans(fig)
    assert "no gap beyond the noise" in fig._suptitle.get_text()


def test_unexplained_shades_where_the_misfit_lies_and_says_so():
    fig = diagnosis_figure(_diagnosis("unexplained", ()))
    assert len(fig.axes) == 2 and len(_spans(fig)) == 2
    assert "unexplained" in fig._suptitle.get_text() and "no catalogue effect" in fig._suptitle.get_text()


@pytest.mark.parametrize("effects", [("strength_layer",), ("strength_layer", "force_drift")])
def test_an_effect_verdict_draws_the_residual_after_it_and_states_its_shrink(effects):
    fig = diagnosis_figure(_diagnosis(effects[0], effects))
    assert len(fig.axes) == 4
    depth_span = [p for p in fig.axes[0].patches]
    assert depth_span and np.allclose(_extent(depth_span[0]), [40.0, 60.0])
    title = fig._suptitle.get_text()
    assert " + ".join(effects) in title and "75 %" in title
    assert " + ".join(effects) in fig.axes[2].get_ylabel()


def test_the_binned_residual_is_drawn_against_the_null_replicates_band_and_counted_in_the_caption():
    from pencli.report.diagnosis import diagnosis_caption

    centres = np.linspace(2.5, 117.5, 24)
    low, high = np.full(24, -1.0), np.full(24, 1.0)
    baseline = np.where((centres > 40) & (centres < 60), 3.0, 0.2)  # four bins beyond the band
    profile = {"centres": centres, "samples": np.full(24, 50), "baseline_n": baseline, "effect_n": 0.1 * baseline,
               "null_low_n": low, "null_high_n": high}
    diagnosis = _diagnosis("strength_layer", ("strength_layer",))
    diagnosis = Diagnosis(**{**diagnosis.__dict__, "profiles": {"depth_mm": profile, "time_since_contact_ms": profile}})
    fig = diagnosis_figure(diagnosis)
    outside = int(np.sum((baseline < low) | (baseline > high)))
    assert outside == 4
    caption = diagnosis_caption(diagnosis)
    assert f"before it {outside} of 24 depth bins outside" in caption and "after it 0 of 24" in caption
    bands = [c for ax in fig.axes for c in ax.collections if c.get_label().startswith("95 % of the null")]
    assert len(bands) == 4  # both rows, depth and time
    means = [line for ax in fig.axes for line in ax.get_lines() if line.get_label() == "binned mean, all runs"]
    assert any(np.allclose(line.get_ydata(), baseline) for line in means)
    assert any(np.allclose(line.get_ydata(), 0.1 * baseline) for line in means)


def test_the_effects_fitted_force_and_found_depth_are_drawn_on_its_row():
    centres = np.linspace(2.5, 117.5, 24)
    before = np.where(centres > 40, 3.0, 0.2)
    profile = {"centres": centres, "samples": np.full(24, 50), "baseline_n": before, "effect_n": np.full(24, 0.1),
               "null_low_n": np.full(24, -1.0), "null_high_n": np.full(24, 1.0)}
    diagnosis = _diagnosis("strength_layer", ("strength_layer",))
    layer = EffectReport("strength_layer", "law", "resistance", {"depth_mm": 40.0, "ratio": 0.6}, {}, 2.0, 75.0,
                         True, 9.0)
    diagnosis = Diagnosis(**{**diagnosis.__dict__, "effects": (layer,),
                             "profiles": {"depth_mm": profile, "time_since_contact_ms": profile}})
    fig = diagnosis_figure(diagnosis)
    force = [line for line in fig.axes[2].get_lines() if line.get_label().startswith("the effect's fitted force")]
    assert len(force) == 1 and np.allclose(force[0].get_ydata(), before - 0.1)
    found = [line for ax in (fig.axes[0], fig.axes[2]) for line in ax.get_lines()
             if np.allclose(np.asarray(line.get_xdata(), dtype=float), 40.0)]
    assert len(found) == 2  # the layer's found depth on both depth panels
    assert fig.axes[0].get_ylabel().startswith("held-out residual [N]") and "with strength_layer" in \
        fig.axes[2].get_ylabel()


def test_the_effects_fitted_force_is_drawn_with_the_runs_range():
    centres = np.linspace(2.5, 117.5, 24)
    before = np.where(centres > 40, 3.0, 0.2)
    low, high = before - 0.1 - 0.5, before - 0.1 + 0.7
    profile = {"centres": centres, "samples": np.full(24, 50), "baseline_n": before, "effect_n": np.full(24, 0.1),
               "null_low_n": np.full(24, -1.0), "null_high_n": np.full(24, 1.0), "force_low_n": low,
               "force_high_n": high}
    diagnosis = _diagnosis("strength_layer", ("strength_layer",))
    diagnosis = Diagnosis(**{**diagnosis.__dict__, "profiles": {"depth_mm": profile, "time_since_contact_ms": profile}})
    fig = diagnosis_figure(diagnosis)
    (band,) = [c for c in fig.axes[2].collections if c.get_label().startswith("its range over the held-out runs")]
    ys = np.concatenate([path.vertices[:, 1] for path in band.get_paths()])
    assert np.isclose(ys.min(), low.min()) and np.isclose(ys.max(), high.max())
    assert not [c for c in fig.axes[0].collections if c.get_label().startswith("its range")]  # the effect's row only


def drawn_as_said(diagnosis):
    """Draw ``diagnosis`` and check that the figure follows it (for tests that made a real diagnosis): a row
    after the effect only for a named verdict; spans only where the first located item above the noise lies, on
    the axis it names, and only where residuals are drawn; a found depth only for an effect that has one; the
    verdict and its shrink in the caption.  Returns the figure."""
    fig = diagnosis_figure(diagnosis)
    named = diagnosis.verdict not in ("none", "unexplained")
    assert len(fig.axes) == (4 if named else 2)
    located = next((w for w in diagnosis.where if w.get("above_noise")), None) if diagnosis.verdict != "none" else None
    for col, key in ((0, "depth_mm"), (1, "time_since_contact_ms")):
        expected = [] if not located or not located.get(key) else [tuple(located[key])]
        for row, ax in enumerate(fig.axes[col::2]):
            spans = [_extent(p) for p in _spans_of(ax)]
            assert all(np.allclose(span, expected[0]) for span in spans) if expected else not spans, (key, spans)
            if row == 0:  # the baseline's row draws where its gap lies
                assert len(spans) == len(expected), (key, spans, expected)
            drawn = np.concatenate([np.asarray(line.get_xdata(), dtype=float) for line in ax.get_lines()])
            for lo, hi in spans:  # residuals are drawn where the span is
                assert np.any((drawn >= lo) & (drawn <= hi)), (key, lo, hi)
    depths = [e.params["depth_mm"] for e in diagnosis.effects
              if e.name in diagnosis.verdict_effects and isinstance(e.params.get("depth_mm"), (int, float))]
    found = [line for ax in fig.axes[0::2] for line in ax.get_lines()
             if len(set(np.asarray(line.get_xdata(), dtype=float).tolist())) == 1 and line.get_linestyle() == ":"]
    assert len(found) == (len(fig.axes) // 2) * len(depths)
    for profile in (diagnosis.profiles or {}).values():  # the pooled fitted force lies within the runs' range
        if named and "force_low_n" in profile:
            force = np.asarray(profile["baseline_n"]) - np.asarray(profile["effect_n"])
            both = np.isfinite(profile["force_low_n"]) & np.isfinite(force)
            assert both.any()
            assert np.all(profile["force_low_n"][both] - 1e-9 <= force[both])
            assert np.all(force[both] <= profile["force_high_n"][both] + 1e-9)
    title = fig._suptitle.get_text().replace("\n", " ")
    if named:
        first = next(e for e in diagnosis.effects if e.name == diagnosis.verdict_effects[0])
        assert " + ".join(diagnosis.verdict_effects) in title and f"{first.shrink_pct:.0f} %" in title
    return fig


def _spans_of(ax) -> list:
    return [p for p in ax.patches if isinstance(p, (Polygon, Rectangle))]


def fitted_force(fig, row_axis) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) of the effect's fitted force drawn on an axis of the effect's row."""
    (line,) = [line for line in row_axis.get_lines() if line.get_label().startswith("the effect's fitted force")]
    return np.asarray(line.get_xdata(), dtype=float), np.asarray(line.get_ydata(), dtype=float)
