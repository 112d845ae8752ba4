"""`pen drops` on records the simulated BlueDrop writes (`pen drops simulate`, :mod:`pencli.acquire.freefall`,
which shares no code with the filters and the fit): impact speed and penetration against the simulation's truth,
the bed fitted across drops with the probe's drag and added mass unknown, stored records, the report, and bad
input in one line."""

from __future__ import annotations

import json

import pytest
import yaml

from tests.conftest import invoke

BED = (18.0, 140.0, 6.0)
"""σ [kPa], b [kPa/m], c [kPa·s/m] of the simulated bed."""
HEIGHTS_M = (0.5, 1.2, 2.5, 5.0)


@pytest.fixture(scope="module")
def drops(tmp_path_factory):
    """Four drops from four heights, each sensor chain with its own biases, and the truth of each."""
    from typer.testing import CliRunner

    root = tmp_path_factory.mktemp("drops")
    runner = CliRunner()
    truths = []
    for k, height in enumerate(HEIGHTS_M):
        r = invoke(runner, "drops", "simulate", "--height-m", height, "--bed", ",".join(map(str, BED)),
                   "--bias-g", 0.03, "--seed", 40 + k, "--out", root / f"drop-{k}.bin", "--json")
        assert r.exit_code == 0, r.output + r.stderr
        truths.append(json.loads(r.stdout))
    return root, truths


def test_each_drop_meets_the_bed_and_stops_where_the_simulation_did(runner, drops):
    root, truths = drops
    files = [root / f"drop-{k}.bin" for k in range(len(HEIGHTS_M))]
    r = invoke(runner, "drops", "show", *files, "--calibration", root / "calibration.csv", "--json")
    assert r.exit_code == 0, r.stderr
    shown = json.loads(r.stdout)
    for record, truth in zip(shown, truths):
        assert record["impact_speed_m_s"] == pytest.approx(truth["impact_speed_m_s"], rel=0.01)
        assert record["penetration_mm"] == pytest.approx(truth["penetration_mm"], rel=0.01)
        assert record["impact_s"] == pytest.approx(truth["impact_s"], abs=2e-3)


def test_the_bed_is_fitted_across_stored_drops_with_the_drag_unknown(runner, drops, tmp_path):
    root, _ = drops
    db = tmp_path / "runs.duckdb"
    r = invoke(runner, "ingest", *sorted(root.glob("drop-*.bin")), "--calibration", root / "calibration.csv",
               "--db", db)
    assert r.exit_code == 0, r.stderr
    wrong = yaml.safe_load(invoke(runner, "params", "show", "drop_water", "--kind", "energizing").stdout)
    wrong.update(drag_coefficient=1.2, added_mass_coefficient=0.05, name="guess")
    guess = tmp_path / "guess.yaml"
    guess.write_text(yaml.safe_dump(wrong))
    r = invoke(runner, "drops", "fit", "drop-*", "-p", "freefall_cone", "-e", guess, "--json", "--db", db)
    assert r.exit_code == 0, r.stderr
    fit = json.loads(r.stdout)
    assert fit["drops"] == len(HEIGHTS_M)
    for key, truth in zip(("strength_kpa", "gradient_kpa_m", "damping_kpa_s_m"), BED):
        assert fit[key] == pytest.approx(truth, rel=0.03), key
    assert fit["drag_coefficient"] == pytest.approx(0.8, rel=0.03)  # the simulated probe's (pen's acquire world)
    assert fit["added_mass_coefficient"] == pytest.approx(0.3, rel=0.05)
    held = json.loads(invoke(runner, "drops", "fit", "drop-*", "-p", "freefall_cone", "-e", guess, "--hold-drag",
                             "--json", "--db", db).stdout)
    assert held["drag_coefficient"] is None
    assert abs(held["strength_kpa"] / BED[0] - 1) > abs(fit["strength_kpa"] / BED[0] - 1)  # the wrong drag costs


