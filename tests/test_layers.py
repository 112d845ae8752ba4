"""Layers of a sounding (pencli.fit.layers) on soundings of the simulated constant-rate cone
(pencli.acquire.sounding), whose layered ground, thin-layer smoothing and noise the detection never sees; the
hold-out seeds below were not used while the method was made (development used seeds 0–59)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pencli.acquire.sounding import SoilLayer, random_layers, sgf_text, simulate_sounding
from pencli.filter.rate import push_rate_mm_s
from pencli.fit.layers import detect_layers
from pencli.io.sgf import read_sgf
from pencli.testing.soundings import random_sounding, six_rate_site
from tests.conftest import invoke

TOLERANCE_M = 0.15
"""A boundary is found when the cut puts one this close: about four diameters of a 10 cm² cone. [m]"""


def test_the_boundaries_of_random_layered_ground_are_found_and_few_are_invented():
    """On 60 hold-out soundings (all 100 seeds 1000–1099: 266 of 271 boundaries found, 3 of 269 reported
    invented): at least 95 % of the true boundaries within 0.15 m, at most 3 % of those reported invented."""
    found = true = invented = reported = 0
    for seed in range(1000, 1060):
        truth, depth, qt = random_sounding(seed)
        got = detect_layers(depth, qt).boundaries_m
        found += sum(any(abs(g - b) <= TOLERANCE_M for g in got) for b in truth)
        invented += sum(not any(abs(g - b) <= TOLERANCE_M for b in truth) for g in got)
        true, reported = true + len(truth), reported + len(got)
    assert true > 150
    assert found >= 0.95 * true, (found, true)
    assert invented <= 0.03 * reported, (invented, reported)


def test_one_layer_with_a_gradient_is_one_layer():
    """Hold-out nulls (seeds 1000–1099 measured 0 of 100 cut): a single layer whose resistance grows with depth,
    at any noise, is at most rarely cut (here at most 1 of 40)."""
    cut = [len(detect_layers(*random_sounding(seed, layered=False)[1:]).layers) > 1 for seed in range(1000, 1040)]
    assert sum(cut) <= 1


def test_a_noiseless_profile_of_straight_lines_is_cut_where_they_meet():
    """Three lines with steps between them, no noise, no smoothing: the boundaries to the row, and each
    layer's line exactly."""
    depth = np.round(np.arange(1.0, 9.0, 0.02), 6)
    q = np.where(depth < 3.0, 2.0 + 0.5 * (depth - 1.0), np.where(depth < 6.0, 12.0, 4.0 + 0.2 * (depth - 6.0)))
    q = q * (1.0 + 1e-4 * np.sin(37.0 * depth))  # a trace of scatter, so the penalty is not zero
    cut = detect_layers(depth, q)
    assert cut.boundaries_m == pytest.approx([2.99, 5.99], abs=0.011)
    assert [round(layer.gradient_per_m, 3) for layer in cut.layers] == [0.5, 0.0, 0.2]


def test_the_simulated_sounding_reads_back_as_sgf_with_its_rate(tmp_path):
    rng = np.random.default_rng(5)
    sounding = simulate_sounding(random_layers(rng, 1.0, 8.0), 8.0, rng, rate_mm_s=40.0)
    path = tmp_path / "s.cpt"
    path.write_text(sgf_text("S5", sounding))
    (read,) = read_sgf(path)
    assert read.kind == "cptu" and read.header_number("MA") == pytest.approx(0.8)
    for column in ("depth_m", "qc_mpa", "fs_kpa", "u2_kpa"):
        np.testing.assert_allclose(read.columns[column], sounding.columns[column], atol=1e-9)
    assert push_rate_mm_s(read.columns["depth_m"], read.time_s) == pytest.approx(40.0, rel=1e-3)


