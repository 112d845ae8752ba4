"""`pen diagnose` on simulated-rig campaigns whose hidden effects the diagnoser never sees.

Campaigns are made at test time from seeds by the sim driver; the true
forms differ from the catalogue's terms (a plateau layer against a step, a
two-pole lag against one, guide friction on top of a lower efficiency, ...).
`bench/bench_diagnose.py` runs the larger set.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from pencli import api
from pencli.diagnose.effects import EFFECTS, views
from pencli.errors import PenNotice
from pencli.testing.campaigns import make_campaign
from tests.conftest import invoke
from tests.test_diagnosis_figure import drawn_as_said, fitted_force

SIX = [("1", 2), ("1", 6), ("1.5", 4), ("2", 2), ("2", 6), ("1.5", 6)]
BLOCKS = [5600, 6000, 6400, 7200, 8200, 5900]


def campaign(tmp_path, effects, seed, material="mpacs_c"):
    return conditioned(make_campaign(tmp_path, material, seed=seed, shots=SIX, effects=effects,
                                     block_kpa=BLOCKS if material == "mpacs_c" else None))


def dev_campaign(tmp_path, seed, index, only, effects=None):
    """Campaign ``index`` of the development set ``--varied 12 seed --only only`` diagnosed: its nuisances, and
    its own effects or ``effects`` (a form a scratch flag drew, written out).  (material, effects, nuisances,
    result)."""
    from pencli.testing.campaigns import varied_campaigns

    _, material, drawn, _, nuisances = varied_campaigns(12, seed, only=only)[index]
    effects = drawn if effects is None else effects
    db = conditioned(make_campaign(tmp_path, material, seed=seed + index, effects=effects,
                                   block_kpa=BLOCKS if material == "mpacs_c" else None, **nuisances))
    return material, effects, nuisances, api.diagnose(db, ["all"])


def catalogue_campaign(tmp_path, index):
    """Campaign ``index`` of the quick catalogue set (:func:`pencli.testing.campaigns.diagnosis_campaigns`), made from
    seed 900 + ``index`` and conditioned."""
    from pencli.testing.campaigns import diagnosis_campaigns

    _, material, effects, _ = diagnosis_campaigns(quick=True)[index]
    return conditioned(make_campaign(tmp_path, material, seed=900 + index, shots=SIX, effects=effects,
                                     block_kpa=BLOCKS if material == "mpacs_c" else None))


def conditioned(db):
    """The campaign tared and inertia-subtracted, as the diagnosis needs it."""
    api.tare_runs(db, ["all"])
    api.subtract_inertia_runs(db, ["all"])
    return db


def measured_and_predicted(db, result, effect):
    """For the run ``effect.trajectory_change`` names, the figure its end shows (the time to full depth [s],
    or the depth it stopped at [mm]): (that figure's name, as the sim rig's run measured it, as the baseline's
    dynamic model predicts it, as that prediction plus the change)."""
    from pencli.fit.resistance import with_coefficients
    from pencli.model.dynamics import simulate

    change = effect.trajectory_change
    run = next(r for r in views(api.load_campaign(db, ["all"])) if r.run_id == change["run"])
    before = simulate(with_coefficients(run.design, result.baseline["coefficients"]), rtol=1e-8).summary
    if run.end == "full_depth":
        baseline = before.penetration_time_s
        return ("penetration_time_pct", run.stop_s - run.contact_s, baseline,
                baseline * (1.0 + change["penetration_time_pct"] / 100.0))
    stop = int(np.searchsorted(run.time_s, run.stop_s))
    return ("final_depth_mm", 1e3 * float(run.depth_m[stop]), before.final_depth_mm,
            before.final_depth_mm + change["final_depth_mm"])


def test_null_campaign_with_block_scatter_is_none(tmp_path):
    result = api.diagnose(campaign(tmp_path, [], 31), ["all"])
    assert result.verdict == "none"
    assert not any(e.significant for e in result.effects)
    drawn_as_said(result)  # one row, nothing shaded


def test_grill_brick_null_is_none(tmp_path):
    assert api.diagnose(campaign(tmp_path, [], 32, "grill_brick"), ["all"]).verdict == "none"


@pytest.mark.slow
def test_plateau_layer_is_found_as_a_strength_layer_where_it_is(tmp_path):
    campaign_db = campaign(tmp_path, [{"name": "strength_layer", "depth_mm": 40, "ratio": 0.6}], 33)
    result = api.diagnose(campaign_db, ["all"])
    assert result.verdict == "strength_layer"
    layer = result.effects[0]
    assert layer.name == "strength_layer" and layer.shrink_pct >= 50
    assert 35 <= layer.params["depth_mm"] <= 45
    assert layer.params["ratio"] < 0.9
    top = result.where[0]
    assert top["phase"] == "penetration" and top["depth_mm"][1] >= 40
    drawn_as_said(result)  # the layer's found depth on both depth panels
    # the dynamic model with the layer predicts the run better than the baseline's, which absorbed part of it
    # (its force added to the baseline's coefficients, the layer was counted twice: 11.44 ms to full depth
    # against 11.76 ms for the baseline and 12.00 ms measured, on the campaign with unrecorded block scatter)
    _, measured, baseline, after = measured_and_predicted(campaign_db, result, layer)
    assert abs(after - measured) < abs(baseline - measured), (measured, baseline, after)


def test_wrong_load_cell_mass_is_found_in_the_force_chain(tmp_path):
    result = api.diagnose(campaign(tmp_path, [{"name": "load_cell_mass_error", "ratio": 1.5}], 34), ["all"])
    assert result.verdict == "load_cell_mass_error"
    assert result.effects[0].params["ratio"] == pytest.approx(1.5, rel=0.1)
    assert "measurement" in result.effects[0].trajectory_change["note"]


def test_propulsion_loss_is_a_drive_side_gap(tmp_path):
    result = api.diagnose(campaign(tmp_path, [{"name": "propulsion_loss", "loss": 0.2}], 35), ["all"])
    assert result.verdict == "propulsion_loss"
    assert result.baseline["drive_gap"]
    loss = next(e for e in result.effects if e.name == "propulsion_loss")
    assert 0.1 < loss.params["loss"] < 0.35  # truth: 20 % less efficiency plus 10 N guide friction


def test_a_guide_friction_is_a_propulsion_loss_though_it_reaches_the_surface_at_another_time(tmp_path):
    """A launcher that loses energy to a friction (99 N over the whole travel,
    no loss of efficiency; campaign 3 of ``bench_diagnose --varied 12 310000 --only propulsion_loss
    --guide-losses``) slows the flight otherwise than the drive view's loss of efficiency does.  Judged on the
    clock from release, the fitted loss moved the predicted motion away (dynamic shrink −6.9 %) because its
    contact came at another time, and the verdict was `none`; in the material, from the measured contact on, the
    loss brings it 82 % closer.  The truth is the friction alone."""
    friction = [{"name": "propulsion_loss", "loss": 0.0, "guide_friction_n": 98.6400516295093}]
    *_, result = dev_campaign(tmp_path, 310000, 3, "propulsion_loss", effects=friction)
    assert result.verdict == "propulsion_loss", (result.verdict, result.baseline["drive_t"])
    loss = next(e for e in result.effects if e.name == "propulsion_loss")
    assert loss.shrink_pct > 50.0  # the motion in the material, with the loss, against without it
    # the deficits follow a friction's law (the slow runs lose most), and its force is the truth's
    assert loss.params["law"] == "guide_friction"
    assert loss.params["guide_friction_n"] == pytest.approx(98.64, rel=0.15)


@pytest.mark.campaign
def test_a_speed_deficit_whose_loss_moves_the_motion_away_is_not_a_propulsion_loss(tmp_path):
    """A loud development null (null 9 of 20 on seed 86000, the force noise redrawn at 5–6 N) was called
    a propulsion loss: its contact speeds fell 0.44 % short (t 4.08), but the loss fitted to them made the
    predicted motion worse (dynamic shrink −23.8 %).  A loss that does not bring the motion closer explains
    nothing.  The truth has no effect at all."""
    from pencli.testing.campaigns import BLOCKS, varied_campaigns

    camps = varied_campaigns(20, 86000, only="nulls")
    own = np.random.default_rng([86000, 99])
    noise_n = [float(own.uniform(5.0, 6.0)) for _ in camps][9]
    _, material, effects, truth, nuisances = camps[9]
    assert not effects and truth == {"none"}
    nuisances = {"shots": SIX, **nuisances, "rig_extra": dict(nuisances["rig_extra"], force_noise_n=noise_n)}
    db = conditioned(make_campaign(tmp_path, material, seed=86009, effects=effects,
                                   block_kpa=BLOCKS if material == "mpacs_c" else None, **nuisances))
    result = api.diagnose(db, ["all"])
    assert result.verdict == "none", (result.verdict, result.baseline["drive_t"])


def test_effect_outside_the_catalogue_is_unexplained(tmp_path):
    result = api.diagnose(campaign(tmp_path, [{"name": "brittle_bursts", "period_mm": 20, "ratio": 0.5}], 36),
                          ["all"])
    assert result.verdict == "unexplained"
    assert result.where and result.where[0]["phase"] in ("penetration", "contact")
    drawn_as_said(result)  # one row, shaded where the misfit lies


def test_a_misfit_that_differs_from_run_to_run_is_unexplained_not_a_small_catalogue_share(tmp_path):
    """Each run's block crushes in bursts of its own period (15–40 mm): no misfit the runs share, so no generic
    profile closes it, and the catalogue's best (a plug growth, significant at z 1,135) removes 2 % of its excess
    over the null floor.  Named before whenever it was significant; a verdict now needs half the excess."""
    for k, (shot, period) in enumerate(zip(SIX, (15, 20, 25, 30, 35, 40))):
        db = make_campaign(tmp_path, "mpacs_c", seed=4100 + k, shots=[shot], block_kpa=[BLOCKS[k]],
                           effects=[{"name": "brittle_bursts", "period_mm": period, "ratio": 0.5}])
    result = api.diagnose(conditioned(db), ["all"])
    assert result.verdict == "unexplained" and not result.verdict_effects, result.notes
    best = max((e for e in result.effects if e.view == "resistance"), key=lambda e: e.explained_share)
    assert best.significant and best.explained_share < 0.5  # a significant effect, but no explanation
    note = next(n for n in result.notes if n.startswith("a misfit stays that no catalogue effect explains"))
    assert f"{best.name} {100 * best.explained_share:.0f} %" in note  # the candidates and their shares
    assert result.axes["run"] > 0.0 and set(result.axes) >= {"depth", "speed", "time_since_contact", "run"}


def test_weak_layers_each_at_its_own_depth_are_unexplained_though_nothing_is_significant(tmp_path):
    """Each run crosses a 15 mm layer 2 % weaker at a depth of its own (25–90 mm): no shape the runs share
    predicts a held-out run's, so no catalogue effect passes its test and no shared profile closes anything; each
    run's own depth profile takes part of the misfit (z 10 against 3.3): `unexplained`, with that said."""
    for k, (shot, depth) in enumerate(zip(SIX, (25, 70, 40, 90, 55, 30))):
        db = make_campaign(tmp_path, "mpacs_c", seed=4360 + k, shots=[shot], block_kpa=[BLOCKS[k]],
                           effects=[{"name": "strength_layer", "depth_mm": depth, "ratio": 0.98,
                                     "thickness_mm": 15.0, "edge_mm": 2.0}])
    result = api.diagnose(conditioned(db), ["all"])
    assert not any(e.significant for e in result.effects), [(e.name, e.z) for e in result.effects]
    assert result.verdict == "unexplained" and result.baseline["run_gap"], result.notes
    assert not result.baseline["resistance_gap"]  # no profile the runs share closes it
    assert result.baseline["own_runs_z"] > result.decision["run_gap_threshold_z"] >= result.decision["gap_threshold_z"]
    assert any(n.startswith("each run has a misfit of its own") for n in result.notes)
    drawn_as_said(result)