def test_a_bed_that_buoys_the_probe_is_fitted_with_its_density_from_the_launcher_file(runner, tmp_path):
    """Four drops into a saturated sand (bulk density 1,900 kg/m³) that buoys the cone's volume below its surface:
    with the density in the launcher file (`bed_density_kg_m3`) the bed comes back within 3 % with the drag and
    added mass fitted too; the same file without it reads the buoyancy as the bed's gradient."""
    for k, height in enumerate(HEIGHTS_M):
        r = invoke(runner, "drops", "simulate", "--height-m", height, "--bed", ",".join(map(str, BED)),
                   "--bed-density", 1900, "--bias-g", 0.03, "--seed", 60 + k, "--out", tmp_path / f"drop-{k}.bin")
        assert r.exit_code == 0, r.output + r.stderr
    launcher = yaml.safe_load(invoke(runner, "params", "show", "drop_water", "--kind", "energizing").stdout)
    fits = {}
    for density in (1900.0, 0.0):
        path = tmp_path / f"fall-{density:g}.yaml"
        path.write_text(yaml.safe_dump({**launcher, "name": "sand", "bed_density_kg_m3": density}))
        r = invoke(runner, "drops", "fit", *sorted(tmp_path.glob("drop-*.bin")), "--calibration",
                   tmp_path / "calibration.csv", "-p", "freefall_cone", "-e", path, "--json")
        assert r.exit_code == 0, r.stderr
        fits[density] = json.loads(r.stdout)
    for key, truth in zip(("strength_kpa", "gradient_kpa_m", "damping_kpa_s_m"), BED):
        assert fits[1900.0][key] == pytest.approx(truth, rel=0.03), key
    assert fits[0.0]["gradient_kpa_m"] - BED[1] > 0.5 * (1900 - 1025) * 9.80665 / 1e3  # the buoyancy as gradient


def test_a_report_draws_each_drop_and_the_bed(runner, drops, tmp_path):
    root, _ = drops
    out = tmp_path / "drops.html"
    r = invoke(runner, "drops", "report", *sorted(root.glob("drop-*.bin")), "--calibration",
               root / "calibration.csv", "-p", "freefall_cone", "-e", "drop_water", "--out", out)
    assert r.exit_code == 0, r.stderr
    html = out.read_text()
    assert html.count("<svg") >= len(HEIGHTS_M) and "The bed across the drops" in html
    assert html.count("Over the rest after the stop") == len(HEIGHTS_M)  # each drop's speed at rest, checked
    assert (tmp_path / "drops.pdf").stat().st_size > 0


@pytest.mark.parametrize("args, said", [
    (["show", "{drop}"], ["drop-0.bin", "--calibration"]),
    (["fit", "{drop}", "--calibration", "{cal}", "-p", "al6061_1mm"], ["geometry blade", "cone"]),
    (["fit", "{drop}", "--calibration", "{cal}", "-e", "springs_4"], ["drive springs", "free_fall"]),
    (["simulate", "--out", "{tmp}/x.bin", "--bed", "0,1,1"], ["--bed", "σ > 0"]),
    (["simulate", "--out", "{tmp}/x.bin", "--impact-shift-g", "0.9"], ["--impact-shift-g 0.9", "0.5 g"]),
    (["simulate", "--out", "{tmp}/x.bin", "--rest-tilt-deg", "75"], ["--rest-tilt-deg 75", "60°"]),
    (["simulate", "--out", "{tmp}/x.bin", "--bed-density", "5000"], ["--bed-density 5000", "3000 kg/m³"]),
    (["show", "{tmp}/missing.bin", "--calibration", "{cal}"], ["missing.bin", "no such file"]),
])
def test_bad_input_is_one_line(runner, drops, tmp_path, args, said):
    root, _ = drops
    filled = [a.format(drop=root / "drop-0.bin", cal=root / "calibration.csv", tmp=tmp_path) for a in args]
    r = invoke(runner, "drops", *filled, "--db", tmp_path / "none.duckdb")
    assert r.exit_code == 1 and "Traceback" not in r.output + r.stderr
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and all(w in lines[0] for w in said), (lines, said)
    assert not list(tmp_path.glob("*.bin"))


def test_a_layer_the_drops_cross_is_named_where_it_is_and_a_bed_without_one_is_none(runner, drops, tmp_path):
    root, _ = drops
    depth_m, step_kpa = 0.13, -9.0
    for k, height in enumerate(HEIGHTS_M):
        r = invoke(runner, "drops", "simulate", "--height-m", height, "--bed", ",".join(map(str, BED)), "--layer",
                   f"{depth_m}:{step_kpa}", "--bias-g", 0.03, "--seed", 70 + k, "--out", tmp_path / f"layer-{k}.bin",
                   "--json")
        assert r.exit_code == 0, r.stderr
        assert json.loads(r.stdout)["penetration_mm"] > 1e3 * depth_m + 20  # every drop crosses it
    layered = json.loads(invoke(runner, "drops", "diagnose", *sorted(tmp_path.glob("layer-*.bin")),
                                "--calibration", tmp_path / "calibration.csv", "--json").stdout)
    assert layered["verdict"] == "layer"
    assert layered["layer_depth_m"] == pytest.approx(depth_m, abs=0.01)
    assert layered["layer_step_kpa"] == pytest.approx(step_kpa, rel=0.25)
    assert layered["heldout_rms_layer_kpa"] < 0.5 * layered["heldout_rms_reference_kpa"]
    plain = json.loads(invoke(runner, "drops", "diagnose", *sorted(root.glob("drop-*.bin")), "--calibration",
                              root / "calibration.csv", "--json").stdout)
    assert plain["verdict"] == "none" and plain["layer_depth_m"] is None


