"""`pen soundings`: the diagnosis of a rate effect across soundings on synthetic sites of known truth (sounding-level
scatter, the shape a permutation null must carry), and the commands on the bundled NTNU soundings and broken input."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pencli.diagnose.soundings import diagnose_soundings
from pencli.fit.rate_effect import UnitMean
from tests.conftest import REPO, invoke

UNITS = REPO / "examples" / "field" / "ntnu-cptu-rate" / "units.json"


def synthetic_site(rng, K: float, soundings: int = 12, units: int = 5, sounding_sd: float = 0.06,
                   unit_sd: float = 0.02) -> list[list[UnitMean]]:
    """Unit means of a site made here: q_u·(1 + K·log10(v/20))·(1 + a sounding's offset + a unit's scatter), rates
    log-uniform over 5-65 mm/s; each sounding's offset (spatial variability across the site) is shared by its
    units, which is what makes an ordinary least-squares error optimistic."""
    q = rng.uniform(300.0, 8000.0, units)
    out = []
    for _ in range(soundings):
        v = 10 ** rng.uniform(np.log10(5.0), np.log10(65.0))
        offset = sounding_sd * rng.normal()
        out.append([UnitMean(u, v * (1 + 0.02 * rng.normal()),
                             float(q[u] * (1 + K * np.log10(v / 20)) * (1 + offset + unit_sd * rng.normal())), 30)
                    for u in range(units)])
    return out


def test_sites_without_a_rate_effect_are_none_at_the_stated_rate():
    """Forty sites without a rate effect, diagnosed at a 5 % false-alarm rate on 99 shuffles: at most 6 are called
    (binomial: 2 expected, 7 or more with probability 0.8 %).  On the same sites a test of K against its ordinary
    least-squares error, blind to the soundings' shared offsets, calls far more."""
    rng = np.random.default_rng(11)
    called = naive = 0
    for k in range(40):
        site = synthetic_site(rng, 0.0)
        result = diagnose_soundings(site, permutations=99, false_alarm=0.05, seed=k)
        called += result.verdict == "rate_effect"
        naive += abs(result.effect.t) > 1.96
    assert called <= 6
    assert naive >= 10, naive


def test_a_site_of_few_soundings_is_tested_on_every_ordering_and_says_what_it_cannot_resolve():
    """Five soundings have 120 orderings of their rates: the null is all of them (the p-value a whole number of
    120ths, the same whatever the seed), and the default 0.2 % rate is below the smallest p-value 1/120, so even
    a strong effect is ``none`` with a note saying so; at 5 % it is named."""
    rng = np.random.default_rng(31)
    site = synthetic_site(rng, -0.3, soundings=5, sounding_sd=0.005, unit_sd=0.002)
    strict = diagnose_soundings(site)
    again = diagnose_soundings(site, seed=7)
    assert strict.exact and strict.null_orderings == 119
    assert strict.p_value == again.p_value
    assert round(strict.p_value * 120, 9) == round(strict.p_value * 120)
    assert strict.verdict == "none" and any("cannot resolve" in note for note in strict.notes)
    loose = diagnose_soundings(site, false_alarm=0.05)
    assert loose.verdict == "rate_effect" and loose.direction == "faster is weaker"
    assert loose.p_value == pytest.approx(1 / 120)


@pytest.mark.parametrize("K", [0.12, -0.12])
def test_a_rate_effect_of_either_sign_is_named_with_its_direction(K):
    """Twenty soundings, each offset by 3 % (twice the clay site's held-out scatter): a change of 12 % per decade,
    about 0.13 across the rates, is named in five sites of five, with its direction."""
    rng = np.random.default_rng(21 if K > 0 else 22)
    found = [diagnose_soundings(synthetic_site(rng, K, soundings=20, sounding_sd=0.03), permutations=99,
                                false_alarm=0.05, seed=k) for k in range(5)]
    assert all(r.verdict == "rate_effect" for r in found), [r.p_value for r in found]
    assert all(r.direction == ("faster is stronger" if K > 0 else "faster is weaker") for r in found)
    assert all(abs(r.effect.per_decade - K) < 4 * r.effect.per_decade_se + 0.03 for r in found)


def test_the_commands_on_the_bundled_soundings(runner):
    shown = invoke(runner, "soundings", "show", UNITS.parent / "soundings" / "TILC57.cpt.gz",
                   UNITS.parent / "soundings" / "HALS13.cpt.gz", "--json")
    assert shown.exit_code == 0, shown.output
    rows = json.loads(shown.stdout)
    assert [r["name"] for r in rows] == ["57", "13"] and all(r["kind"] == "cptu" for r in rows)
    assert rows[0]["rate_mm_s"] == pytest.approx(rows[0]["logger_rate_mm_s"], rel=0.06)
    fitted = invoke(runner, "soundings", "fit", UNITS, "--site", "Tiller-Flotten", "--json")
    assert fitted.exit_code == 0, fitted.output
    record = json.loads(fitted.stdout)
    assert record["per_decade"] > 0 and len(record["reference_values_kpa"]) == 9
    clay = invoke(runner, "soundings", "diagnose", UNITS, "--site", "Tiller-Flotten", "--json")
    assert json.loads(clay.stdout)["verdict"] == "rate_effect"
    assert json.loads(clay.stdout)["direction"] == "faster is stronger"
    halsen = invoke(runner, "soundings", "diagnose", UNITS, "--site", "Halsen", "--json")
    assert json.loads(halsen.stdout)["verdict"] == "none"


def test_the_silty_sand_is_called_faster_is_weaker_or_none_with_the_reason(runner):
    """Øysand: the fit's K is negative; whether the held-out test names it depends on the soundings' scatter about
    each other, and a 'none' says that it is why."""
    sand = invoke(runner, "soundings", "diagnose", UNITS, "--site", "Øysand", "--json")
    assert sand.exit_code == 0, sand.output
    record = json.loads(sand.stdout)
    assert record["per_decade"] < 0
    if record["verdict"] == "rate_effect":
        assert record["direction"] == "faster is weaker"
    else:
        assert record["verdict"] == "none" and any("shuffled rates" in note for note in record["notes"])


def test_bad_input_is_one_line_and_exit_1(runner, tmp_path):
    broken = tmp_path / "units.json"
    broken.write_text(json.dumps({"sites": {"A": {"reference_sounding": "X", "soundings": {"X": {"file": "x.cpt"}}}}}))
    cases = [
        (["soundings", "fit", UNITS, "--site", "Nowhere"], "no site 'Nowhere'"),
        (["soundings", "fit", tmp_path / "missing.json", "--site", "A"], "cannot read"),
        (["soundings", "fit", broken, "--site", "A"], "sites.A.units_m: missing"),
        (["soundings", "diagnose", UNITS, "--site", "Halsen", "--quantity", "qx"], "quantity 'qx'"),
        (["soundings", "show", REPO / "README.md"], "expected '$'"),
    ]
    for args, expected in cases:
        r = invoke(runner, *args)
        assert r.exit_code == 1 and expected in r.stderr and "Traceback" not in r.output, (args, r.output)
        assert len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["units.json"]