def test_a_campaign_that_cannot_tell_two_effects_apart_says_so_and_one_that_can_does_not(tmp_path):
    """A weak velocity friction (6 % drop) in six runs of one blade and one spring count: each run's speed is
    the same function of depth, so a strength gradient fits as well (their held-out improvements 1.4 null
    standard deviations apart).  The same friction in runs of three blades and three spring counts is told
    apart.  The verdict stays one effect name (CONTRACT §4); the notes, the JSON's ``ambiguities`` and the
    command's verdict line say which others fit as well."""
    friction = [{"name": "velocity_friction", "drop": 0.06}]
    alike = api.diagnose(conditioned(make_campaign(tmp_path / "alike", "mpacs_c", seed=61, shots=[("1.5", 4)] * 6,
                                                   effects=friction, block_kpa=BLOCKS)), ["all"], suggest=2)
    apart = api.diagnose(conditioned(make_campaign(tmp_path / "apart", "mpacs_c", seed=61, shots=SIX,
                                                   effects=friction, block_kpa=BLOCKS)), ["all"])
    assert alike.verdict == apart.verdict == "velocity_friction"
    assert [a["effects"][0] for a in alike.ambiguities] == ["velocity_friction"] * len(alike.ambiguities) != []
    other = alike.ambiguities[0]["effects"][1]
    assert abs(alike.ambiguities[0]["difference_z"]) <= 1.96
    assert alike.notes[0].startswith(f"velocity_friction or {other}: this campaign cannot tell them apart")
    assert not apart.ambiguities and not any("cannot tell them apart" in n for n in apart.notes)
    from pencli.report.diagnosis import diagnosis_caption

    assert f"(velocity_friction or {other}: these runs cannot tell them apart)" in diagnosis_caption(alike)
    assert "cannot tell" not in diagnosis_caption(apart)
    # the next runs that would tell them apart: of another blade or launcher than every run so far, each
    # putting the two further apart than any run like the campaign's own
    plan = alike.suggestions
    assert plan["candidates"] == ["velocity_friction", other] and len(plan["runs"]) == 2
    for run in plan["runs"]:
        assert (run["blade_thickness_mm"], run["spring_count"]) != (1.5, 4)
        assert run["candidates"] == ["velocity_friction", other]
        assert run["separation_sigma"] > plan["own_runs_separation_sigma"] > 0
    assert not apart.suggestions  # asked for only where wanted


def test_two_effects_are_both_found(tmp_path):
    effects = [{"name": "strength_layer", "depth_mm": 50, "ratio": 0.5, "thickness_mm": 300},
               {"name": "load_cell_mass_error", "ratio": 1.5}]
    result = api.diagnose(campaign(tmp_path, effects, 37), ["all"])
    found = set(result.verdict_effects) | {e.name for e in result.effects[:2] if e.significant}
    assert {"strength_layer", "load_cell_mass_error"} <= found