def test_a_bias_that_shifts_at_the_impact_is_named_and_a_step_there_closes_it(runner, drops, tmp_path):
    """Each accelerometer's bias shifts by 0.01 g at the impact (the simulated rig's sensor model): the rests before
    the release and after the stop cannot show it, but the speed integrated over the rest after the stop can; the
    drops of the plain bed (same biases at rest, no shift) pass the same check."""
    root, truths = drops
    for k, height in enumerate(HEIGHTS_M):
        r = invoke(runner, "drops", "simulate", "--height-m", height, "--bed", ",".join(map(str, BED)),
                   "--bias-g", 0.03, "--impact-shift-g", 0.01, "--seed", 40 + k, "--out", tmp_path / f"drop-{k}.bin")
        assert r.exit_code == 0, r.stderr
    shifted = json.loads(invoke(runner, "drops", "diagnose", *sorted(tmp_path.glob("drop-*.bin")), "--calibration",
                                tmp_path / "calibration.csv", "--json").stdout)
    check = shifted["accelerometer"]
    assert shifted["verdict"] == "accelerometer_bias" and shifted["bed_verdict"] == "none"
    long_falls = [f"drop-{k}" for k, h in enumerate(HEIGHTS_M) if h >= 2.0]
    assert set(long_falls) <= set(check["biased"])  # a fall of a second or more integrates it well past the noise
    assert set(check["stepped_at_impact"]) == set(check["biased"])
    for name in check["biased"]:
        speeds = check["rest_speed"][name]
        assert speeds["ramp_m_s"] > 0.01  # a bias rising at the impact, ramped over the fall: read too fast
        assert abs(speeds["step_m_s"]) < 0.25 * speeds["ramp_m_s"]
    plain = json.loads(invoke(runner, "drops", "diagnose", *sorted(root.glob("drop-*.bin")), "--calibration",
                              root / "calibration.csv", "--json").stdout)
    assert plain["accelerometer"]["biased"] == [] and plain["verdict"] == "none"
    # read with the step, the penetration is the simulation's again
    shown = json.loads(invoke(runner, "drops", "show", tmp_path / f"drop-{len(HEIGHTS_M) - 1}.bin", "--calibration",
                              tmp_path / "calibration.csv", "--json").stdout)[0]
    assert shown["penetration_mm"] > truths[-1]["penetration_mm"] * 1.005  # the ramp's reading: too deep


def test_a_probe_that_rests_leaning_is_read_through_its_tilt_channels(runner, tmp_path):
    """The probes come to rest leaning 12° (the simulated rig's truth: the axial sensors then read cos θ of
    gravity, the tilt channels sin θ): read as a bias at rest, that lean would drift the speed and the depth; read
    through the tilt channels, each drop stops where the simulation did and the check finds no bias."""
    truths = []
    for k, height in enumerate(HEIGHTS_M):
        r = invoke(runner, "drops", "simulate", "--height-m", height, "--bed", ",".join(map(str, BED)),
                   "--bias-g", 0.03, "--rest-tilt-deg", 12, "--seed", 40 + k, "--out", tmp_path / f"drop-{k}.bin",
                   "--json")
        assert r.exit_code == 0, r.stderr
        truths.append(json.loads(r.stdout))
    files = sorted(tmp_path.glob("drop-*.bin"))
    shown = json.loads(invoke(runner, "drops", "show", *files, "--calibration", tmp_path / "calibration.csv",
                              "--json").stdout)
    for record, truth in zip(shown, truths):
        assert record["penetration_mm"] == pytest.approx(truth["penetration_mm"], rel=0.01)
        assert abs(record["rest_speed_m_s"]) < 0.01
    result = json.loads(invoke(runner, "drops", "diagnose", *files, "--calibration", tmp_path / "calibration.csv",
                               "--json").stdout)
    assert result["verdict"] == "none" and result["accelerometer"]["biased"] == []