def test_the_layers_command_reads_a_sounding_and_draws_its_layers(tmp_path, runner):
    rng = np.random.default_rng(1003)
    layers = [SoilLayer(1.0, 1.0, 0.05, 0.04, 0.4), SoilLayer(4.2, 9.0, 0.0, 0.01, -0.01),
              SoilLayer(7.6, 2.0, 0.1, 0.04, 0.3)]
    path = tmp_path / "three.cpt"
    path.write_text(sgf_text("three", simulate_sounding(layers, 11.0, rng)))
    result = invoke(runner, "soundings", "layers", str(path), "--json")
    assert result.exit_code == 0, result.output
    (record,) = json.loads(result.stdout)
    tops = [layer["top_m"] for layer in record["layers"][1:]]
    assert record["quantity"] == "qt" and tops == pytest.approx([4.2, 7.6], abs=TOLERANCE_M)
    assert record["unit"] == "MPa" and record["layers"][1]["q_top"] == pytest.approx(9.0, rel=0.1)  # the sand's
    figure = tmp_path / "three.png"
    result = invoke(runner, "soundings", "plot", str(path), "--layers", "--out", str(figure))
    assert result.exit_code == 0 and "3 layers" in result.stdout and figure.stat().st_size > 10_000
    short = tmp_path / "short.cpt"
    short.write_text("$\nHK=x,HM=07\n#\nD=1.00,QC=1.0\nD=1.02,QC=1.1\nD=1.04,QC=1.2\n")
    result = invoke(runner, "soundings", "layers", str(short))
    assert result.exit_code == 1 and "short.cpt" in result.stderr and "at least 8" in result.stderr


@pytest.mark.parametrize("seed, per_decade", [(1001, -0.15), (1002, 0.10), (1004, -0.15)])
def test_a_rate_effect_of_either_sign_is_recovered_from_six_soundings_on_their_own_layers(tmp_path, runner, seed,
                                                                                         per_decade):
    """The rate effect's sign and size from six soundings at 5–65 mm/s, the units found as the reference's
    layers (all six hold-out grounds 1000–1005, both signs: within 1.8 %), and the diagnosis names it."""
    units = str(six_rate_site(tmp_path, seed, per_decade))
    result = invoke(runner, "soundings", "fit", units, "--site", "sim", "--json")
    assert result.exit_code == 0, result.output
    fitted = json.loads(result.stdout)
    assert fitted["per_decade"] == pytest.approx(per_decade, rel=0.05)
    result = invoke(runner, "soundings", "diagnose", units, "--site", "sim", "--json")
    assert result.exit_code == 0, result.output
    verdict = json.loads(result.stdout)
    assert verdict["verdict"] == "rate_effect"
    assert verdict["direction"] == ("faster is stronger" if per_decade > 0 else "faster is weaker"), verdict


def test_six_soundings_without_a_rate_effect_are_none(tmp_path, runner):
    units = str(six_rate_site(tmp_path, 1003, 0.0))
    result = invoke(runner, "soundings", "diagnose", units, "--site", "sim", "--json")
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["verdict"] == "none"


def test_a_report_of_soundings_of_three_formats_gives_each_its_layers_and_profile(tmp_path, runner):
    from tests.conftest import REPO

    field = REPO / "examples" / "field"
    files = [field / "gef" / "cpt.gef", *sorted((field / "ags").glob("*CPT01*.ags.gz")),
             field / "ntnu-cptu-rate" / "soundings" / "TILC57.cpt.gz"]
    out = tmp_path / "soundings.html"
    result = invoke(runner, "soundings", "report", *map(str, files), "--out", str(out))
    assert result.exit_code == 0, result.output
    page = out.read_text()
    assert out.with_suffix(".pdf").stat().st_size > 10_000
    assert page.count("layers of qt") == 3 and page.count("<svg") == 3
    for name in ("CPTU17.8 + 83BITE", "HKZ1-CPT01.000", "sounding 57"):
        assert name in page
    assert "pushed at a nominal 20 mm/s" in page and "mm/s (from its clock)" in page
    result = invoke(runner, "soundings", "report", str(files[0]), "--out", str(tmp_path / "x.txt"))
    assert result.exit_code == 2 and not (tmp_path / "x.txt").exists()