def test_a_ringing_between_two_grid_frequencies_is_followed(tmp_path):
    """One mode at 1,110 Hz, ζ 0.03, half-way between the family's grid frequencies 1,067 and 1,154 Hz
    (7.9 % apart) and between its damping ratios 0.02 and 0.04.  Over the 1/σ ≈ 5 ms it rings the nearest grid
    mode drifts a radian in phase, and the family took 51 % of the misfit (the same mode on a grid point: 90 %).
    A single-mode member now carries the mode's first-order change in frequency and decay: 75 %."""
    effects = [{"name": "rig_ringing", "amplitude_n_per_m_s": 50.0, "frequency_hz": 1110.0, "damping_ratio": 0.03,
                "second_amplitude": 0.0}]
    result = api.diagnose(campaign(tmp_path, effects, 41), ["all"])
    ring = result.effects[0]
    assert result.verdict == "rig_ringing", [(e.name, e.shrink_pct) for e in result.effects[:3]]
    assert ring.shrink_pct > 65.0, (ring.shrink_pct, ring.params)


def test_cli_writes_the_contract_json_and_a_figure_and_refuses_bad_input(tmp_path, runner):
    from matplotlib.image import imread

    db = campaign(tmp_path, [{"name": "rig_ringing", "amplitude_n_per_m_s": 60}], 38)
    out, png = tmp_path / "d.json", tmp_path / "d.png"
    r = invoke(runner, "diagnose", "all", "--db", db, "--json", out, "--plot", png)
    assert r.exit_code == 0, r.output
    report = json.loads(out.read_text())
    assert set(report) >= {"runs", "baseline", "where", "effects", "verdict"}
    assert set(report["baseline"]) >= {"heldout_rms_n", "heldout_nrmse"}
    assert report["verdict"] in set(EFFECTS) | {"none", "unexplained"}
    for effect in report["effects"]:
        assert set(effect) >= {"name", "params", "heldout_rms_n", "shrink_pct", "significant"}
        assert effect["name"] in EFFECTS
    shrinks = [e["shrink_pct"] for e in report["effects"] if e["significant"]]
    assert shrinks == sorted(shrinks, reverse=True)
    for item in report["where"]:
        assert item["phase"] in ("flight", "contact", "penetration", "rest")
    pixels = imread(png)
    assert pixels.shape[0] > 300 and np.std(pixels) > 0.05  # drawn on, not an empty canvas
    two = invoke(runner, "diagnose", "r00*", "r01*", "--db", db)
    assert two.exit_code == 1 and "at least 3 runs" in two.stderr
    bad = invoke(runner, "diagnose", "all", "--db", db, "--effects", "gremlins")
    assert bad.exit_code == 1 and "gremlins" in bad.stderr
    gif = invoke(runner, "diagnose", "all", "--db", db, "--plot", tmp_path / "d.gif")
    assert gif.exit_code == 2 and not (tmp_path / "d.gif").exists()


def test_varied_null_campaign_is_none_and_says_what_it_would_have_seen(tmp_path):
    """Coloured noise, 60 kHz, 4 N, stand-off scatter: the calibrated decisions stay quiet."""
    nuisances = {"rig_extra": {"force_noise_n": 4.0, "correlated_noise_n": 2.0, "correlated_noise_ms": 0.5,
                               "sampling_rate_hz": 60000.0},
                 "standoff_mm": [0.8, -1.1, 0.3, -0.4, 1.4, -0.9]}
    db = make_campaign(tmp_path, "grill_brick", seed=41, shots=SIX, **nuisances)
    api.tare_runs(db, ["all"])
    api.subtract_inertia_runs(db, ["all"])
    loose = api.diagnose(db, ["all"], false_alarm=0.2, bootstrap=40)
    with pytest.warns(PenNotice, match=r"75 × beyond .* --bootstrap 600 or more"):  # 1/3000 per test, 40 seen
        strict = api.diagnose(db, ["all"], false_alarm=0.001, bootstrap=40)
    assert strict.verdict == "none", (strict.verdict, strict.notes)
    # a stricter false-alarm rate asks for more evidence
    assert strict.decision["effect_threshold_z"] > loose.decision["effect_threshold_z"]
    assert strict.decision["gap_threshold_z"] > loose.decision["gap_threshold_z"]
    assert strict.decision["false_alarm"] == 0.001 and strict.decision["bootstrap"] == 40
    limits = strict.to_dict()["detection_limits_rms_n"]
    assert set(limits) >= {"strength_layer", "sensor_lag", "force_drift"}
    # of the order of the noise floor.  Velocity friction, nearly collinear with Eq. 9's P, sits highest: 3.0–3.1 ×
    # on this campaign while the threshold was a Gumbel tail (9.93 z); the replicates' largest z here has a heavy
    # tail (GEV shape −0.54 from 40 replicates), and extrapolated to 1/3000 the threshold is 42 z, which puts
    # the friction at 4.0 ×.  At strict rates, more replicates.
    friction = limits.pop("velocity_friction")
    assert 0 < friction < 5 * strict.noise_floor_n, friction
    assert all(0 < v < 4 * strict.noise_floor_n for v in limits.values()), limits
    assert any("would have been seen" in note for note in strict.notes)
    # the baseline's held-out error sits within its null replicates
    assert abs(strict.baseline["gap_z"]) < 3.5


@pytest.mark.campaign
@pytest.mark.slow
def test_the_whole_catalogue_nulls_a_pair_and_an_outside_effect(tmp_path):
    """The test set at one magnitude each, generated from seeds here (the bench uses other seeds and
    the larger set): every catalogue effect, nulls with block scatter, a two-effect campaign, an outside
    effect."""
    import statistics

    from pencli.testing.campaigns import diagnosis_campaigns, judge

    outcomes = []
    for i, (label, _, _, truth) in enumerate(diagnosis_campaigns(quick=True)):
        result = api.diagnose(catalogue_campaign(tmp_path / label, i), ["all"])
        ok, shrink = judge(result, truth)
        outcomes.append((label, truth, result.verdict, ok, shrink))
    singles = [o for o in outcomes if len(o[1]) == 1 and o[1] not in ({"none"}, {"unexplained"})]
    summary = [(o[0], o[2], o[3]) for o in outcomes]
    assert sum(o[3] for o in singles) >= 0.9 * len(singles), summary
    assert all(o[2] == "none" for o in outcomes if o[1] == {"none"}), summary
    assert all(o[3] for o in outcomes if o[1] == {"unexplained"}), summary
    assert all(o[3] for o in outcomes if len(o[1]) > 1), summary
    shrinks = [o[4] for o in outcomes if o[4] is not None and o[2] not in ("none", "unexplained")]
    assert statistics.median(shrinks) >= 60, summary


@pytest.mark.parametrize("label", ["sidewall_pressure_growth-0", "rate_strength-0", "force_drift-0"])
def test_a_family_no_other_test_shows_alone_is_named_and_closes_the_gap(tmp_path, label):
    """The catalogue's campaigns (above, seeds 900 + their place) of the families that no other test of the
    default run shows alone: the verdict names the family and its fit removes most of the baseline's held-out
    error."""
    from pencli.testing.campaigns import diagnosis_campaigns, judge

    i, truth = next((i, c[3]) for i, c in enumerate(diagnosis_campaigns(quick=True)) if c[0] == label)
    result = api.diagnose(catalogue_campaign(tmp_path, i), ["all"])
    ok, shrink = judge(result, truth)
    assert ok, (result.verdict, [(e.name, e.z, e.shrink_pct) for e in result.effects[:3]])
    assert shrink >= 60, shrink
    fig = drawn_as_said(result)
    if label.startswith("force_drift"):  # a drift's gap lies at rest after the stop: drawn there, on the time axis
        top = result.where[0]
        assert top["phase"] == "rest" and top["depth_mm"] is None
        penetrating = max(float(np.max(s["time_since_contact_s"])) for s in result.series) * 1e3
        assert top["time_since_contact_ms"][0] > penetrating
        rest = [line for line in fig.axes[1].get_lines() if line.get_linestyle() == "--"]
        assert len(rest) == len(result.series)  # every run's rest drawn


