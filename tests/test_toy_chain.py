"""A sensor chain pen does not ship, added as a user adds one (:mod:`tests.toy_rangefinder`: one module, one
registration line), is read, fitted and diagnosed by the same code as pen's own chains, and leaves nothing behind
once taken out again.  Its records are the simulated drop's true motion and bed force (:mod:`pencli.acquire.
freefall`, which shares no code with the fit or the diagnosis) read by the sensors this test models: a
rangefinder with 0.01 mm of noise and a tip load cell with 0.2 N."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pencli.acquire.freefall import Bed, Probe, simulate_drop
from pencli.sensors import CHAINS, chain
from tests import toy_rangefinder

HEIGHTS_M = (0.5, 1.0, 3.0, 8.0)
PROBE = Probe()


@pytest.fixture
def rangefinder():
    with toy_rangefinder.register():
        yield


def records(bed: Bed, seed: int) -> list[tuple[np.ndarray, dict]]:
    """(time, channels) of a drop from each height, as the rangefinder and the tip cell record it."""
    rng = np.random.default_rng(seed)
    out = []
    for k, height in enumerate(HEIGHTS_M):
        drop = simulate_drop(PROBE, bed, height, seed=seed * 10 + k)
        time = np.arange(drop.travel_m.size) / 2000.0
        out.append((time, {"range_m": drop.travel_m + rng.normal(0.0, 1e-5, time.size),
                           "tip_force_n": drop.bed_force_n + rng.normal(0.0, 0.2, time.size)}))
    return out


def probe():
    from pencli.fit.freefall import FreeFallProbe

    return FreeFallProbe(PROBE.mass_kg, PROBE.volume_m3, PROBE.half_angle_rad, PROBE.shaft_radius_m,
                         PROBE.drag_coefficient, PROBE.added_mass_coefficient)


def test_a_registered_chain_is_fitted_by_the_bed_fit_within_three_percent(rangefinder):
    """The bed's σ, b, c from four drops read by the toy chain, within 3 % of the simulated bed's; the chain reads
    the force, so the drag and added mass (whose values here are wrong by half) play no part."""
    from pencli.fit.freefall import fit_bed

    bed = Bed(18.0, 140.0, 6.0)
    reader = chain("rangefinder_tip_cell")
    readings = [reader.read(f"drop{k}", t, c) for k, (t, c) in enumerate(records(bed, 3))]
    assert all(r.chain == "rangefinder_tip_cell" and r.force_n is not None for r in readings)
    wrong = replace(probe(), drag_coefficient=0.4, added_mass_coefficient=0.15)
    fit = fit_bed(readings, wrong, nuisances=True)
    assert fit.drag_coefficient is None and fit.added_mass_coefficient is None
    assert fit.strength_kpa == pytest.approx(bed.strength_kpa, rel=0.03)
    assert fit.gradient_kpa_m == pytest.approx(bed.gradient_kpa_m, rel=0.03)
    assert fit.damping_kpa_s_m == pytest.approx(bed.damping_kpa_s_m, rel=0.03)


@pytest.mark.parametrize("layered", [True, False], ids=["layer", "null"])
def test_a_registered_chain_is_diagnosed_by_pens_drop_diagnosis(rangefinder, layered):
    """A hidden layer 0.15 m down, q stepping up by 12 kPa, is named within 1 cm by ``pen drops diagnose``'s
    code; the same bed without it is ``none``.  No accelerometer check runs: this chain has none."""
    from pencli import api

    bed = Bed(18.0, 60.0, 6.0, 0.15, 12.0) if layered else Bed(18.0, 60.0, 6.0)
    reader = chain("rangefinder_tip_cell")
    drops = [api.Drop(None, reader.read(f"drop{k}", t, c)) for k, (t, c) in enumerate(records(bed, 4))]
    result = api.diagnose_drops(drops, probe(), seed=1)
    assert result.accelerometer is None
    if layered:
        assert result.verdict == "layer" and result.layer_depth_m == pytest.approx(0.15, abs=0.01)
        assert result.layer_step_kpa == pytest.approx(12.0, rel=0.2)
    else:
        assert result.verdict == "none"


def test_taking_the_chain_out_leaves_pens_own():
    own = set(CHAINS)
    with toy_rangefinder.register():
        assert set(CHAINS) == own | {"rangefinder_tip_cell"}
        with pytest.raises(ValueError, match="already registered"):
            toy_rangefinder.register()
    assert set(CHAINS) == own
    with pytest.raises(ValueError, match="rangefinder_tip_cell"):
        chain("rangefinder_tip_cell")
