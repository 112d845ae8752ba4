"""`pen acquire`: the simulated rig end to end, and the nidaq driver against a fake nidaqmx."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import yaml

from pencli import api
from pencli.acquire.calibration import load_force_calibration, load_position_calibration
from tests import fake_nidaqmx
from tests.conftest import invoke
from pencli.testing.helpers import snapshot


def _raw(workspace, run_id):
    table, _ = api.workspace(workspace / "runs.duckdb").read_stage(run_id, "raw")
    return {name: table.column(name).to_numpy() for name in table.column_names}


def test_sim_acquire_records_the_run_as_the_paper_describes(workspace, runner):
    truth_file = workspace / "truth.json"
    r = invoke(runner, "acquire", "--springs", "2", "-p", "al6061_1mm", "-m", "mpacs_c", "--yes", "--save",
               "--id", "shot1", "--operator", "me", "--tag", "test", "--truth-out", truth_file, "--json")
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["id"] == "shot1"
    truth = json.loads(truth_file.read_text())
    cols = _raw(workspace, "shot1")
    t = cols["time_s"]
    rate = (t.size - 1) / (t[-1] - t[0])
    assert rate == pytest.approx(30000, rel=1e-9)
    assert t[0] == pytest.approx(-0.2, abs=1e-12)  # 0.2 s kept before the release
    pos = cols["position_mm"]
    moving = np.flatnonzero(np.diff(pos)) + 1
    assert t[-1] - t[moving[-1]] == pytest.approx(0.2, abs=2 / rate)  # and 0.2 s after the motion stops
    steps = np.unique(np.round(np.diff(np.unique(pos)), 9))
    assert np.allclose(steps / 0.16, np.round(steps / 0.16))  # encoder quantisation 0.16 mm
    offset = 148.0  # springs_2 stand-off
    assert pos.max() - offset == pytest.approx(truth["final_depth_mm"], abs=0.16)
    pre = t < 0
    assert np.std(cols["fz_n"][pre]) == pytest.approx(2.0, rel=0.1)  # the default rig's noise
    assert np.mean(cols["fz_n"][pre]) == pytest.approx(-0.8 - 0.389 * 9.81, abs=0.2)  # offset + blade weight
    detail = api.run_detail(workspace / "runs.duckdb", "shot1")
    info = json.loads(detail.row["info"])
    assert info["driver"] == "sim" and info["operator"] == "me" and "tare_before_fire" in info
    assert "strength_pa" not in json.dumps(info)  # the truth is not stored with the run
    assert "coefficients" not in detail.parameters["material"]  # a run records measured properties only


def test_declining_to_fire_records_nothing(workspace, runner):
    before = snapshot(workspace)
    r = invoke(runner, "acquire", "--springs", "4", "--save", input="n\n")
    assert r.exit_code == 1 and "not fired" in r.stderr
    assert snapshot(workspace) == before


def test_discard_keeps_nothing(workspace, runner):
    r = invoke(runner, "acquire", "--springs", "6", "--yes", "--discard")
    assert r.exit_code == 0 and "discarded" in r.output
    assert not (workspace / "runs.duckdb").exists()


def test_rig_file_hidden_effect_changes_the_run_but_not_its_record(workspace, runner):
    rig = workspace / "rig.yaml"
    rig.write_text(yaml.safe_dump({"kind": "rig", "name": "layered", "seed": 3, "true_material": "mpacs_c",
                                   "effects": [{"name": "strength_layer", "depth_mm": 15, "ratio": 0.4}]}))
    for run_id, extra in (("plain", []), ("layered", ["--rig", rig])):
        r = invoke(runner, "acquire", "--springs", "2", "-m", "mpacs_c", "--yes", "--save", "--id", run_id, *extra)
        assert r.exit_code == 0, r.output
    plain, layered = _raw(workspace, "plain"), _raw(workspace, "layered")
    assert layered["position_mm"].max() > plain["position_mm"].max() + 5  # a weak layer lets it go deeper
    params = api.workspace(workspace / "runs.duckdb").run_parameters("layered")
    assert "effects" not in json.dumps(params)


def test_encoder_phase_moves_where_the_counts_step_not_where_they_start(workspace, runner):
    """Rest at the middle of a count (0) steps after half a count of travel; rest just short of an edge (0.45
    of a count past the middle) steps after 0.05 of a count.  Both records read 0 at rest."""
    first_step = {}
    for phase in (0.0, 0.45):
        rig = workspace / f"rig-{phase}.yaml"
        rig.write_text(yaml.safe_dump({"kind": "rig", "name": "p", "seed": 3, "encoder_phase": phase}))
        run_id = f"phase-{phase}"
        r = invoke(runner, "acquire", "--springs", "4", "--yes", "--save", "--id", run_id, "--rig", rig)
        assert r.exit_code == 0, r.output
        raw = _raw(workspace, run_id)
        position, time = raw["position_mm"], raw["time_s"]
        rest = position[time < 0]
        assert np.all(rest == rest[0])
        first_step[phase] = time[np.argmax(position != rest[0])]
    # from rest under a nearly constant push the travel grows as t²: 0.5 and 0.05 of a count are √10 apart
    # in time (sampled at 30 kHz, so only roughly)
    assert first_step[0.45] < 0.5 * first_step[0.0]


def test_the_anti_alias_filter_passes_white_noise_in_its_noise_bandwidth():
    """A 4th-order Butterworth low-pass at f_c passes white noise of a band f_c·(π/8)/sin(π/8) wide (its
    noise-equivalent bandwidth): at 3 kHz of a 30 kHz record, √(1.0262·3/15) = 0.453 of the noise's standard
    deviation, read on the pre-trigger span of the axial channel."""
    from pencli import api

    spread = {}
    for corner in (0.0, 3000.0):
        rig = {"kind": "rig", "name": "aa", "seed": 5, "force_noise_n": 4.0, "anti_alias_hz": corner}
        columns = api.acquire(springs=2, penetrator="al6061_1mm", material="mpacs_c", rig=rig).run.columns
        spread[corner] = float(np.std(columns["fz_n"][columns["time_s"] < -0.01]))
    expected = math.sqrt(math.pi / 8 / math.sin(math.pi / 8) * 3000.0 / 15000.0)
    assert spread[0.0] == pytest.approx(4.0, rel=0.04)
    assert spread[3000.0] / spread[0.0] == pytest.approx(expected, rel=0.06)


@pytest.mark.parametrize("kind,order", [("butterworth", 4), ("bessel", 4), ("bessel", 8), ("chebyshev", 4),
                                        ("chebyshev", 5)])
def test_each_kind_of_anti_alias_filter_has_its_corner_ripple_and_rest_level(kind, order):
    """The rig's anti-alias kinds by their definitions, read from the same white noise with and without the filter
    (the ratio of their spectra is |H|²): a Butterworth or Bessel (magnitude-normalised) is 3 dB down at its corner;
    a Chebyshev type I of 3 dB ripple, scaled to a gain of 1 at 0 Hz, swings by a factor 2 in power over its pass
    band (between 1 and 2 from a trough at 0 Hz for an even order, 0.5 and 1 from a peak for an odd one) and ends
    on a trough at its corner; and every kind reads a 100 N rest level as
    100 N (unscaled, an even-order Chebyshev reads it 29 % low)."""
    from scipy.signal import welch

    from pencli import api

    def pre_trigger(**extra):
        rig = {"kind": "rig", "name": "k", "seed": 5, "force_noise_n": 4.0, "force_offsets_n": [0.0, 0.0, 100.0],
               "anti_alias_ripple_db": 3.0, **extra}
        columns = api.acquire(springs=2, penetrator="al6061_1mm", material="mpacs_c", rig=rig).run.columns
        return columns["fz_n"][columns["time_s"] < -0.01]

    plain = pre_trigger()
    filtered = pre_trigger(anti_alias_hz=3000.0, anti_alias_kind=kind, anti_alias_order=order)
    assert np.mean(filtered) == pytest.approx(np.mean(plain), abs=0.2)
    freq, p0 = welch(plain - plain.mean(), fs=30000.0, nperseg=1024)
    _, p1 = welch(filtered - filtered.mean(), fs=30000.0, nperseg=1024)
    gain = p1 / p0
    at_corner = float(np.interp(3000.0, freq, gain))
    passband = gain[(freq > 100.0) & (freq < 2900.0)]
    if kind == "chebyshev":
        top = 2.0 if order % 2 == 0 else 1.0  # an even order starts at a trough, an odd one at a peak
        assert np.max(passband) == pytest.approx(top, rel=0.12)
        assert np.min(passband) == pytest.approx(top / 2.0, rel=0.12)
        assert at_corner == pytest.approx(top / 2.0, rel=0.12)
    else:
        assert at_corner == pytest.approx(0.5, rel=0.12)
        assert np.max(passband) < 1.1


def test_resonant_noise_has_its_level_and_its_band_and_leaves_other_draws_alone():
    """The narrow-band pick-up: its standard deviation as set, its power where its mode is (Welch, the peak
    within the mode's band), and a rig without it records exactly what it did before the key existed."""
    from scipy.signal import welch

    from pencli import api

    def pre_trigger(**extra):
        rig = {"kind": "rig", "name": "rn", "seed": 9, "force_noise_n": 0.2, **extra}
        columns = api.acquire(springs=2, penetrator="al6061_1mm", material="mpacs_c", rig=rig).run.columns
        return columns["fz_n"][columns["time_s"] < -0.01]

    plain = pre_trigger()
    hum = pre_trigger(resonant_noise_n=3.0, resonant_noise_hz=700.0, resonant_noise_damping=0.02)
    assert np.std(hum - plain) == pytest.approx(3.0, rel=0.15)  # 0.2 s of a narrow band: ~20 cycles of its width
    freq, power = welch(hum - plain, fs=30000.0, nperseg=4096)
    assert abs(freq[np.argmax(power)] - 700.0) < 2 * 0.02 * 700.0 + 30000.0 / 4096
    assert np.array_equal(pre_trigger(resonant_noise_n=0.0, resonant_noise_hz=900.0), plain)


def test_pink_noise_has_its_level_and_a_power_falling_as_one_over_f_and_leaves_other_draws_alone():
    """The flicker noise: its standard deviation as set (within 10 %: it is set over the whole recording, the run
    keeps 0.46 s of it, and flicker noise keeps its power at the lowest frequencies), a Welch spectrum whose log-log
    slope is -1 from 20 Hz to 5 kHz (a least-squares line through the bins), and a rig without it records what it
    did before the key."""
    from scipy.signal import welch

    from pencli import api

    def pre_trigger(**extra):
        rig = {"kind": "rig", "name": "pn", "seed": 9, "force_noise_n": 0.2, **extra}
        columns = api.acquire(springs=2, penetrator="al6061_1mm", material="mpacs_c", rig=rig).run.columns
        return columns["fz_n"]

    plain = pre_trigger()
    flicker = pre_trigger(pink_noise_n=3.0) - plain
    assert np.std(flicker) == pytest.approx(3.0, rel=0.1)
    freq, power = welch(flicker, fs=30000.0, nperseg=8192)
    band = (freq >= 20.0) & (freq <= 5000.0)
    slope = np.polyfit(np.log(freq[band]), np.log(power[band]), 1)[0]
    assert slope == pytest.approx(-1.0, abs=0.08)
    assert np.array_equal(pre_trigger(pink_noise_n=0.0), plain)


def test_a_quadrature_encoder_counts_the_edges_where_they_truly_lie():
    """The quadrature count against a count of its edges by brute force (every edge k at k + 1/2 + error of
    k mod 4, counted at or below the position, minus one), on 2,000 positions over 40 counts, with the edge errors
    of a worn encoder and with none (then the position rounded); and a rig with the errors records other counts,
    never more than a count off, while the default records what it did."""
    from pencli import api
    from pencli.acquire.sim import quadrature_counts

    rng = np.random.default_rng(2)
    position = rng.uniform(-20.0, 20.0, 2000)
    for errors in ([0.2, -0.15, 0.05, -0.3], [0.0, 0.0, 0.0, 0.0]):
        ks = np.arange(-30, 30)
        edges = ks + 0.5 + np.array(errors)[ks % 4]
        brute = np.array([ks[edges <= x].max() + 1 if np.any(edges <= x) else -30 for x in position])
        assert np.array_equal(quadrature_counts(position, errors), brute)
    assert np.array_equal(quadrature_counts(position, [0.0] * 4), np.round(position).astype(np.int64))

    def counts(**extra):
        rig = {"kind": "rig", "name": "q", "seed": 3, **extra}
        run = api.acquire(springs=4, penetrator="al6061_1.5mm", material="mpacs_c", rig=rig).run
        return run.columns["position_mm"]

    plain, worn = counts(), counts(encoder_edge_errors=[0.3, -0.3, 0.3, -0.3])
    n = min(plain.size, worn.size)  # the recording ends where its motion is seen to stop
    plain, worn = plain[:n], worn[:n]
    assert not np.array_equal(plain, worn)
    assert np.max(np.abs(plain - worn)) <= np.max(np.diff(np.unique(plain))) * 1.0001  # never more than a count
    assert np.array_equal(counts(encoder_edge_errors=[0.0, 0.0, 0.0, 0.0])[:n], plain)


@pytest.mark.parametrize("content,words", [
    ({"kind": "rig", "name": "x", "sampling_rate": 3}, "unknown key 'sampling_rate'"),
    ({"kind": "rig", "name": "x", "resonant_noise_hz": 20000.0}, "resonant_noise_hz"),
    ({"kind": "rig", "name": "x", "resonant_noise_damping": 1.5}, "resonant_noise_damping"),
    ({"kind": "rig", "name": "x", "effects": [{"name": "gremlins"}]}, "unknown effect 'gremlins'"),
    ({"kind": "rig", "name": "x", "effects": [{"name": "strength_layer", "depht_mm": 3}]}, "depht_mm"),
    ({"kind": "rig", "name": "x", "effects": [{"name": "strength_gradient", "shape": 3, "kink_mm": -5}]},
     "kink_mm = -5"),
    ({"kind": "rig", "name": "x", "driver": "labview"}, "driver"),
    ({"kind": "rig", "name": "x", "encoder_phase": 1.0}, "encoder_phase"),
    ({"kind": "rig", "name": "x", "anti_alias_hz": 15000.0}, "anti_alias_hz"),
    ({"kind": "rig", "name": "x", "converter_noise_n": -0.1}, "converter_noise_n"),
    ({"kind": "rig", "name": "x", "anti_alias_kind": "elliptic"}, "anti_alias_kind"),
    ({"kind": "rig", "name": "x", "anti_alias_order": 2.5}, "anti_alias_order"),
    ({"kind": "rig", "name": "x", "anti_alias_ripple_db": 0}, "anti_alias_ripple_db"),
    ({"kind": "rig", "name": "x", "pink_noise_n": -1}, "pink_noise_n"),
    ({"kind": "rig", "name": "x", "encoder_edge_errors": [0.1, 0.6, 0, 0]}, "encoder_edge_errors"),
    ({"kind": "rig", "name": "x", "encoder_edge_errors": [0.1, 0.2]}, "encoder_edge_errors"),
])
def test_bad_rig_file_is_one_line(workspace, runner, content, words):
    rig = workspace / "rig.yaml"
    rig.write_text(yaml.safe_dump(content))
    r = invoke(runner, "acquire", "--springs", "2", "--yes", "--save", "--rig", rig)
    assert r.exit_code == 1 and words in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_bad_calibration_file_is_one_line(workspace, runner):
    cal = workspace / "bad.cal"
    cal.write_text('<FTSensor><Calibration><Axis Name="Fx" values="1 2 3"/></Calibration></FTSensor>')
    r = invoke(runner, "acquire", "--springs", "2", "--yes", "--save", "--force-cal", cal)
    assert r.exit_code == 1 and "Fy" in r.stderr


def test_calibration_files_read_ati_xml_and_yaml(tmp_path):
    ati = load_force_calibration()
    assert ati.matrix.shape == (6, 6) and ati.matrix[2, 2] == 1800.0
    (tmp_path / "m.yaml").write_text(yaml.safe_dump({"matrix": np.eye(6).tolist()}))
    assert np.array_equal(load_force_calibration(tmp_path / "m.yaml").matrix, np.eye(6))
    assert load_position_calibration().counts_per_mm == 6.25


def test_nidaq_driver_uses_the_daqmx_api_and_its_data_becomes_a_run(workspace, runner, monkeypatch):
    rate, total, pre = 30000.0, 60000, 6000
    cal = load_force_calibration()
    rng = np.random.default_rng(0)
    forces = np.zeros((total, 6))
    forces[:, 2] = -4.0 + rng.normal(0, 1.0, total)
    forces[pre + 3000:pre + 3600, 2] += 800.0  # a penetration
    volts = forces @ np.linalg.inv(cal.matrix).T
    counts = np.zeros(total + 500)  # the counter task started earlier: its buffer holds more
    travel = np.clip((np.arange(total) - pre) / 3600.0, 0, 1) * 250.0 * 6.25
    counts[500:] = np.round(travel)
    fake_nidaqmx.install(monkeypatch, counts, volts, volts[:3000])
    rig = workspace / "rig.yaml"
    rig.write_text(yaml.safe_dump({"kind": "rig", "name": "lab", "driver": "nidaq", "device": "Dev2",
                                   "gauge_channels": "Dev2/ai0:5", "encoder_counter": "Dev2/ctr1",
                                   "trigger_source": "/Dev2/PFI3", "fire_line": "Dev2/port0/line7"}))
    r = invoke(runner, "acquire", "--springs", "4", "--rig", rig, "--yes", "--save", "--id", "real1")
    assert r.exit_code == 0, r.output
    calls = {(task, what): (args, kwargs) for task, what, args, kwargs in fake_nidaqmx.CALLS}
    args, kwargs = calls[("pen_gauges", "triggers.reference_trigger.cfg_dig_edge_ref_trig")]
    assert args == ("/Dev2/PFI3",) and kwargs["pretrigger_samples"] == pre
    args, kwargs = calls[("pen_gauges", "timing.cfg_samp_clk_timing")]
    assert args == (rate,) and kwargs["samps_per_chan"] == total
    args, kwargs = calls[("pen_encoder", "ci_channels.add_ci_lin_encoder_chan")]
    assert args == ("Dev2/ctr1",) and kwargs["units"].name == "TICKS"
    assert calls[("pen_encoder", "timing.cfg_samp_clk_timing")][1]["source"] == "/Dev2/ai/SampleClock"
    writes = [a[0] for task, what, a, _ in fake_nidaqmx.CALLS if task == "pen_fire" and what == "write"]
    assert writes[0] is False and True in writes and writes[-1] is False  # latch released, then made safe
    assert ("pen_gauges", "close") in {(t, w) for t, w, _, _ in fake_nidaqmx.CALLS}
    cols = _raw(workspace, "real1")
    assert cols["time_s"][0] == pytest.approx(-0.2)
    assert cols["position_mm"].max() == pytest.approx(250.0, abs=0.16)
    assert cols["fz_n"].max() > 700


def test_nidaq_without_the_package_says_how_to_install(workspace, runner, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "nidaqmx", None)
    r = invoke(runner, "acquire", "--springs", "4", "--driver", "nidaq", "--yes", "--save")
    assert r.exit_code == 1 and "pen[daq]" in r.stderr


def test_a_shot_that_cannot_be_saved_is_not_fired(workspace, runner, monkeypatch):
    """On a read-only workspace the shot was recorded, then lost.  Now nothing fires."""
    import os
    import stat

    import pencli.acquire.sim as sim

    made = invoke(runner, "acquire", "--springs", "2", "--yes", "--save", "--id", "first")  # makes the workspace
    assert made.exit_code == 0, made.output
    fired = []
    monkeypatch.setattr(sim.SimRig, "fire", lambda self: fired.append(1))
    os.chmod(workspace / "runs.duckdb", stat.S_IRUSR)
    try:
        if os.access(workspace / "runs.duckdb", os.W_OK):
            pytest.skip("running as a user whom file permissions do not stop")
        r = invoke(runner, "acquire", "--springs", "2", "--yes", "--save")
    finally:
        os.chmod(workspace / "runs.duckdb", stat.S_IRUSR | stat.S_IWUSR)
    assert r.exit_code == 1 and "not writable" in r.output and "before firing" in r.output
    assert fired == []


def test_a_taken_run_id_is_refused_before_firing(workspace, runner, monkeypatch):
    r = invoke(runner, "acquire", "--springs", "2", "--yes", "--save", "--id", "dup")
    assert r.exit_code == 0, r.output
    import pencli.acquire.sim as sim

    fired = []
    monkeypatch.setattr(sim.SimRig, "fire", lambda self: fired.append(1))
    r = invoke(runner, "acquire", "--springs", "2", "--yes", "--save", "--id", "dup")
    assert r.exit_code == 1 and "'dup' is taken" in r.output and fired == []


def test_without_a_terminal_a_recorded_shot_is_kept_not_dropped_at_a_prompt(workspace, runner):
    """With --yes --json and no terminal, the shot was fired and then discarded at the
    save prompt."""
    r = invoke(runner, "acquire", "--springs", "2", "--yes", "--json")
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    assert out["saved"] is True and out["id"]
    assert [row["run_id"] for row in api.list_runs(workspace / "runs.duckdb")] == [out["id"]]


def test_a_shot_whose_save_fails_after_firing_is_written_somewhere_and_said_where(workspace, runner, monkeypatch,
                                                                                 tmp_path_factory):
    import tempfile

    from pencli.errors import StoreError

    rescue = tmp_path_factory.mktemp("rescue")
    monkeypatch.setattr(tempfile, "tempdir", str(rescue))

    def full_disk(*args, **kwargs):
        raise StoreError("runs.duckdb: no space left on device")

    monkeypatch.setattr(api, "add_run", full_disk)
    r = invoke(runner, "acquire", "--springs", "2", "--yes", "--save", "--id", "lost")
    assert r.exit_code == 1
    assert "no space left" in r.output and "kept as a run folder" in r.output
    kept = list(rescue.glob("pen-unsaved-lost-*"))
    assert len(kept) == 1 and str(kept[0]) in r.output.replace("\n", "")
    outcome = api.ingest([kept[0]], workspace / "other.duckdb")  # the rescued shot ingests as it was
    assert outcome
    assert [row["run_id"] for row in api.list_runs(workspace / "other.duckdb")] == ["lost"]


def test_a_workspace_in_a_missing_folder_is_refused_before_firing(workspace, runner, monkeypatch):
    import pencli.acquire.sim as sim

    fired = []
    monkeypatch.setattr(sim.SimRig, "fire", lambda self: fired.append(1))
    r = invoke(runner, "acquire", "--springs", "2", "--yes", "--save", "--db", workspace / "nowhere" / "runs.duckdb")
    assert r.exit_code == 1 and "does not exist" in r.output and "before firing" in r.output
    assert fired == [] and not (workspace / "nowhere").exists()


def test_the_bundled_example_catalog_holds_no_machine_paths():
    """The example catalog stored absolute build paths (a temporary rig file, the install's data
    folder).  Bundled files are named bundled:<name>, an in-memory rig is 'inline'."""
    import json as _json
    import re

    import duckdb

    from tests.conftest import REPO

    con = duckdb.connect(str(REPO / "examples" / "workspace" / "runs.duckdb"), read_only=True)
    try:
        texts = [str(v) for table in ("runs", "run_parameters", "stages", "materials", "sweeps")
                 for row in con.execute(f"SELECT * FROM {table}").fetchall() for v in row]
        info = [_json.loads(r[0]) for r in con.execute("SELECT info FROM runs").fetchall()]
    finally:
        con.close()
    absolute = [t for t in texts if re.search(r"(^|[\"' ])/(tmp|home|root|work|usr|opt)/", t)]
    assert absolute == []
    assert {i["position_calibration"] for i in info} == {"bundled:encoder_default.yaml"}
    assert {i["force_calibration"] for i in info} == {"bundled:ft_default.cal"}


def test_acquire_accepts_an_out_of_range_material_when_asked(workspace, runner):
    """The validation error tells the user to pass --allow-out-of-range; pen acquire had no such option."""
    import yaml

    from pencli.params.load import load_preset

    material = load_preset("mpacs_c", "material").to_mapping()
    material["density_kg_m3"] = 5000.0  # documented range [1, 3000] kg/m³
    path = workspace / "dense.yaml"
    path.write_text(yaml.safe_dump(material))
    before = snapshot(workspace)
    refused = invoke(runner, "acquire", "--springs", "4", "-m", str(path), "--yes", "--save")
    assert refused.exit_code == 1 and "--allow-out-of-range" in refused.stderr
    assert snapshot(workspace) == before
    accepted = invoke(runner, "acquire", "--springs", "4", "-m", str(path), "--yes", "--save", "--id", "dense",
                      "--allow-out-of-range", "--json")
    assert accepted.exit_code == 0, accepted.output
    assert api.run_detail(workspace / "runs.duckdb", "dense").parameters["material"]["density_kg_m3"] == 5000.0