def test_a_null_behind_an_anti_alias_filter_is_none(tmp_path):
    """A 0.08 mm encoder at 60 kHz with the force channels behind a Butterworth low-pass at 0.1 of the rate: the
    filter delays the inertia force m·a in flight, which a load-cell mass column follows.  With replicates that
    did not pass the force through the filter read from the noise, this null scored a load-cell mass error at
    z 84 (and a force drift at 8.3); the filter read must be in the JSON."""
    db = make_campaign(tmp_path, "mpacs_c", seed=43, shots=SIX, block_kpa=BLOCKS, encoder_mm=0.08, anti_alias=0.1,
                       rig_extra={"sampling_rate_hz": 60000.0, "force_noise_n": 2.0})
    result = api.diagnose(conditioned(db), ["all"])
    assert result.verdict == "none", (result.verdict, [(e.name, e.z) for e in result.effects[:3]])
    read = [n["anti_alias"] for n in result.decision["noise_model"]]
    assert all(r is not None and r["corner_hz"] == pytest.approx(6000.0, rel=0.12) for r in read), read
    assert [n["line"] for n in result.decision["noise_model"]] == [None] * len(read)  # the rig makes no band


@pytest.mark.campaign
def test_a_null_behind_an_anti_alias_filter_and_a_converter_floor_is_none(tmp_path):
    """As above, with the converter adding white noise after the filter at 5 % of the gauge's (26 dB under it):
    the roll-off ends on that floor, the filter had been read as none, and this null was called a load-cell mass
    error at z 82 (seeds 44 and 45: 60 and 85)."""
    db = make_campaign(tmp_path, "mpacs_c", seed=43, shots=SIX, block_kpa=BLOCKS, encoder_mm=0.08, anti_alias=0.1,
                       converter_noise=0.05, rig_extra={"sampling_rate_hz": 60000.0, "force_noise_n": 2.0})
    result = api.diagnose(conditioned(db), ["all"])
    assert result.verdict == "none", (result.verdict, [(e.name, e.z) for e in result.effects[:3]])
    read = [n["anti_alias"] for n in result.decision["noise_model"]]
    assert all(r is not None and r["corner_hz"] == pytest.approx(6000.0, rel=0.12) for r in read), read


@pytest.mark.campaign
def test_a_null_whose_runs_read_its_filter_corner_apart_is_none(tmp_path):
    """Null 5 of ``varied_campaigns(10, 254000, only="nulls")`` (seed 254005; 8 runs at 30 kHz, 2.2 N of white
    noise, 0.08 mm counts, a 4th-order Butterworth at 3,505 Hz): the runs' noise reads the corner at 3,401–3,790 Hz,
    and the filter rings at the contact step at the true corner.  With every replicate behind the corner as read,
    that ringing was called a rig ringing at z 7.78 against 4.11; the replicates' corners drawn within the spread
    the runs' reads show, it is ``none``.  Tuned on: where the flaw was found."""
    from pencli.testing.campaigns import BLOCKS, SIX, varied_campaigns

    _, material, effects, _, nuisances = varied_campaigns(6, 254000, only="nulls")[5]
    db = make_campaign(tmp_path, material, seed=254005, effects=effects,
                       block_kpa=BLOCKS if material == "mpacs_c" else None, **{"shots": SIX, **nuisances})
    result = api.diagnose(conditioned(db), ["all"])
    assert result.verdict == "none", (result.verdict, [(e.name, e.z) for e in result.effects[:3]])
    spreads = {n["anti_alias"]["corner_spread"] for n in result.decision["noise_model"]}
    assert len(spreads) == 1 and 0.02 < spreads.pop() < 0.06, result.decision["noise_model"]


@pytest.mark.campaign
def test_a_null_read_by_a_flickering_encoder_is_none_and_its_position_error_is_read(tmp_path):
    """A 0.08 mm encoder whose reading carries 10 µm of white position error (a vibrating string): it flickers
    between counts at rest and is rougher than its quantisation in motion.  Before the rest levels and the
    replicates' position error, the stop was booked at the last flicker (up to 0.45 s late) and nulls were called
    rate strength at z 10⁴.  The error read must be in the JSON.  (Replicates quantising an error-free motion
    also call this campaign `none`; on the unrounded nuisances it was drawn from they called it a sensor lag at
    z 3.0 against 2.8, the load-cell mass column at z −117; with the error, −31.)"""
    db = make_campaign(tmp_path, "mpacs_c", seed=507, shots=[("1", 4), ("1", 6), ("2", 2), ("2", 4), ("2", 6)],
                       strength_scale=[1.013, 0.971, 1.029, 0.932, 0.981], standoff_mm=[-0.97, 1.74, -2.66, 1.22, -0.12],
                       encoder_mm=0.08, encoder_phase=[0.95, 0.14, 0.39, 0.75, 0.66], anti_alias=0.2,
                       rates_hz=[30000.0, 60000.0, 60000.0, 60000.0, 30000.0],
                       rig_extra={"force_noise_n": 0.7, "position_noise_um": 10.0})
    result = api.diagnose(conditioned(db), ["all"])
    assert result.verdict == "none", (result.verdict, [(e.name, e.z) for e in result.effects[:3]])
    read = [n["position_noise_um"] for n in result.decision["noise_model"]]
    assert all(5.0 <= r <= 15.0 for r in read), read


@pytest.mark.slow
def test_a_strong_gradient_in_scattered_blocks_is_a_gradient(tmp_path):
    """The block's strength scatter multiplies a gradient as it multiplies the strength.  Fitted
    as a shared column beside per-run strength factors, ±5 % of scatter on a gradient that more than doubles
    the strength by 100 mm was a per-run misfit that a speed law took up (dev gradient-10 of seed 41000)."""
    gradient = {"name": "strength_gradient", "change_per_100mm": 1.6, "shape": 1, "exponent": 1.6}
    db = conditioned(make_campaign(tmp_path, "grill_brick", seed=47, shots=SIX, effects=[gradient],
                                   strength_scale=[0.94, 1.05, 0.96, 1.03, 0.95, 1.04]))
    result = api.diagnose(db, ["all"])
    assert result.verdict == "strength_gradient", [(e.name, e.shrink_pct) for e in result.effects[:3]]
    top = result.effects[0]
    assert top.name == "strength_gradient" and top.shrink_pct > 75.0


@pytest.mark.campaign
@pytest.mark.slow
def test_a_gradient_of_two_slopes_is_a_gradient(tmp_path):
    """A gradient no one curve of the family matched (steepening threefold at 50 mm) was named a
    plateau layer (74 % shrink against the best curve's 67 %) and then, with smooth monotone sums in the family,
    a monotone sum.  The family holds two straight slopes meeting at a depth, and
    the fit must find the truth's: the kink at 50 mm, the slope tripling there, the strength ×2.5 at 100 mm."""
    gradient = {"name": "strength_gradient", "change_per_100mm": 1.5, "shape": 3, "kink_mm": 50, "slope_ratio": 3}
    result = api.diagnose(campaign(tmp_path, [gradient], seed=62), ["all"])
    assert result.verdict == "strength_gradient", [(e.name, e.shrink_pct) for e in result.effects[:3]]
    found = result.effects[0].params
    assert found["shape"] == "two_slopes" and found["kink_mm"] == 50.0, found
    assert found["slope_ratio"] == pytest.approx(3.0, rel=0.1) and found["change_per_100mm"] == pytest.approx(1.5, rel=0.1)


