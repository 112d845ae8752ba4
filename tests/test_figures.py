"""What the report figures draw, read back from the figures themselves: names and units on every axis, captions
whose numbers are the data's, intervals that respect their bounds, and numbered, captioned figures in the page."""

from __future__ import annotations

import json
import re
import shutil

import numpy as np
import yaml
import pytest

from pencli import api
from pencli.report import figures
from tests.conftest import REPO

RAW_KEY = re.compile(r"\b[a-z]+(?:_[a-z0-9]+)*_(?:mm|s|n|nm|kpa|j|m|kg|pct|deg|m_s|m_s2|kg_m3|kn_m|kpa_s_m)\b")
"""A stored key with its unit in the name (``blade_thickness_mm``, ``fx_n``): what no figure may show."""


@pytest.fixture(scope="module")
def example(tmp_path_factory):
    root = tmp_path_factory.mktemp("figures")
    shutil.copytree(REPO / "examples" / "workspace", root / "workspace")
    return root / "workspace" / "runs.duckdb"


def texts_of(fig) -> list[str]:
    """Every piece of text a figure shows: titles, axis labels, tick labels, legends, annotations, colour bars."""
    from matplotlib.text import Text

    fig.canvas.draw()
    return [t.get_text() for t in fig.findobj(Text) if t.get_visible() and t.get_text()]


def close(fig):
    import matplotlib.pyplot as plt

    plt.close(fig)


def model_table(db, run_id):
    ws = api.workspace(db)
    fit = [v for v in ws.material_versions() if run_id in v["source_runs"]][-1]
    data = ws.read_table(fit["model_data_path"], "model", filters=[("run_id", "=", run_id)]).to_pydict()
    return {k: np.asarray(v) for k, v in data.items()}


def balance_of(db, run_id):
    from pencli.fit.energy import measured_energy

    ws = api.workspace(db)
    fit = [v for v in ws.material_versions() if run_id in v["source_runs"]][-1]
    return measured_energy(ws.load_run(run_id), json.loads(fit["coefficients"]), json.loads(fit["fit"])["ci95"])


def every_figure(db):
    """(name, figure, caption) for every figure kind a report draws, from the example workspace."""
    ws = api.workspace(db)
    run = ws.load_run("mc-1.0-4")
    raw = ws.load_run("mc-1.0-4", "raw")
    events = run.events.to_dict()
    yield ("raw", *figures.raw_channels("mc-1.0-4", raw.columns, events))
    yield ("kinematics", *figures.kinematics_panels("mc-1.0-4", run.columns, events))
    yield ("model", *figures.model_vs_data("mc-1.0-4", model_table(db, "mc-1.0-4")))
    fit_table = ws.read_table(ws.material_versions("mpacs_c")[-1]["model_data_path"], "model").to_pydict()
    yield ("campaign", *figures.campaign_fit("mpacs_c", {k: np.asarray(v) for k, v in fit_table.items()}))
    yield ("energy", *figures.energy_balance("mc-1.0-4", balance_of(db, "mc-1.0-4")))
    together = [(r, ws.load_run(r, "raw"), ws.load_run(r)) for r in ("mc-1.0-4", "gb-1.5-4")]
    yield ("campaign-raw", *figures.campaign_raw([(r, raw.columns, run.events.to_dict()) for r, raw, run in together]))
    yield ("campaign-kinematics", *figures.campaign_kinematics([(r, run.columns, run.events.to_dict())
                                                                for r, _, run in together]))
    yield ("campaign-energy", *figures.campaign_energy([(r, balance_of(db, r)) for r, _, _ in together]))
    fit = json.loads(ws.material_versions("mpacs_c")[-1]["fit"])
    yield ("fit", *figures.fit_intervals("mpacs_c", fit))
    sweep = ws.sweep_row(1)
    keys = list(json.loads(sweep["variables"]))
    table = {k: np.asarray(v) for k, v in ws.read_table(sweep["path"], "sweep").to_pydict().items()}
    yield ("map", *figures.sweep_map(table, keys[0], keys[1], "penetration_time_s"))
    yield ("map-final-depth", *figures.sweep_map(table, keys[0], keys[1], "final_depth_mm"))
    yield ("partial", *figures.sweep_partial(table, keys))
    three = dict(table, extra_mm=np.linspace(0, 1, len(table[keys[0]])))
    yield ("scatter", *figures.sweep_scatter(three, [*keys, "blade_width_mm"] if "blade_width_mm" in table
                                             else [keys[0], keys[1], keys[0]]))


