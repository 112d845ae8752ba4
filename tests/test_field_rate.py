"""The rate effect across soundings: on a law of known K, and on the NTNU piezocone study's 64 raw soundings against
what its authors published (their per-unit ratios, fitted here by hand)."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from pencli.errors import FitError
from pencli.fit.rate_effect import UnitMean, fit_rate_effect, unit_means, warp_depths
from pencli.sensors.cone_tip import qt_kpa
from pencli.io.sgf import read_sgf
from tests.conftest import REPO

FIELD = REPO / "examples" / "field" / "ntnu-cptu-rate"


@pytest.mark.parametrize("K", [0.12, -0.15, 0.0])
def test_a_rate_effect_of_either_sign_is_recovered_within_its_error(K):
    """Eight units, twenty soundings at rates log-uniform over 5-65 mm/s, each unit mean scattered by 3 % (a block's
    spatial variability): K within 3 standard errors, and the error near the law's own, σ/√Σ(L − L̄)²."""
    rng = np.random.default_rng(int(1000 * abs(K)) + 5)
    q = rng.uniform(200.0, 9000.0, 8)
    rates = 10 ** rng.uniform(np.log10(5), np.log10(65), 20)
    samples = [UnitMean(u, v, float(q[u] * (1 + K * np.log10(v / 20)) * (1 + 0.03 * rng.normal())), 30)
               for v in rates for u in range(8)]
    fit = fit_rate_effect(samples)
    L = np.log10(rates / 20)
    expected_se = 0.03 / np.sqrt(8 * np.sum((L - L.mean()) ** 2))
    assert abs(fit.per_decade - K) < 3 * fit.per_decade_se
    assert fit.per_decade_se == pytest.approx(expected_se, rel=0.3)
    for u in range(8):
        assert fit.reference_values[u] == pytest.approx(q[u], rel=0.03)


def test_a_rate_effect_needs_spread_rates_and_enough_soundings():
    same = [UnitMean(u, 20.0 + 0.1 * k, 100.0 + u + k, 30) for u in range(3) for k in range(5)]
    with pytest.raises(FitError, match="decades"):
        fit_rate_effect(same)
    with pytest.raises(FitError, match="unknowns"):
        fit_rate_effect([UnitMean(0, 5.0, 1.0, 30), UnitMean(1, 50.0, 2.0, 30)])


def test_depths_are_warped_by_the_interpolated_shift_held_beyond_the_ends():
    pairs = [[5.0, 5.5], [10.0, 10.0]]  # 5.5 m at the reference is 5 m here; 10 m is 10 m
    got = warp_depths(np.array([4.0, 5.0, 7.5, 10.0, 12.0]), pairs)
    np.testing.assert_allclose(got, [4.5, 5.5, 7.75, 10.0, 12.0])
    np.testing.assert_array_equal(warp_depths(np.array([1.0, 2.0]), []), [1.0, 2.0])
    assert qt_kpa(np.array([1.0]), np.array([100.0]), 0.8)[0] == pytest.approx(1020.0)


def _authors_per_decade(rows: list[dict]) -> tuple[float, float]:
    """K and its standard error of k − 1 = K·log10(v/20) fitted through the origin to the authors' ratios qt_k at
    their rates (ordinary least squares, written here)."""
    k = np.array([float(r["qt_k"]) for r in rows])
    L = np.log10(np.array([float(r["rate_avg"]) for r in rows]) / 20.0)
    K = float(L @ (k - 1.0) / (L @ L))
    residual = k - 1.0 - K * L
    return K, float(np.sqrt(residual @ residual / (len(k) - 1) / (L @ L)))


@pytest.fixture(scope="module")
def sites():
    """Per site: pen's fit from the raw soundings, the authors' K and error, the authors' qt at 20 mm/s per unit."""
    units = json.loads((FIELD / "units.json").read_text(encoding="utf-8"))["sites"]
    with (FIELD / "authors_results.csv").open(encoding="utf-8") as file:
        rows = list(csv.DictReader(file))
    out = {}
    for index, (site, definition) in enumerate(units.items()):
        samples = []
        for sounding in definition["soundings"].values():
            (record,) = read_sgf(FIELD / sounding["file"])
            qt = qt_kpa(record.columns["qc_mpa"], record.columns["u2_kpa"], record.header_number("MA"))
            samples += unit_means(record.columns["depth_m"], record.time_s, qt, definition["units_m"],
                                  sounding["warp_m"], sounding["drop_m"])
        theirs = [r for r in rows if r["unit"].startswith(f"{index}-")]
        reference = {int(r["unit"].split("-")[1]): float(r["qt_value_ref"]) for r in theirs}
        out[site] = (fit_rate_effect(samples), *_authors_per_decade(theirs), reference)
    return out


@pytest.mark.parametrize("site, sign", [("Tiller-Flotten", 1), ("Øysand", -1)])
def test_the_rate_effect_from_raw_soundings_is_the_authors_where_they_found_one(sites, site, sign):
    """Faster is stronger in the clay (undrained, viscous), weaker in the silty sand (drainage from partial to
    undrained): pen's K has the published sign, clear of zero, and lies within the two standard errors of the K
    fitted to the authors' ratios (measured: +0.100 ± 0.003 against +0.107 ± 0.004; −0.158 ± 0.027 against
    −0.145 ± 0.022)."""
    fit, K, se, _ = sites[site]
    assert np.sign(fit.per_decade) == np.sign(K) == sign
    assert abs(fit.t) > 3
    assert abs(fit.per_decade - K) <= fit.per_decade_se + se, (fit.per_decade, fit.per_decade_se, K, se)


def test_no_rate_effect_beyond_the_noise_at_halsen(sites):
    """Halsen: neither pen (+0.009 ± 0.038) nor the authors' ratios (+0.026 ± 0.032) find one."""
    fit, K, se, _ = sites["Halsen"]
    assert abs(fit.t) < 2 and abs(K) < 2 * se
    assert abs(fit.per_decade - K) <= fit.per_decade_se + se


@pytest.mark.parametrize("site", ["Tiller-Flotten", "Øysand", "Halsen"])
def test_each_units_qt_at_the_reference_rate_is_the_authors(sites, site):
    """pen's q_u against the authors' reference-rate qt (theirs a LOWESS through the unit's values at 20 mm/s):
    median relative difference under 3 % (measured 0.8 %, 1.6 %, 1.1 %), none over 8 %."""
    fit, _, _, theirs = sites[site]
    relative = np.array([fit.reference_values[u] / theirs[u] - 1.0 for u in fit.reference_values])
    assert len(relative) == len(theirs)
    assert np.median(np.abs(relative)) < 0.03 and np.max(np.abs(relative)) < 0.08, relative