def test_a_drift_with_a_velocity_friction_is_a_pair(tmp_path):
    """Two drift shapes together match a velocity friction on five runs about as well as the friction
    does, so "better than a second own shape by more than the null's noise" failed and the friction was lost.
    What the friction adds on top of the best pair of drift shapes told them apart.  The drift family has powers, logarithms and time constants √2 apart: one drift shape follows this drift,
    and the friction beats a second one outright (it removes 97 % of what the drift leaves); the route through
    the own pair is held by ``test_a_pressure_growth_under_ringing_counts_against_what_ringings_own_pair_leaves``."""
    effects = [{"name": "force_drift", "amplitude_n": 85.0, "time_constant_s": 0.02, "shape": 2},
               {"name": "velocity_friction", "drop": 0.5, "speed_m_s": 2.7, "shape": 0}]
    db = conditioned(make_campaign(tmp_path, "grill_brick", seed=55010, effects=effects, encoder_mm=0.16,
                                   shots=[("1", 2), ("1", 6), ("1", 4), ("2", 2), ("2", 4)],
                                   rig_extra={"force_noise_n": 0.5, "sampling_rate_hz": 60000.0},
                                   strength_scale=[0.99, 0.92, 0.97, 0.99, 0.86],
                                   standoff_mm=[0.5, 0.9, 0.9, 0.7, 0.2], encoder_phase=[0.45] * 5))
    result = api.diagnose(db, ["all"])
    assert set(result.verdict_effects) == {"force_drift", "velocity_friction"}, result.baseline.get("best_pair")


@pytest.mark.campaign
@pytest.mark.slow
def test_a_friction_beside_a_drift_is_found_though_it_extrapolates_wildly_on_null_replicates(tmp_path):
    """A velocity friction (a linear fall, 53 % of μ at 3.3 m/s) beside a drift on four runs at two
    spring counts.  Beside the drift, each friction member fitted to a null replicate's noise extrapolated
    wildly to some held-out run on more than half of the replicates (median improvement −37 N², down to
    −159,000 N²); the null's MAD was 46 N², and a friction that removed all of the drift's remainder (102 → 5.5
    N², floor 8.7) scored z 2.9 against 4.6 and was lost.  A fold whose other folds are fitted better without
    the second effect now scores without it.  Campaign 10 of ``--pairs 12 99500 --drift-friction`` (its
    nuisances; the forms written out)."""
    effects = [{"name": "force_drift", "amplitude_n": 94.8, "time_constant_s": 0.0413, "shape": 0},
               {"name": "velocity_friction", "drop": 0.527, "speed_m_s": 3.34, "shape": 1}]
    *_, result = dev_campaign(tmp_path, 99500, 10, "pairs", effects)
    assert set(result.verdict_effects) == {"force_drift", "velocity_friction"}, result.baseline.get("best_pair")


@pytest.mark.campaign
@pytest.mark.slow
@pytest.mark.xfail(reason="with the window ending 2 ms before a hard stop the friction beside the drift is lost: "
                          "the best second is a strength gradient (not significant); the last 2 ms before the stops "
                          "hold the lowest speeds a speed law is told apart by")
def test_a_friction_beside_a_drift_between_the_old_time_constants_is_a_pair(tmp_path):
    """A drift 1 − e^(−t/33 ms) fell between the family's time constants (20 and 50 ms); a second
    drift shape took that mismatch, did better than the friction beside the first (over the own pair z −12),
    and the friction was lost.  With time constants √2 apart (and logarithmic and power drifts) the friction
    removes 59 % of what the drift leaves and adds on top of the own pair.  Campaign 6 of ``--pairs 12 105000
    --drift-friction`` (its nuisances; the forms written out)."""
    effects = [{"name": "force_drift", "amplitude_n": 125.97, "time_constant_s": 0.033, "shape": 0},
               {"name": "velocity_friction", "drop": 0.55, "speed_m_s": 2.974, "shape": 1}]
    *_, result = dev_campaign(tmp_path, 105000, 6, "pairs", effects)
    assert set(result.verdict_effects) == {"force_drift", "velocity_friction"}, result.baseline.get("best_pair")


@pytest.mark.campaign
@pytest.mark.slow
@pytest.mark.xfail(strict=False, reason=(
    "premise gone with the exact bounded solve: the plug growth's z is "
    "6.75 (OpenBLAS Zen, Haswell) or 6.77 (SkylakeX) against the family-wise 7.87 or 7.88, so nothing passes and "
    "the verdict is none on every kernel tried. The plug passed only under the old solve, which stopped short of "
    "the optimum on some null replicates' plug fits, and only with the SkylakeX kernel (7.94 against 7.79; Zen "
    "7.15 against 7.72). Non-strict: the friction's own z still moves with the kernel (5.12 Zen, 4.90 SkylakeX)"))
def test_a_friction_that_closes_more_than_a_plug_growth_the_familywise_test_passes_is_named(tmp_path):
    """A velocity friction (a linear fall of 46 % to 3.5 m/s) on five grill-brick
    runs at mixed rates behind an anti-alias filter, a 0.32 mm encoder, 4.3 N white and 1.2 N correlated noise.
    A plug growth passed the family-wise test (z 7.9 against 7.7) closing 7.7 % of the held-out error and was
    named; the friction closed 19.4 % at z 5.3 (its null wide: a speed law on a coarse encoder's speeds).  The
    family-wise test now says there is an effect, the fit says which.  Campaign 22 of ``--varied 24 161000
    --only velocity_friction``."""
    from pencli.testing.campaigns import varied_campaigns

    _, material, effects, truth, nuisances = varied_campaigns(24, 161000, only="velocity_friction")[22]
    assert truth == {"velocity_friction"} and material == "grill_brick" and nuisances["encoder_mm"] == 0.32
    db = conditioned(make_campaign(tmp_path, material, seed=161022, effects=effects, **nuisances))
    result = api.diagnose(db, ["all"])
    assert result.verdict == "velocity_friction", (result.baseline.get("naming"), result.notes)


@pytest.mark.campaign
@pytest.mark.slow
def test_a_gradient_whose_slope_falls_to_a_sixth_at_a_depth_is_a_gradient(tmp_path):
    """Strength rising ×3.5 by 100 mm, steeply to 57 mm and at a sixth of that
    slope after it (sim truth shape 3), on eight grill-brick runs, was named a strength layer: a step at the kink
    was the nearest other shape.  The gradient family now holds two straight slopes meeting at a depth.
    Campaign 6 of ``--varied 12 181000 --only strength_gradient --two-slopes``."""
    from pencli.testing.campaigns import two_slopes
    from pencli.testing.campaigns import varied_campaigns

    _, material, effects, truth, nuisances = two_slopes(varied_campaigns(12, 181000, only="strength_gradient"),
                                                        181000)[6]
    assert truth == {"strength_gradient"} and effects[0]["shape"] == 3.0 and material == "grill_brick"
    db = conditioned(make_campaign(tmp_path, material, seed=181006, effects=effects, **nuisances))
    result = api.diagnose(db, ["all"])
    assert result.verdict == "strength_gradient", [(e.name, e.shrink_pct) for e in result.effects[:3]]