def test_no_figure_shows_a_raw_key_and_every_axis_has_a_unit(example):
    for name, fig, caption in every_figure(example):
        shown = texts_of(fig)
        try:
            assert not [t for t in shown if RAW_KEY.search(t)], (name, [t for t in shown if RAW_KEY.search(t)])
            assert not RAW_KEY.search(caption), (name, caption)
            for ax in fig.axes:
                for text in (ax.get_xlabel(), ax.get_ylabel()):
                    if text and name not in ("fit",):  # the fit's correlation axes carry symbols
                        assert re.search(r"\[[^\]]+\]", text) or text in ("",), (name, text)
            assert re.search(r"\d", caption), (name, caption)  # the answer, with numbers
        finally:
            close(fig)


def test_the_model_figure_states_the_rms_of_its_own_data_and_draws_the_residual(example):
    data = model_table(example, "mc-2.0-2")
    fig, caption = figures.model_vs_data("mc-2.0-2", data)
    try:
        window = data["in_window"].astype(bool)
        residual = data["resistance_n"][window] - data["resistance_model_n"][window]
        rms = np.sqrt(np.mean(residual ** 2))
        assert f"leaves {rms:.1f} N RMS" in caption
        drawn = [line for ax in fig.axes for line in ax.get_lines()
                 if np.size(line.get_ydata()) == residual.size and np.allclose(line.get_ydata(), residual)]
        assert drawn, "the residual against Eq. 9 is drawn"
        # nothing is drawn outside the window on the force-depth axis: no drop to 0 N after the stop
        force_axis = fig.axes[0]
        assert min(float(np.min(line.get_ydata())) for line in force_axis.get_lines()) > 0.0
        assert all(np.size(line.get_xdata()) == residual.size for line in force_axis.get_lines())
    finally:
        close(fig)


def test_the_fit_figure_holds_intervals_at_their_bounds_and_numbers_its_correlations(example):
    fit = json.loads(api.workspace(example).material_versions("mpacs_c")[-1]["fit"])
    fit["ci95"]["damping_kpa_s_m"] = [-0.81, 0.81]  # a normal interval that crosses C ≥ 0, as a C = 0 fit gives
    fig, caption = figures.fit_intervals("mpacs_c", fit)
    try:
        drawn_x = [x for ax in fig.axes for line in ax.get_lines() for x in np.atleast_1d(line.get_xdata())]
        assert min(drawn_x) >= 0.0
        assert any("held at its bound 0" in t for t in texts_of(fig))
        numbers = [t for t in texts_of(fig) if re.fullmatch(r"[+-]\d\.\d\d", t)]
        assert len(numbers) == len(fit["correlation"]) ** 2
        assert "C = " in caption and "[0" in caption.split("C = ")[1][:30]
    finally:
        close(fig)


def test_a_sweep_map_is_drawn_in_the_unit_its_colour_bar_names(example):
    ws = api.workspace(example)
    sweep = ws.sweep_row(1)
    keys = list(json.loads(sweep["variables"]))
    table = {k: np.asarray(v) for k, v in ws.read_table(sweep["path"], "sweep").to_pydict().items()}
    fig, caption = figures.sweep_map(table, keys[0], keys[1], "penetration_time_s")
    try:
        filled = fig.axes[0].collections[0]  # the filled contours: their levels span the data, in ms
        lo, hi = np.min(table["penetration_time_s"]) * 1e3, np.max(table["penetration_time_s"]) * 1e3
        assert min(filled.levels) <= lo and hi <= max(filled.levels) <= 1.2 * hi
        assert any("penetration time [ms]" in t for t in texts_of(fig))
        crosses = 0 < np.mean(table["full_penetration"]) < 1
        assert ("full-penetration boundary" in caption) == bool(crosses)
        assert f"{np.max(table['penetration_time_s']) * 1e3:.4g} ms" in caption
    finally:
        close(fig)
    with pytest.raises(ValueError, match="three varied parameters"):
        figures.sweep_scatter(table, keys[:2])


