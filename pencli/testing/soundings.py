"""Soundings of the simulated constant-rate cone (:mod:`pencli.acquire.sounding`) as the layer and rate-effect
tests and benches draw them, from a seed: one definition for both."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from pencli.acquire.sounding import SoilLayer, random_layers, sgf_text, simulate_sounding

RATES_MM_S = (5, 10, 20, 35, 50, 65)
"""The push rates of a simulated site's six soundings. [mm/s]"""


def random_sounding(seed: int, layered: bool = True) -> tuple[list[float], np.ndarray, np.ndarray]:
    """(true boundaries [m], depth [m], qt [kPa]) of sounding ``seed``: 1 to 6 random layers from 1 to 15 m (or,
    with ``layered`` False, one layer with a gradient), noise 1–6 %, pushed at 10, 20 or 40 mm/s."""
    from pencli.sensors.cone_tip import qt_kpa

    rng = np.random.default_rng(seed if layered else [seed, 99])
    if layered:
        layers = random_layers(rng, 1.0, 15.0)
    else:
        qt = float(np.exp(rng.uniform(np.log(0.5), np.log(15.0))))
        layers = [SoilLayer(1.0, qt, float(rng.uniform(0, 0.15) * qt), 0.01 if qt > 4 else 0.04,
                            -0.01 if qt > 4 else 0.4)]
    sounding = simulate_sounding(layers, 15.0, rng, noise=float(rng.uniform(0.01, 0.06)),
                                 rate_mm_s=float(rng.choice([10, 20, 40])))
    c = sounding.columns
    return [layer.top_m for layer in layers[1:]], c["depth_m"], qt_kpa(c["qc_mpa"], c["u2_kpa"], sounding.area_ratio)


def six_rate_site(folder: Path, seed: int, per_decade: float) -> Path:
    """Six soundings through the same random ground (``seed``, 1 to 12 m) at :data:`RATES_MM_S` with a rate effect
    of ``per_decade``, written as SGF files into ``folder`` with a units file whose units are the 20 mm/s
    sounding's layers; returns the units file (site ``sim``)."""
    rng = np.random.default_rng(seed)
    layers = random_layers(rng, 1.0, 12.0)
    soundings = {}
    for rate in RATES_MM_S:
        sounding = simulate_sounding(layers, 12.0, rng, rate_mm_s=rate, rate_effect=per_decade, noise=0.03)
        (folder / f"r{rate}.cpt").write_text(sgf_text(f"r{rate}", sounding))
        soundings[f"r{rate}"] = {"file": f"r{rate}.cpt", "nominal_rate_mm_s": rate}
    units = folder / "units.json"
    units.write_text(json.dumps({"sites": {"sim": {"reference_sounding": "r20", "units_m": "layers",
                                                   "soundings": soundings}}}))
    return units


__all__ = ["RATES_MM_S", "random_sounding", "six_rate_site"]