@pytest.mark.campaign
@pytest.mark.slow
def test_an_exponential_gradient_between_the_old_lengths_is_named_alone(tmp_path):
    """A strength growing as 3.95^(x/100 mm) (e-folding over 73 mm) fell between the gradient family's
    exponential lengths (40, 80 and 160 mm); fitted at 80 mm it left 5 × the null floor, and a strength layer
    beside it took that mismatch and was reported as a second effect.  With lengths 2^¼ apart the gradient
    leaves 1.6 × the floor and stands alone.  Campaign 17 of ``--varied 28 106000`` (7 grill-brick runs, a
    0.32 mm encoder, white and AR(1) noise)."""
    from pencli.testing.campaigns import varied_campaigns

    _, material, effects, truth, nuisances = varied_campaigns(28, 106000)[17]
    assert truth == {"strength_gradient"} and effects[0]["shape"] == 0.0 and material == "grill_brick"
    db = conditioned(make_campaign(tmp_path, material, seed=106017, effects=effects, **nuisances))
    result = api.diagnose(db, ["all"])
    assert list(result.verdict_effects) == ["strength_gradient"], result.baseline.get("best_pair")
    assert result.effects[0].shrink_pct > 94.0, [(e.name, e.shrink_pct) for e in result.effects[:3]]


def test_a_delay_whose_late_rise_falls_outside_the_stand_off_tolerance_is_a_lag(tmp_path):
    """A pure delay of 0.44 ms with block surfaces up to 3.9 mm off the file's stand-off moved one run's
    force rise past where its contact was looked for, the window took the step in, and the campaign was named a
    force drift that closed 0.8 % of the gap (the lag: −5.6 %).  The drawn campaign 3 of the development lags of
    seed 62000 (7 grill-brick runs at 30 kHz, 0.65 N of noise, anti-alias filter)."""
    from pencli.testing.campaigns import varied_campaigns

    _, material, effects, truth, nuisances = varied_campaigns(14, 62000, only="sensor_lag")[3]
    assert effects[0]["shape"] == 2.0 and material == "grill_brick"
    db = conditioned(make_campaign(tmp_path, material, seed=62003, effects=effects, **nuisances))
    result = api.diagnose(db, ["all"])
    assert result.verdict == "sensor_lag", [(e.name, e.z, e.shrink_pct) for e in result.effects[:3]]
    # the one run whose surface (2.96 mm past the stand-off) plus the delay at 10.4 m/s (4.6 mm) passes the 5 mm
    # tolerance; its rise comes 2.96 mm / 10.4 m/s + 0.44 ms = 0.72 ms after the position's contact
    late = result.baseline["late_force_rise_ms"]
    assert nuisances["standoff_mm"][2] > 2.9 and set(late) == {"r02-1mm-4s"}, late
    assert abs(late["r02-1mm-4s"] - (2.96 / 10.4 + effects[0]["tau_ms"])) < 0.1, late
    # the figure: no found depth (a lag has none); what the lag takes out is largest at the force's step, in the
    # first millisecond after contact
    fig = drawn_as_said(result)
    since_contact, force = fitted_force(fig, fig.axes[3])
    seen = np.isfinite(force)
    assert since_contact[seen][np.argmax(np.abs(force[seen]))] < 1.0


@pytest.mark.campaign
@pytest.mark.parametrize("index", [1, 2])
def test_a_delay_between_the_old_grid_delays_under_late_rises_is_a_lag(tmp_path, index):
    """Pure delays of 0.65 and 0.58 ms (dev sensor lags 1 and 2 of ``--varied 16 190000 --only
    sensor_lag``: Grill Brick, 6 and 4 runs, 4.6 and 4.9 N of noise) were named a load-cell mass error, the lag
    not even significant.  Two causes: the surfaces were read from change points before the late rises (one run's
    put 4.3 mm deep, where the right delay then scored 2,986 N²), and the delay members stood 0.45 and 0.7 ms
    apart, so the folds' picks jumped between them and the odd pick scored 45–67 N² on its run (the baseline
    21–28 N²).  The truth is the simulated rig's; the expected verdict is the truth's name."""
    from pencli.testing.campaigns import varied_campaigns

    _, material, effects, truth, nuisances = varied_campaigns(16, 190000, only="sensor_lag")[index]
    assert effects[0]["shape"] == 2.0 and 0.55 < effects[0]["tau_ms"] < 0.7 and material == "grill_brick"
    db = conditioned(make_campaign(tmp_path, material, seed=190000 + index, effects=effects, **nuisances))
    result = api.diagnose(db, ["all"])
    assert result.verdict == "sensor_lag", [(e.name, e.z, e.shrink_pct) for e in result.effects[:3]]
    assert result.effects[0].params["shape"] == "delay", result.effects[0].params


def test_a_pressure_growth_under_ringing_counts_against_what_ringings_own_pair_leaves(tmp_path):
    """The struck modes (a second one 1.62 × the first's frequency, decaying twice as fast) are more than
    one ringing member follows, so the ringing alone leaves a misfit of its own; the pressure growth removed a
    third of that (z 260 against 4.2), short of the half a second effect must remove, though it removed 80 % of
    what the best pair of ringing shapes leaves.  Campaign 1 of ``bench_diagnose --pairs 12 66000
    --ringing-pairs`` (4 Grill Brick runs, 0.32 mm encoder, 4.6 N of noise).  A single ringing mode carries its first-order change in frequency and decay, the ringing alone leaves less, and
    the pressure removes 70 % of it: the case the test was written for (under half) is gone, the verdict and
    what the pressure adds over the own pair are still checked."""
    effects = [{"name": "rig_ringing", "amplitude_n_per_m_s": 56.0, "frequency_hz": 1284.5, "damping_ratio": 0.0595,
                "second_amplitude": 0.206, "second_ratio": 1.62},
               {"name": "sidewall_pressure_growth", "scale_mm": 59.9, "exponent": 1.88, "shape": 1.0, "rise": 2.34}]
    db = conditioned(make_campaign(tmp_path, "grill_brick", seed=66001, effects=effects, encoder_mm=0.32,
                                   shots=[("1.5", 2), ("1", 6), ("1.5", 4), ("1", 2)],
                                   rig_extra={"force_noise_n": 4.61, "correlated_noise_n": 0.0,
                                              "sampling_rate_hz": 30000.0},
                                   strength_scale=[0.937, 1.087, 1.044, 0.966], standoff_mm=[1.75, 1.79, -0.54, 2.25],
                                   encoder_phase=[0.0] * 4, converter_noise=0.165))
    result = api.diagnose(db, ["all"])
    pair = result.baseline["best_pair"]
    assert set(result.verdict_effects) == {"rig_ringing", "sidewall_pressure_growth"}, pair
    assert pair["over_own_pair"]["adds"] and pair["over_own_pair"]["share_of_remainder"] >= 0.5, pair


@pytest.mark.campaign
def test_a_gradient_saturating_within_a_few_millimetres_is_a_gradient(tmp_path):
    """Strength that rises 2.4-fold within the first 4.3 mm (saturating) was named a strength layer or a
    plug growth; the gradient family's saturating members started at 20 mm.  Campaign 5 of a development
    scratch set: the drawn gradients of ``--varied 8 68000 --only strength_gradient --short-gradients``, made
    saturating, 4–15 mm long (a stream of their own), here 5 Grill Brick runs at mixed rates behind an anti-alias filter.  Its
    margin is small (layer 86.8 % against gradient 81.2 % with the nuisances rounded to 3 digits).  A layer member
    "plateau" from 5 to 15 mm (4 mm edges) would score 91.2 % against the gradient's 87.3 % were a plateau not a
    band whose bottom edge goes back."""
    from pencli.testing.campaigns import varied_campaigns

    _, material, effects, _, nuisances = varied_campaigns(8, 68000, only="strength_gradient")[5]
    own = np.random.default_rng([68000, 9])
    length_mm = [float(own.uniform(4, 15)) for _ in range(8)][5]
    effects = [dict(effects[0], shape=2.0, length_mm=length_mm)]
    assert material == "grill_brick" and length_mm < 5.0
    db = conditioned(make_campaign(tmp_path, material, seed=68005, effects=effects, **nuisances))
    result = api.diagnose(db, ["all"])
    assert result.verdict == "strength_gradient", [(e.name, e.z, e.shrink_pct) for e in result.effects[:3]]