def test_the_report_numbers_and_captions_every_figure(example, tmp_path):
    from pencli.report.build import PDF_TEXT_COLUMNS, Section, _text_lines, write_report

    sections = api.report_runs(example, ["mc-1.0-4", "gb-1.0-2"]) + api.report_material(example, "mpacs_c")
    write_report("pen report: two runs and MPACS C", sections, tmp_path / "r.html")
    page = (tmp_path / "r.html").read_text()
    assert "<html lang='en'>" in page and "name='viewport'" in page
    numbers = [int(n) for n in re.findall(r"<figure id='figure-(\d+)'", page)]
    assert numbers == list(range(1, sum(len(s.figures) for s in sections) + 1))
    captions = re.findall(r"<figcaption><b>Figure (\d+)[^<]*</b> ([^<]+)</figcaption>", page)
    assert len(captions) == len(numbers) and all(len(text) > 40 for _, text in captions)
    alts = re.findall(r"<svg role='img' aria-label='([^']+)'", page)
    assert len(alts) == len(numbers) and len(set(alts)) == len(alts)  # each figure titled, no two alike
    assert "<text" in page and "resistance R [N]" in page  # figures are vector, their text kept as text
    assert "(paper Fig. 13)" in page and "(paper Fig. 11)" in page
    long = Section("long", text="word " * 400, provenance={"key": "x" * 500})
    assert all(len(line) <= PDF_TEXT_COLUMNS for line in _text_lines(long))


def test_predict_draws_a_run_whose_energy_bars_balance(tmp_path, runner):
    from matplotlib.image import imread

    from tests.conftest import invoke

    out = tmp_path / "run.png"
    r = invoke(runner, "predict", "-p", "al6061_1mm", "-m", "mpacs_c", "-e", "springs_4", "--plot", out)
    assert r.exit_code == 0, r.output
    assert imread(out).shape[0] > 500 and "reaches full depth" in r.stderr
    prediction = api.predict("al6061_1mm", "mpacs_c", "springs_4")
    fig, caption = figures.prediction("x", prediction.result.trajectory, prediction.result.summary)
    try:
        bars = [p.get_height() for p in fig.axes[2].patches]
        supplied, spent = sum(bars[:2]), sum(bars[2:])
        assert spent == pytest.approx(supplied, rel=1e-6)  # springs + gravity = each term + what is left
        # the stacked terms add up to the model's resistance at every depth
        top = fig.axes[1].collections[-1].get_paths()[0].vertices[:, 1].max()
        assert top == pytest.approx(float(np.max(prediction.result.trajectory.resistance_n)), rel=1e-6)
    finally:
        close(fig)
    bad = invoke(runner, "predict", "-p", "al6061_1mm", "-m", "mpacs_c", "-e", "springs_4", "--plot",
                 tmp_path / "run.jpg")
    assert bad.exit_code == 2 and "--plot" in bad.output and not (tmp_path / "run.jpg").exists()


