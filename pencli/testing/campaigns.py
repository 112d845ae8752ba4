"""Simulated-rig campaigns for fitting and diagnosis tests: made by the sim driver, never by the model code.

Each campaign is a list of shots (blade, springs, seed, block strength) fired
through `api.acquire` with a rig file that carries the true material, so the
truth lives only in the rig file and the sim driver.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from pencli import api
from pencli.acquire.rig import RIG_KEYS
from pencli.errors import DataError
from pencli.params.load import load_preset

BLADES = ("1", "1.5", "2")
SPRINGS = (2, 4, 6)


def twelve_shots() -> list[tuple[str, int]]:
    """Blades 1, 1.5, 2 mm × springs 2, 4, 6, plus three repeats: twelve runs."""
    combos = [(b, s) for b in BLADES for s in SPRINGS]
    return combos + [("1", 4), ("1.5", 2), ("2", 6)]


def make_campaign(folder: Path, material: str, *, shots=None, seed: int = 0, effects=(), block_kpa=None,
                  rig_extra=None, record_material: dict | None = None, standoff_mm: list | None = None,
                  strength_scale: list | None = None, encoder_mm: float | None = None,
                  encoder_phase: list | None = None, rates_hz: list | None = None,
                  anti_alias: float | None = None, position_noise_um: float | None = None,
                  converter_noise: float | None = None) -> Path:
    """Fire a campaign into ``folder/runs.duckdb``; returns the catalog path.

    ``shots``: (blade thickness in mm of a bundled 184 mm blade, or a penetrator file ending in .yaml; springs, or a
    launcher file ending in .yaml).
    ``standoff_mm``: per shot, the true stand-off minus the file's (stand-off scatter).
    ``strength_scale``: per shot, the block's true strength over the recorded one (unrecorded scatter).
    ``encoder_mm``: the string encoder's step (default: the bundled encoder's).
    ``encoder_phase``: per shot, where the blade rests within one count (default 0, every shot alike).
    ``rates_hz``: per shot, the sampling rate (default: the rig's, every shot alike).
    ``anti_alias``: the force channels' anti-alias corner as a fraction of each shot's sampling rate (default none).
    ``position_noise_um``: the encoder's white position error before it quantises (default none). [µm]
    ``converter_noise``: white noise the converter adds after the anti-alias filter, as a fraction of the gauge's
    white force noise (default none).
    """
    folder.mkdir(parents=True, exist_ok=True)
    db = folder / "runs.duckdb"
    shots = shots or twelve_shots()
    position_cal = None
    if encoder_mm is not None:
        position_cal = folder / "encoder.yaml"
        position_cal.write_text(yaml.safe_dump({"counts_per_mm": 1.0 / float(encoder_mm)}))
    for i, (blade, springs) in enumerate(shots):
        mapping = load_preset(material, "material").to_mapping()
        mapping.pop("notes", None)
        if record_material:
            mapping.update(record_material)
        if block_kpa is not None:
            mapping["microstructure_strength_kpa"] = float(block_kpa[i % len(block_kpa)])
        material_file = folder / f"material-{i}.yaml"
        material_file.write_text(yaml.safe_dump(mapping))
        rig = {"kind": "rig", "name": "campaign", "seed": seed * 1000 + i, "true_material": str(material_file),
               "effects": [dict(e) for e in effects], **(rig_extra or {})}
        if standoff_mm is not None:
            rig["surface_offset_error_mm"] = float(standoff_mm[i % len(standoff_mm)])
        if strength_scale is not None:
            rig["strength_scale"] = float(strength_scale[i % len(strength_scale)])
        if encoder_phase is not None:
            rig["encoder_phase"] = float(encoder_phase[i % len(encoder_phase)])
        if rates_hz is not None:
            rig["sampling_rate_hz"] = float(rates_hz[i % len(rates_hz)])
        if anti_alias is not None:
            rate = float(rig.get("sampling_rate_hz", RIG_KEYS["sampling_rate_hz"][1]))
            rig["anti_alias_hz"] = float(anti_alias) * rate
        if position_noise_um is not None:
            rig["position_noise_um"] = float(position_noise_um)
        if converter_noise is not None:
            gauge = float(rig.get("force_noise_n", RIG_KEYS["force_noise_n"][1]))
            rig["converter_noise_n"] = float(converter_noise) * gauge
        rig_file = folder / f"rig-{i}.yaml"
        rig_file.write_text(yaml.safe_dump(rig))
        penetrator = blade if str(blade).endswith(".yaml") else f"al6061_{blade}mm"  # a file, or a blade's mm
        launcher = {"springs": None, "energizing": springs} if str(springs).endswith(".yaml") else {"springs": springs}
        shot = api.acquire(**launcher, penetrator=penetrator, material=str(material_file), rig=rig_file,
                           position_cal=position_cal, duration_s=1.0, info={"id": f"r{i:02d}-{blade}mm-{Path(str(springs)).stem}s"})
        try:
            api.add_run(shot.run, db, command="test campaign")
        except DataError:  # a saturated shot is discarded, as the lab would
            continue
    return db


# ---------------------------------------------------------------------------- diagnosis test set
SIX = [("1", 2), ("1", 6), ("1.5", 4), ("2", 2), ("2", 6), ("1.5", 6)]
BLOCKS = [5600, 6000, 6400, 7200, 8200, 5900]

# (label, material, effects, expected verdict set)
SINGLE = {
    "strength_layer": [{"depth_mm": 40, "ratio": 0.6}, {"depth_mm": 60, "ratio": 1.6}],
    "strength_gradient": [{"change_per_100mm": 1.5}, {"change_per_100mm": 3.0}],
    "plug_growth": [{"growth_mm": 1.5}, {"growth_mm": 3.0}],
    "sidewall_pressure_growth": [{"scale_mm": 60}, {"scale_mm": 30}],
    "velocity_friction": [{"drop": 0.4}, {"drop": 0.6}],
    "rate_strength": [{"coefficient": 0.1}, {"coefficient": 0.2}],
    "load_cell_mass_error": [{"ratio": 1.5}, {"ratio": 0.7}],
    "sensor_lag": [{"tau_ms": 0.3}, {"tau_ms": 0.8}],
    "rig_ringing": [{"amplitude_n_per_m_s": 40}, {"amplitude_n_per_m_s": 80}],
    "force_drift": [{"amplitude_n": 80}, {"amplitude_n": 150}],
    "propulsion_loss": [{"loss": 0.15}, {"loss": 0.3}],
}
PAIRS = [
    [{"name": "strength_layer", "depth_mm": 50, "ratio": 0.5, "thickness_mm": 300},
     {"name": "load_cell_mass_error", "ratio": 1.5}],
    [{"name": "rig_ringing", "amplitude_n_per_m_s": 60}, {"name": "sidewall_pressure_growth", "scale_mm": 40}],
    [{"name": "propulsion_loss", "loss": 0.2}, {"name": "strength_layer", "depth_mm": 40, "ratio": 1.5, "thickness_mm": 300}],
]


def diagnosis_campaigns(quick: bool = False):
    """(label, material, hidden effects, acceptable verdicts) of the diagnosis test set."""
    out = []
    for i in range(2 if quick else 4):
        out.append((f"null-{i}", "mpacs_c" if i % 2 == 0 else "grill_brick", [], {"none"}))
    for name, magnitudes in SINGLE.items():
        for k, params in enumerate(magnitudes[:1] if quick else magnitudes):
            out.append((f"{name}-{k}", "mpacs_c", [{"name": name, **params}], {name}))
    for k, pair in enumerate(PAIRS[:1] if quick else PAIRS):
        out.append((f"pair-{k}", "mpacs_c", pair, {e["name"] for e in pair}))
    out.append(("outside", "mpacs_c", [{"name": "brittle_bursts", "period_mm": 20, "ratio": 0.5}], {"unexplained"}))
    return out




RANDOM_FORMS = {  # (low, high) per parameter of the sim world's effect forms; "shape": how many forms to draw from
    "strength_layer": {"depth_mm": (30, 90), "edge_mm": (0.5, 8), "thickness_mm": (30, 300)},
    "strength_gradient": {"change_per_100mm": (1.0, 3.0), "shape": 3, "exponent": (0.5, 3.0), "length_mm": (15, 80)},
    "plug_growth": {"growth_mm": (1.5, 3.0), "length_mm": (10, 60), "shape": 3},
    "sidewall_pressure_growth": {"scale_mm": (30, 80), "exponent": (1.2, 2.5), "shape": 2, "rise": (1.0, 3.0)},
    "velocity_friction": {"drop": (0.3, 0.6), "speed_m_s": (1.0, 5.0), "shape": 3},
    "rate_strength": {"coefficient": (0.08, 0.2), "exponent": (1.0, 2.0), "shape": 3, "speed_m_s": (2.0, 6.0)},
    "load_cell_mass_error": {"ratio": (0.6, 1.6)},
    "sensor_lag": {"tau_ms": (0.2, 0.8), "shape": 3},
    "rig_ringing": {"amplitude_n_per_m_s": (40, 80), "frequency_hz": (400, 2500), "damping_ratio": (0.02, 0.06),
                    "second_amplitude": (0.0, 0.6), "second_ratio": (1.5, 3.5)},
    "force_drift": {"amplitude_n": (60, 150), "time_constant_s": (0.02, 0.1), "shape": 3},
    "propulsion_loss": {"loss": (0.1, 0.3)},
}


def random_effect(name: str, rng) -> dict:
    """The sim world's effect ``name`` with its form (``shape``) and parameters drawn within their meaning."""
    params = {k: float(rng.integers(r)) if k == "shape" else float(rng.uniform(*r))
              for k, r in RANDOM_FORMS[name].items()}
    if name == "load_cell_mass_error" and 0.85 < params["ratio"] < 1.15:
        params["ratio"] = 1.3 if params["ratio"] > 1 else 0.7
    if name == "strength_layer":
        params["ratio"] = float(rng.choice([rng.uniform(0.5, 0.7), rng.uniform(1.4, 1.8)]))
    if name == "strength_gradient" and rng.uniform() < 0.25:  # strength may also fall with depth
        params["change_per_100mm"] = -float(rng.uniform(0.3, 0.6))
    if name == "velocity_friction" and rng.uniform() < 0.3:  # or friction rise with speed
        params["drop"] = -params["drop"]
    if name == "force_drift" and params["shape"] == 1:  # linear: amplitude per time constant, over the whole record
        params["time_constant_s"] *= 4.0
    return {"name": name, **params}


POOL = [(b, s) for b in BLADES for s in SPRINGS]


def random_nuisances(rng) -> dict:
    """make_campaign keywords for a campaign with varied nuisances: noise level and colour, rate, encoder
    step, 4–8 runs of random blades and springs, unrecorded block scatter 3–6 %, stand-off scatter, an
    anti-alias filter and mixed rates (:func:`_acquisition`), and the encoder's phase: at the middle of a
    count in every shot, at one random place in every shot (a blade that rests against the same stop), or
    at a random place in each shot."""
    n_shots = int(rng.integers(4, 9))
    picks = rng.choice(len(POOL), n_shots, replace=n_shots > len(POOL))
    return {"rig_extra": {"force_noise_n": float(rng.uniform(0.5, 6.0)),
                          "correlated_noise_n": float(rng.choice([0.0, rng.uniform(0.5, 3.0)])),
                          "correlated_noise_ms": float(rng.uniform(0.1, 2.0)),
                          "sampling_rate_hz": float(rng.choice([30000.0, 60000.0]))},
            "shots": [POOL[int(k)] for k in picks],
            "encoder_mm": float(rng.choice([0.08, 0.16, 0.32])),
            "strength_scale": [float(x) for x in rng.normal(1.0, rng.uniform(0.03, 0.06), n_shots)],
            "standoff_mm": [float(x) for x in rng.normal(0.0, rng.uniform(0.3, 1.5), n_shots)],
            "encoder_phase": [float(x) for x in _phases(rng, n_shots)],
            **_acquisition(rng, n_shots)}


def _acquisition(rng, n_shots: int) -> dict:
    """Half the campaigns' force channels behind an anti-alias low-pass (corner 0.1–0.4 of the rate); a third
    of them with runs at mixed rates (30 and 60 kHz drawn per run); a third read by an encoder with 1–10 µm of
    white position error on top of its quantisation; half with a converter adding white noise of 2–20 % of the
    gauge's after the filter.  Drawn from a stream of their own, so the
    rest of a seed's campaign is what it was before these nuisances were added."""
    import numpy as np

    own = np.random.default_rng([int(rng.bit_generator.state["state"]["state"] % 2 ** 63), 11])
    out = {}
    if own.uniform() < 0.5:
        out["anti_alias"] = float(own.uniform(0.1, 0.4))
    if own.uniform() < 1.0 / 3.0:
        out["rates_hz"] = [float(r) for r in own.choice([30000.0, 60000.0], n_shots)]
    if own.uniform() < 1.0 / 3.0:  # drawn after the others, so they are what they were before it was added
        out["position_noise_um"] = float(own.uniform(1.0, 10.0))
    if own.uniform() < 0.5:  # likewise: a converter's own noise after the filter, 2-20 % of the gauge's
        out["converter_noise"] = float(own.uniform(0.02, 0.2))
    return out


def _phases(rng, n_shots: int):
    kind = int(rng.integers(0, 3))
    if kind == 0:
        return [0.0] * n_shots
    if kind == 1:
        return [float(rng.uniform(0.0, 1.0))] * n_shots
    return rng.uniform(0.0, 1.0, n_shots)


def varied_campaigns(count: int, seed: int, *, only: str | None = None):
    """(label, material, hidden effects, acceptable verdicts, nuisances) with random forms and nuisances:
    nulls, every single effect and pairs in turn (or ``only`` "nulls", "pairs" or one effect's name)."""
    import numpy as np

    rng = np.random.default_rng(seed)
    names = list(RANDOM_FORMS)
    kinds = {"nulls": 0, "pairs": 13, **{n: 2 + k for k, n in enumerate(names)}}
    if only is not None and only not in kinds:
        raise ValueError(f"only: got {only!r}; expected one of {', '.join(kinds)}")
    out = []
    for i in range(count):
        kind = kinds.get(only, i % 14)
        material = str(rng.choice(["mpacs_c", "grill_brick"]))
        if kind < 2:
            label, effects, truth = f"null-{i}", [], {"none"}
        elif kind < 13:
            name = names[kind - 2]
            label, effects, truth = f"{name}-{i}", [random_effect(name, rng)], {name}
        else:
            a, b = rng.choice([n for n in names if n not in ("strength_gradient",)], 2, replace=False)
            label, effects, truth = f"pair-{i}", [random_effect(str(a), rng), random_effect(str(b), rng)], {a, b}
        out.append((label, material, effects, truth, random_nuisances(rng)))
    return out


def judge(result, truth: set[str]) -> tuple[bool, float | None]:
    """(correct, shrink of the verdict's effect) by the hold-out bench's rules: the verdict names the true
    effect; both effects of a pair are among the verdict's effects; ``none`` and ``unexplained`` by verdict.
    A single effect ranked first, or named indistinguishable from the first, does not count when the verdict is
    something else."""
    if len(truth) == 1:
        ok = result.verdict in truth
    else:
        ok = truth <= set(result.verdict_effects)
    shrink = next((e.shrink_pct for e in result.effects if e.name == result.verdict), None)
    return bool(ok), shrink


def redrawn(campaigns, seed, stream, change):
    """The campaigns with ``change(effects, truth, rng)`` → (effects, truth) applied to each, drawing from a
    stream of their own (``stream``), so that the campaigns' other draws stay what ``--varied`` made them."""
    own = np.random.default_rng([seed, stream])
    return [(label, material, *change(effects, truth, own), nuisances)
            for label, material, effects, truth, nuisances in campaigns]


def two_slopes(campaigns, seed):
    """The campaigns with every strength gradient in the two-slope form (sim truth shape 3)."""
    def change(effects, truth, own):
        return [dict(e, shape=3.0, kink_mm=float(own.uniform(20, 80)),
                     slope_ratio=float(own.choice([own.uniform(0, 0.5), own.uniform(2, 4)])))
                if e["name"] == "strength_gradient" else e for e in effects], truth

    return redrawn(campaigns, seed, 3, change)


def diagnose_folders(folders, db: Path):
    """A campaign's run folders through ``pen ingest``, ``tare``, ``subtract-inertia`` and ``diagnose``, as a lab
    runs them; returns the diagnosis, its own time and the whole pipeline's. [s]"""
    import time

    started = time.perf_counter()
    api.ingest(folders, db)
    api.tare_runs(db, ["all"])
    api.subtract_inertia_runs(db, ["all"])
    t0 = time.perf_counter()
    result = api.diagnose(db, ["all"])
    done = time.perf_counter()
    return result, done - t0, done - started