@pytest.mark.campaign
def test_a_gradient_rising_in_an_s_wider_than_a_layers_edge_is_a_gradient(tmp_path):
    """Strength rising in an S (a tanh step tens of millimetres wide) was named a strength layer or a
    plug growth: the gradient family had no S-shaped member, the layer's widest edge (12 mm) came nearest.
    Campaign 1 of ``bench_diagnose --varied 8 78000 --only strength_gradient --s-gradients`` (the S's centre and
    width from a stream of their own), named a plug growth.  Single S-shaped rises in the gradient family name it a
    gradient, but unrestricted they fail: centred past the depth a fold's training runs reach, an S-rise is
    unconstrained there and explodes on the held-out run of a tenth of the null replicates, and that wide null
    lost a layer + ringing pair
    (``test_a_layer_under_ringing_is_a_pair_though_a_second_ringing_shape_explodes_on_some_replicates``).  An
    S-rise now enters only where every fold's training runs reach a width past its centre (``Member.reach_m``)."""
    from pencli.testing.campaigns import BLOCKS, varied_campaigns

    _, material, effects, _, nuisances = varied_campaigns(8, 78000, only="strength_gradient")[1]
    own = np.random.default_rng([78000, 11])
    drawn = [(float(own.uniform(20, 80)), float(own.uniform(15, 40))) for _ in range(2)]  # centre, width
    centre_mm, width_mm = drawn[1]
    effects = [dict(effects[0], shape=4.0, length_mm=centre_mm, width_mm=width_mm)]
    assert width_mm > 12.0  # wider than any layer edge of the catalogue
    db = conditioned(make_campaign(tmp_path, material, seed=78001, effects=effects,
                                   block_kpa=BLOCKS if material == "mpacs_c" else None, **nuisances))
    result = api.diagnose(db, ["all"])
    assert result.verdict == "strength_gradient", [(e.name, e.z, e.shrink_pct) for e in result.effects[:3]]


@pytest.mark.campaign
def test_a_layer_under_ringing_is_a_pair_though_a_second_ringing_shape_explodes_on_some_replicates(tmp_path):
    """The layer beat a second ringing shape by 11,902 N² on the data, but two ringing shapes together
    extrapolate wildly on a few null replicates (−10¹⁵ N²), and the plain sd of the difference (4·10¹⁴) hid it.
    The drawn campaign 2 of the development pairs of seed 60000 (4 runs, coloured noise, anti-alias filter)."""
    from pencli.testing.campaigns import BLOCKS, varied_campaigns

    _, material, effects, truth, nuisances = varied_campaigns(12, 60000, only="pairs")[2]
    assert truth == {"rig_ringing", "strength_layer"}
    db = conditioned(make_campaign(tmp_path, material, seed=60002, effects=effects, block_kpa=BLOCKS, **nuisances))
    result = api.diagnose(db, ["all"])
    assert set(result.verdict_effects) == truth, result.baseline.get("best_pair")


@pytest.mark.slow
@pytest.mark.parametrize("effect, seed, key, truth, tolerance", [
    ({"name": "plug_growth", "growth_mm": 2.0, "length_mm": 20.0, "shape": 1}, 52, "growth_mm", 2.0, 0.15),
    pytest.param({"name": "strength_layer", "depth_mm": 30, "ratio": 1.8, "thickness_mm": 300}, 51, "ratio", 1.8, 0.08,
                 marks=pytest.mark.campaign),
])
def test_a_strong_effects_size_is_stated_against_the_fit_that_has_it(tmp_path, effect, seed, key, truth, tolerance):
    """An effect's size is stated against the strength factor of the fit with the effect in.  The
    baseline's absorbs part of a strong effect: against it a 2.0 mm plug read 0.95 mm and a 1.8 × layer 1.52."""
    db = conditioned(make_campaign(tmp_path, "mpacs_c", seed=seed, shots=SIX, effects=[effect], block_kpa=BLOCKS,
                                   strength_scale=[0.95, 1.04, 0.97, 1.03, 0.96, 1.05]))
    result = api.diagnose(db, ["all"])
    assert result.verdict == effect["name"]
    assert result.effects[0].params[key] == pytest.approx(truth, rel=tolerance)


@pytest.mark.slow
@pytest.mark.parametrize("effect, seed, figure, left", [
    ({"name": "plug_growth", "growth_mm": 2.0, "length_mm": 20.0, "shape": 1}, 52, "final_depth_mm", 0.3),
    pytest.param({"name": "strength_gradient", "change_per_100mm": 1.0}, 53, "penetration_time_pct", 0.35,
                 marks=pytest.mark.campaign),
])
def test_a_strong_effects_trajectory_change_leads_to_the_measured_run(tmp_path, effect, seed, figure, left):
    """The trajectory with the effect is the fit *with* the effect (its own strength, P, C and K)
    plus the effect's force.  On the baseline's coefficients, which absorb part of a strong effect, the force
    was counted twice: a 2 mm plug's blade stopped at 84 mm against the 110 mm measured (the baseline's at
    128 mm), a gradient's penetration took 15.3 ms against 13.2 ms measured (the baseline's 12.9 ms).
    Blocks without scatter, so the median run's strength is the campaign's mean.  ``left``: the share of the
    baseline's error the effect may leave.  The gradient (e-folding over 144 mm) was fitted at 160 mm and left
    under 0.3; since the lengths are 2^¼ apart it is fitted at 134.5 mm, with its change at 100 mm 0.72 for
    1.0 (the baseline's P and K take the rest), and leaves 0.31 (13.14 ms against 13.23 ms measured, the
    baseline's 12.93 ms).  Why an exponential is not followed closer is open."""
    db = conditioned(make_campaign(tmp_path, "mpacs_c", seed=seed, shots=SIX, effects=[effect]))
    result = api.diagnose(db, ["all"])
    top = result.effects[0]
    assert top.name == effect["name"]
    shown, measured, baseline, after = measured_and_predicted(db, result, top)
    assert shown == figure  # the run stopped in the block (the plug's), or went to full depth (the gradient's)
    assert abs(baseline - measured) > 0.015 * measured  # the effect matters to the trajectory
    assert abs(after - measured) < left * abs(baseline - measured), (measured, baseline, after)


def test_a_null_read_by_a_coarse_encoder_at_30_khz_is_none(tmp_path):
    """The data's tip meets the material between two samples; the replicates' did on one.  With each
    replicate's acceleration jumping exactly at the derivatives' break, the data's derivative error around
    contact was larger than any replicate's, and this null (0.32 mm encoder, 30 kHz, dev null-26 of seed 43000
    in that configuration) was called a sensor lag at z 7.8 against 4.4.  On 30 such nulls the data's lag
    improvement stood above the replicates' median in 24, and 2 were called a lag; 0 once each replicate's
    contact is drawn within the sampling interval before the break."""
    db = make_campaign(tmp_path, "grill_brick", seed=43026, shots=[("1.5", 4), ("2", 6), ("1.5", 2), ("1", 6), ("1", 4)],
                       rig_extra={"force_noise_n": 3.2533910821748866, "sampling_rate_hz": 30000.0}, encoder_mm=0.32,
                       strength_scale=[1.0763102211664286, 1.00035191152437, 0.973554286181353, 1.0374923720268432,
                                       1.017738561357161],
                       standoff_mm=[-0.07016525615080679, -0.3544131564865499, -0.32687594177848317, 4.80806293696783,
                                    1.6754945184700265],
                       encoder_phase=[0.6573548685951855] * 5)
    result = api.diagnose(conditioned(db), ["all"])
    assert result.verdict == "none", [(e.name, e.z) for e in result.effects[:3]]
    lag = next(e for e in result.effects if e.name == "sensor_lag")
    assert lag.z < result.decision["effect_threshold_z"]