def test_a_prediction_band_follows_the_fitted_covariance(tmp_path):
    """With the covariance of one coefficient, the band of the penetration time lies between the runs simulated
    (independently of the band) at that coefficient 1.56σ and 2.36σ either side: the time is monotonic in the
    strength, and the 2.5 and 97.5 % points of 400 draws scatter by 0.135σ about ±1.96σ (±0.4σ is three of
    that).  With no covariance the band is the prediction itself; the figure shades it and its caption states it."""
    from dataclasses import replace

    from pencli.model.dynamics import simulate
    from pencli.predict.band import prediction_band

    central = api.predict("al6061_1mm", "mpacs_c", "springs_2")
    mean = {k.split(".", 1)[1]: v for k, v in central.material.values.items() if k.startswith("coefficients.")}
    sigma = 0.02 * mean["strength_factor"]
    band = prediction_band(central.design, mean, {"strength_factor": {"strength_factor": sigma ** 2}},
                           central.result, draws=400)

    def time_at(k):
        factor = (mean["strength_factor"] + k * sigma) / mean["strength_factor"]
        design = replace(central.design, strength_factor=central.design.strength_factor * factor)
        return simulate(design).summary.penetration_time_s

    lo, hi = band.figures["penetration_time_s"]
    inner, outer = sorted((time_at(-1.56), time_at(1.56))), sorted((time_at(-2.36), time_at(2.36)))
    assert outer[0] < lo < inner[0] < inner[1] < hi < outer[1], (outer, inner, lo, hi)
    assert np.all(band.depth_low_m <= central.result.trajectory.depth_m + 1e-6)  # the integrator's tolerance
    assert np.all(central.result.trajectory.depth_m <= band.depth_high_m + 1e-6)
    still = prediction_band(central.design, mean, {"strength_factor": {"strength_factor": 0.0}}, central.result,
                            draws=5)
    assert still.figures["penetration_time_s"][1] - still.figures["penetration_time_s"][0] < 1e-12
    fig, caption = figures.prediction("x", central.result.trajectory, central.result.summary, band)
    try:
        assert f"takes {lo * 1e3:.2f}–{hi * 1e3:.2f} ms" in caption and "95 % of 400 draws" in caption
        shaded = [c for ax in fig.axes for c in ax.collections if "drawn from the fit's covariance" in c.get_label()]
        assert len(shaded) == 2  # depth against time, resistance against depth
    finally:
        close(fig)


def test_a_fit_writes_its_covariance_and_predict_plots_its_band(tmp_path, runner):
    from tests.conftest import invoke

    example = tmp_path / "ws"
    shutil.copytree(REPO / "examples" / "workspace", example)
    db = example / "runs.duckdb"
    outcome = api.fit(db, "mpacs_c", ["mc-*"], out=tmp_path / "fit.yaml", record=False, bootstrap=0)
    written = yaml.safe_load((tmp_path / "fit.yaml").read_text())["coefficient_covariance"]
    for name, c in outcome.result.coefficients.items():
        assert written[name][name] == pytest.approx(c.stderr ** 2, rel=1e-9)
    r = invoke(runner, "predict", "-p", "al6061_1mm", "-m", tmp_path / "fit.yaml", "-e", "springs_4", "--plot",
               tmp_path / "run.svg")
    assert r.exit_code == 0, r.output
    assert "over the fit's uncertainty (95 % of 100 draws)" in r.stderr


def test_a_map_of_three_variables_holds_the_third_at_a_stated_value_and_a_list_is_drawn_as_categories():
    rng = np.random.default_rng(3)
    a, b, c = np.meshgrid(np.linspace(1, 2, 5), np.linspace(6, 12, 5), np.array([100.0, 150.0, 200.0]),
                          indexing="ij")
    table = {"blade_thickness_mm": a.ravel(), "spring_stiffness_kn_m": b.ravel(), "blade_width_mm": c.ravel()}
    depth = np.minimum(133.0, 40 * table["spring_stiffness_kn_m"] / table["blade_thickness_mm"]
                       * 150 / table["blade_width_mm"] + rng.normal(0, 0.1, a.size))
    table.update(final_depth_mm=depth, full_penetration=depth >= 133.0, penetration_time_s=depth / 1e4,
                 residual_ke_j=np.where(depth >= 133.0, 5.0, 0.0))
    fig, caption = figures.sweep_map(table, "blade_thickness_mm", "spring_stiffness_kn_m", "final_depth_mm",
                                     others=["blade_width_mm"])
    close(fig)
    assert "rectangular blade width w held at 150 mm" in caption
    assert "over 25 designs" in caption  # the slice, not the 75 designs averaged
    fig, caption = figures.sweep_partial(table, ["blade_thickness_mm", "blade_width_mm"], "final_depth_mm")
    try:
        width_axis = fig.axes[1]
        assert [t.get_text() for t in width_axis.get_xticklabels()] == ["100", "150", "200"]
        assert width_axis.containers  # points with their spread (an error bar), not a band
    finally:
        close(fig)


