"""SnowMicroPen profiles: the ``.pnt`` reader on the committed SnowEx 2020 profiles (licence beside them) and on
broken copies; the shot-noise estimates against simulated snow of known elements (:mod:`pencli.acquire.snow`, which
shares no code with the estimator), through the file format and the command."""

from __future__ import annotations

import gzip
import hashlib
import json
import math
import re

import numpy as np
import pytest

from pencli import api
from pencli.acquire.snow import SnowLayer, header, measured_force, true_force
from pencli.errors import DataError
from pencli.fit.shot_noise import frontal_area_mm2
from pencli.io.pnt import pnt_bytes, read_pnt
from tests.conftest import REPO, invoke

FIELD = REPO / "examples" / "field" / "snowex-smp"
SNOW_DEPTH_MM = 740.0
"""Snow depth at pit 2S7 in the field notes the attribution README quotes (74 cm). [mm]"""

MEDIAN_SE = math.sqrt(math.pi / 2)
"""The standard error of a median of normal values over that of their mean."""


def listed() -> dict[str, str]:
    """profile file (uncompressed name) → sha256, from the attribution README's table."""
    return dict(re.findall(r"^\| (\S+\.pnt) \| ([0-9a-f]{64}) \|$", (FIELD / "README.md").read_text(), re.MULTILINE))


def test_the_committed_profiles_are_the_ones_listed_with_their_licence():
    files = listed()
    assert len(files) == 3 and sorted(f"{n}.gz" for n in files) == sorted(p.name for p in FIELD.glob("*.pnt.gz"))
    for name, digest in files.items():  # the sha256 content digest of each file as published
        assert hashlib.sha256(gzip.decompress((FIELD / f"{name}.gz").read_bytes())).hexdigest() == digest, name
    assert "BSD 3-Clause License" in (FIELD / "LICENSE").read_text()


def test_a_real_profile_reads_as_the_instrument_wrote_it():
    """The header's facts of a SnowEx 2020 SMP (a 5 mm cone at 20 mm/s, a 40 N sensor, 4.13 µm steps), every
    sample, and the snow depth: from the surface found in the force to the profile's end, the pit's 74 cm."""
    for path in sorted(FIELD.glob("*.pnt.gz")):
        profile = read_pnt(path)
        assert profile.name == path.name.split("_")[2]  # S19M1255: the file name's own
        assert (profile.tip_diameter_mm, profile.speed_mm_s, profile.overload_n) == (5.0, 20.0, 40.0)
        assert profile.step_mm == pytest.approx(0.004132, abs=1e-6)
        raw = gzip.decompress(path.read_bytes())
        assert profile.force_n.size == int.from_bytes(raw[358:362], "big")
        counts = np.frombuffer(raw, ">i2", count=profile.force_n.size, offset=512)
        assert np.array_equal(profile.force_n, counts * profile.header["force_per_count_n"])
        result = api.estimate_snow_profile(path)
        assert abs(result.bottom_mm - result.surface_mm - SNOW_DEPTH_MM) < 30, (path.name, result.surface_mm)
    clipped = api.estimate_snow_profile(FIELD / "SNEX20_SMP_S19M1257_2S7_20200208.pnt.gz")
    assert clipped.estimates.clipped[-3:].any() and not clipped.estimates.clipped[:-20].any()  # the ground, at 40 N


def test_larger_elements_where_the_pit_wall_has_coarser_grains():
    """The element size L against the specific surface area measured on the same pit wall with another instrument
    (IS3, every 5 cm): coarser grains (lower SSA) should break as larger elements, so the ranks run opposite.  Each
    profile's L, median over ±25 mm of each SSA height (the height above ground taken from the profile's own snow
    depth), is ranked against the SSA: negative at the 1 % level (one-sided Spearman), each profile alone."""
    from scipy.stats import spearmanr

    ssa = np.genfromtxt(FIELD / "ssa_2S7.csv", delimiter=",", names=True, usecols=(0, 1))
    for path in sorted(FIELD.glob("*.pnt.gz")):
        result = api.estimate_snow_profile(path)
        est, snow = result.estimates, result.bottom_mm - result.surface_mm
        sizes, areas = [], []
        for height_cm, area in zip(ssa["height_cm"], ssa["ssa_m2_kg"]):
            near = (np.abs(est.depth_mm - (snow - 10 * height_cm)) < 25) & ~est.clipped
            if near.sum() > 3:
                sizes.append(np.median(est.element_size_mm[near]))
                areas.append(area)
        rho = spearmanr(sizes, areas, alternative="less")
        assert len(sizes) >= 12 and rho.statistic < 0 and rho.pvalue < 0.01, (path.name, rho)