def test_a_steep_plug_in_blocks_whose_surfaces_scatter_is_a_plug_of_its_size(tmp_path):
    """A plug 2.5 mm wide at saturation (exponential, 23 mm) on blades of 1–2 mm, in four blocks whose
    surfaces lay −0.6 to +2.3 mm from the file's stand-off.  With depth counted from the file's stand-off the
    plug's own exact shape left a held-out RMS of 54 N against 2.5 N of noise (7.5 N with no stand-off
    scatter), fitted growth 1.7 mm, and the campaign was named a strength layer; depth counted from each
    block's surface as its force saw it (:func:`pencli.diagnose.effects.surfaces`) gives the plug.
    Campaign 2 of the development set ``--varied 12 82000 --only plug_growth``."""
    material, effects, nuisances, result = dev_campaign(tmp_path, 82000, 2, "plug_growth")
    assert material == "mpacs_c" and max(nuisances["standoff_mm"]) > 2.0
    assert result.verdict == "plug_growth", [(e.name, e.z, e.shrink_pct) for e in result.effects[:3]]
    # each block's surface in the JSON, against the stand-off scatter the rig was given (both less their median),
    # to within the blade's travel in one sample at contact (0.35 mm at 10.5 m/s and 30 kHz)
    read = np.array([result.baseline["surface_mm"][k] for k in sorted(result.baseline["surface_mm"])])
    truth = np.array(nuisances["standoff_mm"])
    assert np.abs((read - np.median(read)) - (truth - np.median(truth))).max() < 0.35, (read, truth)
    plug = next(e for e in result.effects if e.name == "plug_growth")  # lengths √2 apart: 4.8 mm
    assert plug.params["growth_mm"] == pytest.approx(effects[0]["growth_mm"], rel=0.25), (plug.params, effects)


def test_a_stribeck_friction_is_a_velocity_friction_not_a_plug(tmp_path):
    """Friction that falls with speed (by 39 % of μ, 1.5 m/s) and rises again past it (a viscous part,
    54 % of μ at 10 m/s), a form outside the development sim's ``--varied`` draws.  No one-law speed member
    follows a fall and a rise; the plug's depth-growing damping and inertia columns came closer, and the
    campaign was named a plug (34 % shrink against the friction's 33 %).  Campaign 10 of the development set
    ``--varied 12 95000 --only velocity_friction --wide-friction`` (its nuisances; the form written out)."""
    stribeck = [{"name": "velocity_friction", "shape": 4, "drop": 0.39, "speed_m_s": 1.51, "viscous": 0.54}]
    *_, result = dev_campaign(tmp_path, 95000, 10, "velocity_friction", stribeck)
    ranked = [(e.name, e.z, e.shrink_pct, e.params.get("shape")) for e in result.effects[:3]]
    assert result.verdict == "velocity_friction", ranked
    friction = next(e for e in result.effects if e.name == "velocity_friction")
    plug = next(e for e in result.effects if e.name == "plug_growth")
    assert friction.shrink_pct > plug.shrink_pct + 10, ranked


@pytest.mark.campaign
@pytest.mark.slow
def test_a_plug_that_drives_the_baselines_strength_factor_below_zero_is_still_a_plug(tmp_path):
    """A plug 2.7 mm wide at 49 mm (a capped power of depth, exponent 2.5) on blades of 1–2 mm more than
    triples the frontal force of the thinnest.  The baseline without it fits negative strength factors (its P and
    K take the growth), and the plug's strength column, built at their mean, pointed against the plug, whose
    growth is bounded ≥ 0: the plug's own exact shape was held at zero growth (48–173 N per held-out run) and the
    campaign was named a gradient.  Campaign 6 of ``--varied 12 99300 --only plug_growth --wide-plugs`` (its
    nuisances; the form written out)."""
    capped = [{"name": "plug_growth", "shape": 3, "growth_mm": 2.71, "length_mm": 49.3, "exponent": 2.48}]
    *_, result = dev_campaign(tmp_path, 99300, 6, "plug_growth", capped)
    ranked = [(e.name, e.z, e.shrink_pct, e.params.get("growth_mm")) for e in result.effects[:3]]
    assert result.verdict == "plug_growth", ranked
    plug, second = result.effects[0], result.effects[1]
    assert plug.shrink_pct > second.shrink_pct + 5 and plug.params["growth_mm"] > 0, ranked


@pytest.mark.campaign
@pytest.mark.slow
def test_a_plug_that_forms_slowly_then_fast_is_not_taken_by_a_staircase_of_two_layer_edges(tmp_path):
    """A plug 2.2 mm wide that forms as (x/18.1 mm)^2.48 and then stays was named a strength layer: the
    layer family's "plateau" 5–15 mm had both edges rising (+0.70 and +1.02 of the strength), a two-step
    staircase, a graded profile no layer has, and it fitted the plug's rise better than the plug family did
    (996 against 1,060 N² held out).  A plateau is now a band (its bottom edge goes back).  Campaign 2 of
    ``--varied 12 99300 --only plug_growth --wide-plugs`` (its nuisances; the form written out)."""
    capped = [{"name": "plug_growth", "shape": 3, "growth_mm": 2.24, "length_mm": 18.1, "exponent": 2.48}]
    *_, result = dev_campaign(tmp_path, 99300, 2, "plug_growth", capped)
    ranked = [(e.name, e.z, e.shrink_pct, e.params.get("shape")) for e in result.effects[:3]]
    assert result.verdict == "plug_growth", ranked
    layer = next(e for e in result.effects if e.name == "strength_layer")
    if layer.params["shape"] == "plateau":  # a band: below it the strength goes back
        back = layer.params["ratio_below"] - layer.params["ratio"]
        assert back * (layer.params["ratio"] - 1.0) <= 1e-9, layer.params


@pytest.mark.campaign
@pytest.mark.slow
def test_a_plug_that_forms_as_the_square_root_of_depth_is_a_plug(tmp_path):
    """A plug 2.8 mm wide that forms as (x/14.5 mm)^0.44 and then stays: steep at the surface, a corner
    at 14.5 mm.  None of the exponential, hyperbolic or straight capped rises follows both, and the campaign was
    named a strength layer.  Campaign 8 of ``--varied 12 99400 --only plug_growth --wide-plugs`` (its nuisances;
    the form written out).  Its size reads low, 1.76 mm for 2.79, and 2.08 with the exact form as the only
    member: past the first millimetres this plug is a constant added width, which each run's own strength factor
    (block scatter) takes up; only the rise near the surface tells it apart.  This test does not read the size."""
    concave = [{"name": "plug_growth", "shape": 3, "growth_mm": 2.79, "length_mm": 14.5, "exponent": 0.44}]
    *_, result = dev_campaign(tmp_path, 99400, 8, "plug_growth", concave)
    ranked = [(e.name, e.z, e.shrink_pct, e.params.get("shape")) for e in result.effects[:3]]
    assert result.verdict == "plug_growth", ranked
    plug = result.effects[0]
    assert plug.params["shape"] == "capped_power" and plug.params["exponent"] == 0.5, (plug.params, ranked)