def test_the_measured_energy_balances_to_within_two_percent_on_every_example_run(example):
    """The sim rig's runs, conditioned and fitted: the kinetic energy at contact plus the drive's work in the
    material is what the fitted terms dissipate plus what is left, to 2 %; the launcher delivers what its file
    says to 3 %; and the figure draws the numbers the balance holds."""
    for run_id in api.workspace(example).run_ids():
        b = balance_of(example, run_id)
        assert abs(b.unaccounted_j) < 0.02 * b.supplied_j, (run_id, b)
        assert abs(b.launcher_shortfall_j) < 0.03 * b.launcher_j, (run_id, b)
        for term, span in b.terms_interval_j.items():
            assert span is None or span[0] - 1e-9 <= b.terms_j[term] <= span[1] + 1e-9, (run_id, term)
    fig, caption = figures.energy_balance("mc-1.5-2", b := balance_of(example, "mc-1.5-2"))
    try:
        heights = [p.get_height() for p in fig.axes[0].patches]
        contact, drive, *terms, left, missing = heights[1:]
        assert contact + drive == pytest.approx(sum(terms) + left + missing)
        assert f"{b.contact_ke_j:.1f} J" in caption and "not accounted for" in caption
    finally:
        close(fig)


def test_runs_drawn_together_show_each_run_once_per_panel_in_its_own_colour(example):
    ws = api.workspace(example)
    ids = ["mc-1.0-4", "mc-2.0-2", "gb-1.0-2"]
    runs = {r: ws.load_run(r) for r in ids}
    raws = {r: ws.load_run(r, "raw") for r in ids}
    fig, caption = figures.campaign_raw([(r, raws[r].columns, runs[r].events.to_dict()) for r in ids])
    kin, kin_caption = figures.campaign_kinematics([(r, runs[r].columns, runs[r].events.to_dict()) for r in ids])
    try:
        for panel in [*fig.axes, *kin.axes]:
            colours = [tuple(line.get_color()) for line in panel.get_lines() if np.size(line.get_xdata()) > 2]
            assert len(colours) == len(ids) and len(set(colours)) == len(ids)  # one line per run, colours apart
        assert [t.get_text() for t in fig.legends[0].get_texts()] == ids
        peaks = [float(np.max(raws[r].columns["fz_n"])) for r in ids]
        assert f"peak axial force {min(peaks):.0f}–{max(peaks):.0f} N" in caption
        # each run's depth is drawn against the time since its own contact: 0 mm at 0 ms
        for line in kin.axes[0].get_lines()[:len(ids)]:
            t, depth = np.asarray(line.get_xdata()), np.asarray(line.get_ydata())
            assert abs(float(np.interp(0.0, t, depth))) < 1.0
        speeds = [runs[r].events.contact_speed_m_s for r in ids]
        assert f"contact (dashed) at {min(speeds):.2f}–{max(speeds):.2f} m/s" in kin_caption
        arrested = sum(runs[r].events.end == "arrest" for r in ids)
        assert f"{arrested} arrested in the material" in kin_caption
    finally:
        close(fig)
        close(kin)


def test_the_campaign_energy_bars_are_each_runs_shares_and_a_term_set_to_zero_draws_nothing(example):
    from dataclasses import replace

    ids = ["mc-1.0-4", "mc-1.5-2", "gb-2.0-2"]
    balances = [(r, balance_of(example, r)) for r in ids]
    balances = [(r, replace(b, terms_j={**b.terms_j, "damping": 0.0})) for r, b in balances]  # as a fit at C = 0
    fig, caption = figures.campaign_energy(balances)
    try:
        ax = fig.axes[0]
        legend = [t.get_text() for t in fig.legends[0].get_texts()]
        bars = {name: container for name, container in zip(legend, ax.containers)}
        for k, (run_id, b) in enumerate(balances):
            for term, value in b.terms_j.items():
                if term in bars:
                    assert bars[term].patches[k].get_width() == pytest.approx(100 * value / b.supplied_j)
            lost = bars["not accounted for"].patches[k]
            assert lost.get_width() == pytest.approx(100 * b.unaccounted_j / b.supplied_j)
        assert "damping" not in legend and {"strength", "friction", "inertia"} <= set(legend)
        worst = max(balances, key=lambda rb: abs(rb[1].unaccounted_j / rb[1].supplied_j))
        assert f"{100 * worst[1].unaccounted_j / worst[1].supplied_j:+.1f} % ({worst[0]})" in caption
    finally:
        close(fig)