def simulated(tmp_path, layers, air_mm=40.0, seed=0, noise_n=0.0):
    """A simulated profile written as ``.pnt``: (path, surface [mm])."""
    rng = np.random.default_rng(seed)
    length = air_mm + sum(layer.thickness_mm for layer in layers)
    _, force = true_force(layers, air_mm, length, rng)
    path = tmp_path / f"sim{seed}.pnt"
    path.write_bytes(pnt_bytes(header(f"SIM{seed:05d}", length), measured_force(force, rng, noise_n=noise_n)))
    return path, air_mm


@pytest.mark.parametrize("seed", range(4))
def test_shot_noise_of_known_elements_is_recovered(tmp_path, seed):
    """Random elements (λ 5–50 mm⁻¹, f₀ 0.05–2 N, δ 0.05–0.5 mm) in 3 m of snow, read through the file and
    estimated in 50 mm windows: the windows' medians of λ, f₀ and δ within 3.5 standard errors of their own scatter
    of the truth (the median of the nonlinear estimates sits about 0.7 of one above or below it), the mean force
    λ f₀ δ / 2 within 3.5 of the mean's (Campbell's theorem), and the strength term that force over the cone's
    area."""
    rng = np.random.default_rng(1000 + seed)
    truth = SnowLayer(3000.0, rng.uniform(5, 50), float(np.exp(rng.uniform(np.log(0.05), np.log(2)))),
                      rng.uniform(0.05, 0.5))
    path, _ = simulated(tmp_path, [truth], seed=seed)
    est = api.estimate_snow_profile(path, window_mm=50.0, overlap=0.0).estimates
    for values, true in ((est.intensity_per_mm, truth.intensity_per_mm), (est.rupture_force_n, truth.rupture_force_n),
                         (est.deflection_mm, truth.deflection_mm)):
        se = MEDIAN_SE * np.std(values) / np.sqrt(values.size)
        assert abs(np.median(values) - true) < 3.5 * se, (np.median(values), true, se)
    mean_se = np.std(est.mean_force_n) / np.sqrt(est.mean_force_n.size)
    assert abs(np.mean(est.mean_force_n) - truth.mean_force_n) < 3.5 * mean_se
    assert np.allclose(est.strength_kpa, est.mean_force_n / frontal_area_mm2(5.0) * 1e3)


def test_the_surface_and_layers_of_simulated_snow_are_found(tmp_path):
    """Air, then a soft layer over a hard one: the surface within a millimetre of the truth, and each layer's
    medians (windows of 10 mm, the layers' edges left out) on the right side of the other's, the strength term
    within 10 % of λ f₀ δ / 2 over the cone's area."""
    soft, hard = SnowLayer(300.0, 8.0, 0.1, 0.3), SnowLayer(300.0, 40.0, 1.0, 0.1)
    path, surface = simulated(tmp_path, [soft, hard], seed=7, noise_n=0.003)
    result = api.estimate_snow_profile(path, window_mm=10.0, layers=[(20, 280), (320, 580)])
    assert abs(result.surface_mm - surface) <= 1.0
    top, bottom = result.layers
    assert top.intensity_per_mm < bottom.intensity_per_mm and top.rupture_force_n < bottom.rupture_force_n
    assert top.deflection_mm > bottom.deflection_mm and top.element_size_mm > bottom.element_size_mm
    for layer, truth in ((top, soft), (bottom, hard)):
        assert layer.strength_kpa == pytest.approx(truth.mean_force_n / frontal_area_mm2(5.0) * 1e3, rel=0.1)


def test_a_file_written_is_read_back_to_the_count():
    force = np.array([0.0, 0.5, 1.27, 39.9, 55.0, -0.3])
    head = header("ROUND", 1.0)
    profile_bytes = pnt_bytes(head, force)
    assert len(profile_bytes) == 512 + 2 * force.size
    counts = np.frombuffer(profile_bytes, ">i2", offset=512)
    assert np.array_equal(counts, np.clip(np.rint(force / head["force_per_count_n"]), -32768, 32767))


@pytest.mark.parametrize("case", ["empty", "short header", "samples missing", "zero factor", "not gzip"])
def test_a_broken_copy_is_one_line_naming_the_file(tmp_path, case):
    real = gzip.decompress((FIELD / "SNEX20_SMP_S19M1255_2S7_20200208.pnt.gz").read_bytes())
    name, data, expected = {
        "empty": ("a.pnt", b"", "shorter than a SnowMicroPen header"),
        "short header": ("a.pnt", real[:300], "shorter than a SnowMicroPen header"),
        "samples missing": ("a.pnt", real[:100_000], "force samples (byte 358) but the file holds 49744"),
        "zero factor": ("a.pnt", real[:10] + bytes(4) + real[14:], "force_per_count_n = 0.0"),
        "not gzip": ("a.pnt.gz", real, "cannot read it as a SnowMicroPen file"),
    }[case]
    path = tmp_path / name
    path.write_bytes(data)
    with pytest.raises(DataError) as error:
        read_pnt(path)
    message = str(error.value)
    assert message.startswith(str(path)) and expected in message and "\n" not in message
    assert [p.name for p in tmp_path.iterdir()] == [name]


def test_the_commands_on_the_bundled_profiles(runner, tmp_path):
    shown = invoke(runner, "snow", "show", *sorted(FIELD.glob("*.pnt.gz")), "--json")
    assert shown.exit_code == 0, shown.output
    rows = json.loads(shown.stdout)
    assert [r["name"] for r in rows] == ["S19M1255", "S19M1256", "S19M1257"]
    assert [r["at_range"] > 0 for r in rows] == [False, False, True]
    out, plot = tmp_path / "windows.csv", tmp_path / "profile.png"
    done = invoke(runner, "snow", "estimate", FIELD / "SNEX20_SMP_S19M1256_2S7_20200208.pnt.gz", "--layer", "0:150",
                  "--layer", "150:500", "--out", out, "--plot", plot, "--json")
    assert done.exit_code == 0, done.output
    record = json.loads(done.stdout)
    table = np.genfromtxt(out, delimiter=",", names=True)
    assert table.size == record["windows"] and set(table.dtype.names) >= {"depth_mm", "strength_kpa", "clipped"}
    assert plot.stat().st_size > 10_000 and "kPa" in record["caption"]
    top, middle = record["layers"]
    assert top["strength_kpa"] > middle["strength_kpa"]  # the pit's wind slab at the top
    bad = [(["snow", "estimate", FIELD / "SNEX20_SMP_S19M1256_2S7_20200208.pnt.gz", "--layer", "5"], "TOP:BOTTOM"),
           (["snow", "show", REPO / "README.md"], "SnowMicroPen"),
           (["snow", "estimate", FIELD / "SNEX20_SMP_S19M1256_2S7_20200208.pnt.gz", "--surface-mm", "949.9"],
            "shorter than one window")]
    for args, expected in bad:
        r = invoke(runner, *args)
        assert r.exit_code != 0 and expected in r.stderr and "Traceback" not in r.output, (args, r.output)
        assert len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["profile.png", "windows.csv"]


def test_a_report_of_profiles_gives_each_its_layers_and_figure(tmp_path, runner):
    files = sorted(FIELD.glob("*.pnt.gz"))[:2]
    out = tmp_path / "smp.html"
    result = invoke(runner, "snow", "report", *map(str, files), "--layer", "0:150", "--layer", "150:500",
                    "--out", str(out))
    assert result.exit_code == 0, result.output
    page = out.read_text()
    assert out.with_suffix(".pdf").stat().st_size > 10_000
    assert page.count("<svg") == 2 and page.count("each layer&#x27;s medians") + page.count("each layer's medians") == 2
    for profile in api.read_snow_profiles(files):
        assert f"SnowMicroPen profile {profile.name}" in page
    result = invoke(runner, "snow", "report", str(files[0]), "--layer", "150:50", "--out", str(tmp_path / "b.html"))
    assert result.exit_code == 1 and not (tmp_path / "b.html").exists()
