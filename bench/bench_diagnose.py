"""Diagnosis on a larger set of simulated campaigns whose truth the diagnoser never sees.

Run: python -m bench.bench_diagnose [--quick | --varied N [SEED] | --nulls N [SEED] | --pairs N [SEED]] [--only EFFECT]
     [--two-slopes] [--drift-friction] [--weak-drifts] [--slow-speeds] [--wide-friction] [--wide-plugs] [--ringing-pairs]
     [--short-gradients] [--bessel-lags] [--s-gradients] [--onset-rates] [--guide-losses]
     [--few-coloured] [--unknown-material] [--resonant-noise] [--butterworth-filters | --filter-kinds]
     [--pink-noise] [--edge-errors] [--weak-rates] [--weak-ringings] [--sized]

``--two-slopes``: every strength gradient of the campaigns takes the sim truth's two-slope form (shape 3; kink
20–80 mm, slope ratio 0–0.5 or 2–4, drawn from a stream of their own), which ``--varied`` never draws.
``--drift-friction``: every pair is a force drift with a velocity friction (random forms, their own stream).
``--weak-drifts``: every force drift of amplitude 3–30 N, log-uniform (its own stream; ``--varied`` draws 60–150 N).
``--weak-rates``: every rate strength's coefficient drawn log-uniform in 0.004–0.08 (its own stream; ``--varied``
draws 0.08–0.2, which leaves z in the hundreds to thousands), so that its sizes span the detection limit.
``--weak-ringings``: every rig ringing's amplitude drawn log-uniform in 0.3–10 N per m/s of contact speed (its own
stream, 17; ``--varied`` draws 40–80, which leaves z in the thousands), so that its sizes span the detection limit.
``--sized``: every effect campaign is also diagnosed without its effects (its twin: the same seed, so the same
runs, nuisances and noise), and its size printed as the hold-out bench defines it: sqrt(max(S − S_twin, 0)) / noise,
S the baseline's held-out mean square and noise the gauges' white and coloured RMS together (twice the time).
``--slow-speeds``: every rate strength and velocity friction takes a characteristic speed of 0.5–2 m/s (its own
stream; ``--varied`` draws 1–6 m/s), where a saturating law is flat over most of a run.
``--wide-friction``: every velocity friction a power law in speed or a Stribeck fall with a viscous rise (sim
truth shapes 3 and 4; its own stream).
``--onset-rates``: every rate strength flat below an onset speed of 1–4 m/s, a power of the speed past it (sim truth
shape 3; its own stream).  A lead read off world three's second draw, whose rate strengths were named velocity
frictions (docs/guide/diagnosis.md); it tells whether the development world shows the swap at all.
``--guide-losses``: every propulsion loss a friction on the moving body alone (no loss of efficiency), of 30–120 N
log-uniform, that acts over the whole travel, in the material too (its own stream, 20; ``--varied`` draws a loss of
efficiency of 10–30 % with a 10 N friction).  A friction takes the same force from each run, so its share of the
energy falls with the springs; and it slows the flight otherwise than a loss of efficiency does, so a model whose
launcher loses efficiency reaches the surface at the right speed at another time (world three's guide
frictions).
``--wide-plugs``: every plug a power of depth up to its length, then constant (sim truth shape 3; its own stream).
``--short-gradients``: every strength gradient saturates (sim truth shape 2) within 4–15 mm (its own stream;
``--varied`` draws 15–80 mm).
``--s-gradients``: every strength gradient an S-shaped rise (sim truth shape 4) centred at 20–80 mm, tanh width
15–40 mm (its own stream).
``--bessel-lags``: every sensor lag a fourth-order Bessel low-pass (sim truth shape 3) of group delay 0.2–0.8 ms
(its own stream; ``--varied`` draws one or two poles or a pure delay).
``--few-coloured``: every campaign cut to four runs, its noise mostly AR(1) (its own stream).
``--unknown-material``: every campaign in a simulant no table holds: density 100–600 kg/m³, strength
1–9 MPa, friction 0.2–0.9, strength factor 0.4–1.4, sidewall pressure 5–40 kPa, inertia coefficient 20–60, and
half of them damped (0.2–3 kPa·s/m; the tabled simulants are not), recorded as they are true (its own stream).
``--resonant-noise``: every campaign's gauges also pick up narrow-band noise (the sim rig's ``resonant_noise_*``):
a level of 0.5–1.2 × its white noise, at 150–3000 Hz, damping ratio 0.02–0.3, campaign i's drawn from the stream
``[SEED, i, 78]`` (a test of a lead from world three: ``--nulls 30 213000
--resonant-noise`` called null 19, whose noise model reads an anti-alias filter the rig does not have).
``--filter-kinds``: every campaign's force channels behind an anti-alias low-pass that is no 4th-order Butterworth
(the only kind the noise model reads): a Bessel or a Chebyshev type I (ripple 0.1–1 dB, log-uniform), half each, of
order 2–8, its corner the campaign's own where it has one, else 0.1–0.4 of the rate; campaign i's drawn from the
stream ``[SEED, i, 79]``.  ``--butterworth-filters``: the same corners behind the 4th-order Butterworth, the
baseline of a test of world three's filters on the development world.
``--pink-noise``: every campaign's gauges also make flicker noise (the sim rig's ``pink_noise_n``) of 0.3–1.5 ×
its white noise, campaign i's drawn from the stream ``[SEED, i, 80]`` (world three draws pink gauge noise; the
development world did not).
``--edge-errors``: every campaign's encoder a quadrature encoder whose four edges per cycle sit off their nominal
places (the sim rig's ``encoder_edge_errors``: duty-cycle and phase errors of its two channels), each edge by a
normal error of standard deviation 0.03-0.15 count (log-uniform), clipped to ±0.4, campaign i's drawn from the
stream ``[SEED, i, 81]`` (world three's encoder has such errors; the development world's had none).
``--ringing-pairs``: every pair is rig ringing with a depth law (pressure growth, plug growth, gradient or layer;
random forms, their own stream).
Prints, per campaign, the truth and the verdict, then: the share of
single-effect verdicts that name the true effect (the hold-out bench's rule),
false-positive rate on null campaigns, median held-out shrink of the
verdict on effect campaigns, the smallest effect magnitude detected per
effect, and the median diagnosis time of a 6-run campaign.

Campaigns: six runs (blades 1, 1.5, 2 mm; 2, 4, 6 springs) from the sim
driver, each carrying hidden effects in the true world; MPACS C blocks
scatter in strength (recorded per block, as the paper measured them).
"""

from __future__ import annotations

import math
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from pencli.testing.options import check_options
from pencli import api
from pencli.errors import FitError
from pencli.testing.campaigns import (BLOCKS, SIX, diagnosis_campaigns, judge, make_campaign, random_effect, redrawn,
                                     two_slopes, varied_campaigns)


def drift_friction(campaigns, seed):
    """The campaigns with every pair replaced by a force drift and a velocity friction."""
    def change(effects, truth, own):
        if len(effects) != 2:
            return effects, truth
        return ([random_effect("force_drift", own), random_effect("velocity_friction", own)],
                {"force_drift", "velocity_friction"})

    return redrawn(campaigns, seed, 5, change)


def _weakened(campaigns, seed, stream: int, name: str, key: str, low: float, high: float):
    """The campaigns with every effect ``name``'s parameter ``key`` drawn log-uniform in ``low``–``high``."""
    def change(effects, truth, own):
        return [dict(e, **{key: float(np.exp(own.uniform(np.log(low), np.log(high))))})
                if e["name"] == name else e for e in effects], truth

    return redrawn(campaigns, seed, stream, change)


def weak_drifts(campaigns, seed):
    """Every force drift's amplitude in 3–30 N (``--varied`` draws 60–150 N, which puts a drift first with z in the
    thousands beside any second effect)."""
    return _weakened(campaigns, seed, 14, "force_drift", "amplitude_n", 3.0, 30.0)


def weak_rates(campaigns, seed):
    """Every rate strength's coefficient in 0.004–0.08."""
    return _weakened(campaigns, seed, 16, "rate_strength", "coefficient", 0.004, 0.08)


def weak_ringings(campaigns, seed):
    """Every rig ringing's amplitude in 0.3–10 N/(m/s)."""
    return _weakened(campaigns, seed, 17, "rig_ringing", "amplitude_n_per_m_s", 0.3, 10.0)


def slow_speeds(campaigns, seed):
    """The campaigns with every speed law's characteristic speed drawn from 0.5–2 m/s."""
    def change(effects, truth, own):
        return [dict(e, speed_m_s=float(own.uniform(0.5, 2.0)))
                if e["name"] in ("rate_strength", "velocity_friction") else e for e in effects], truth

    return redrawn(campaigns, seed, 7, change)


def wide_friction(campaigns, seed):
    """The campaigns with every velocity friction in a form ``--varied`` never draws (its own stream): a power law
    in speed (exponent 0.3–2.5, sim truth shape 3) or a Stribeck fall with a viscous rise past it (shape 4: drop
    0.3–0.6 by 0.5–3 m/s, rise 0.2–0.8 of μ at 10 m/s), drops of either sign."""
    def change(effects, truth, own):
        def redraw(e):
            if own.uniform() < 0.5:
                return dict(e, shape=3.0, exponent=float(own.uniform(0.3, 2.5)))
            return dict(e, shape=4.0, drop=abs(e["drop"]), speed_m_s=float(own.uniform(0.5, 3.0)),
                        viscous=float(own.uniform(0.2, 0.8)))

        return [redraw(e) if e["name"] == "velocity_friction" else e for e in effects], truth

    return redrawn(campaigns, seed, 12, change)


def onset_rates(campaigns, seed):
    """The campaigns with every rate strength flat below an onset speed of 1–4 m/s and rising past it as a power
    (exponent 0.5–1.5, coefficient 0.05–0.2 per (m/s)^exponent; sim truth shape 3; its own stream), a law that no
    speed law of ``--varied`` has: at the run's slow, deep end it leaves nothing, so its misfit sits early in the
    penetration, where the speed is high."""
    def change(effects, truth, own):
        return [dict(e, shape=3.0, speed_m_s=float(own.uniform(1.0, 4.0)), exponent=float(own.uniform(0.5, 1.5)),
                     coefficient=float(own.uniform(0.05, 0.2)))
                if e["name"] == "rate_strength" else e for e in effects], truth

    return redrawn(campaigns, seed, 19, change)


def guide_losses(campaigns, seed):
    """The campaigns with every propulsion loss a friction of 30–120 N over the whole travel alone (see the
    module's doc)."""
    def change(effects, truth, own):
        return [dict(e, loss=0.0, guide_friction_n=float(np.exp(own.uniform(np.log(30.0), np.log(120.0)))))
                if e["name"] == "propulsion_loss" else e for e in effects], truth

    return redrawn(campaigns, seed, 20, change)


def wide_plugs(campaigns, seed):
    """The campaigns with every plug a power of depth until its length, then constant (sim truth shape 3;
    exponent 0.4–2.5, length 10–60 mm; its own stream): from a square root, steep at the surface, to a plug that
    forms slowly and then fast."""
    def change(effects, truth, own):
        return [dict(e, shape=3.0, exponent=float(own.uniform(0.4, 2.5)), length_mm=float(own.uniform(10, 60)))
                if e["name"] == "plug_growth" else e for e in effects], truth

    return redrawn(campaigns, seed, 13, change)


def short_gradients(campaigns, seed):
    """The campaigns with every strength gradient saturating (sim truth shape 2) within 4–15 mm (its own stream)."""
    def change(effects, truth, own):
        return [dict(e, shape=2.0, length_mm=float(own.uniform(4, 15))) if e["name"] == "strength_gradient" else e
                for e in effects], truth

    return redrawn(campaigns, seed, 9, change)


def s_gradients(campaigns, seed):
    """The campaigns with every strength gradient an S-shaped rise (sim truth shape 4) centred at 20–80 mm, tanh
    width 15–40 mm (its own stream): a smooth monotone profile that is neither a power, a saturation nor a step
    (a layer's edge is a tanh too, at most 12 mm wide in the catalogue, 0.5–8 mm in ``--varied``)."""
    def change(effects, truth, own):
        return [dict(e, shape=4.0, length_mm=float(own.uniform(20, 80)), width_mm=float(own.uniform(15, 40)))
                if e["name"] == "strength_gradient" else e for e in effects], truth

    return redrawn(campaigns, seed, 11, change)


def bessel_lags(campaigns, seed):
    """The campaigns with every sensor lag a fourth-order Bessel low-pass (sim truth shape 3) of group delay
    0.2–0.8 ms (its own stream): a delay with a rounded step, which no single lag member has."""
    def change(effects, truth, own):
        return [dict(e, shape=3.0, tau_ms=float(own.uniform(0.2, 0.8))) if e["name"] == "sensor_lag" else e
                for e in effects], truth

    return redrawn(campaigns, seed, 10, change)


def ringing_pairs(campaigns, seed):
    """The campaigns with every pair replaced by rig ringing and a depth law (pressure growth, plug growth,
    gradient or layer; random forms, their own stream)."""
    laws = ["sidewall_pressure_growth", "plug_growth", "strength_gradient", "strength_layer"]

    def change(effects, truth, own):
        if len(effects) != 2:
            return effects, truth
        second = str(own.choice(laws))
        return [random_effect("rig_ringing", own), random_effect(second, own)], {"rig_ringing", second}

    return redrawn(campaigns, seed, 8, change)


def few_coloured(campaigns, seed):
    """The campaigns cut to their first four runs, with noise that is mostly coloured: white 0.3–1 N and an AR(1)
    part of 1–4 N whose time constant (0.02–0.15 ms) gives a sample-to-sample correlation of about 0.2–0.9 at
    30–60 kHz (its own stream).  Few runs and coloured noise leave the fewest held-out folds and the most
    drift-like wander in each run."""
    own = np.random.default_rng([seed, 14])
    out = []
    for label, material, effects, truth, nuisances in campaigns:
        n = len(nuisances["shots"])
        cut = {k: (v[:4] if isinstance(v, list) and len(v) == n else v) for k, v in nuisances.items()}
        cut["rig_extra"] = dict(nuisances["rig_extra"], force_noise_n=float(own.uniform(0.3, 1.0)),
                                correlated_noise_n=float(own.uniform(1.0, 4.0)),
                                correlated_noise_ms=float(own.uniform(0.02, 0.15)))
        out.append((label, material, effects, truth, cut))
    return out


def unknown_material(campaigns, seed):
    """The campaigns in a simulant no table holds, with damping in half of them (its own stream; see the doc)."""
    own = np.random.default_rng([seed, 15])
    out = []
    for label, material, effects, truth, nuisances in campaigns:
        damping = float(own.uniform(0.2, 3.0)) if own.uniform() < 0.5 else 0.0
        record = {"density_kg_m3": float(own.uniform(100, 600)),
                  "microstructure_strength_kpa": float(own.uniform(1000, 9000)),
                  "friction_coefficient": float(own.uniform(0.2, 0.9)),
                  "coefficients": {"strength_factor": float(own.uniform(0.4, 1.4)),
                                   "sidewall_pressure_kpa": float(own.uniform(5, 40)),
                                   "damping_kpa_s_m": damping,
                                   "inertia_coefficient": float(own.uniform(20, 60))}}
        out.append((label, material, effects, truth, dict(nuisances, record_material=record)))
    return out


def _rig_added(campaigns, seed: int, stream: int, draw):
    """Every campaign's rig with the keys ``draw(rng, white_noise_n)`` returns added, campaign i's drawn from the
    stream ``[seed, i, stream]`` (so the rest of the campaign is what it was)."""
    out = []
    for i, (label, material, effects, truth, nuisances) in enumerate(campaigns):
        extra = dict(nuisances["rig_extra"])
        extra.update(draw(np.random.default_rng([seed, i, stream]), extra["force_noise_n"]))
        out.append((label, material, effects, truth, dict(nuisances, rig_extra=extra)))
    return out


def resonant_noise(campaigns, seed):
    """Narrow-band gauge noise added to every campaign's rig (see the module's doc)."""
    def draw(own, white):
        level, hz, damping = own.uniform(0.5, 1.2) * white, own.uniform(150, 3000), own.uniform(0.02, 0.3)
        return {"resonant_noise_n": float(level), "resonant_noise_hz": float(hz),
                "resonant_noise_damping": float(damping)}
    return _rig_added(campaigns, seed, 78, draw)


def pink_noise(campaigns, seed):
    """Flicker gauge noise added to every campaign's rig (see the module's doc)."""
    return _rig_added(campaigns, seed, 80, lambda own, white: {"pink_noise_n": float(own.uniform(0.3, 1.5) * white)})


def edge_errors(campaigns, seed):
    """A quadrature encoder's edge errors on every campaign's rig (see the module's doc)."""
    def draw(own, white):
        sigma = float(np.exp(own.uniform(np.log(0.03), np.log(0.15))))
        return {"encoder_edge_errors": [float(np.clip(e, -0.4, 0.4)) for e in own.normal(0.0, sigma, 4)]}
    return _rig_added(campaigns, seed, 81, draw)


def _filters(campaigns, seed, butterworth: bool):
    """Every campaign behind an anti-alias low-pass (see the module's doc), drawn alike for both flags."""
    out = []
    for i, (label, material, effects, truth, nuisances) in enumerate(campaigns):
        own = np.random.default_rng([seed, i, 79])
        corner, kind = float(own.uniform(0.1, 0.4)), ("bessel", "chebyshev")[int(own.integers(2))]
        order, ripple = int(own.integers(2, 9)), float(np.exp(own.uniform(np.log(0.1), np.log(1.0))))
        if butterworth:
            kind, order = "butterworth", 4
        extra = dict(nuisances["rig_extra"], anti_alias_kind=kind, anti_alias_order=order,
                     anti_alias_ripple_db=ripple)
        out.append((label, material, effects, truth,
                    dict(nuisances, anti_alias=nuisances.get("anti_alias", corner), rig_extra=extra)))
    return out


def filter_kinds(campaigns, seed):
    """Bessel and Chebyshev anti-alias filters on every campaign (see the module's doc)."""
    return _filters(campaigns, seed, butterworth=False)


def butterworth_filters(campaigns, seed):
    """The same corners behind the 4th-order Butterworth (see the module's doc)."""
    return _filters(campaigns, seed, butterworth=True)


REDRAWS = {"--two-slopes": two_slopes, "--drift-friction": drift_friction, "--weak-drifts": weak_drifts,
           "--weak-rates": weak_rates, "--weak-ringings": weak_ringings,
           "--slow-speeds": slow_speeds,
           "--wide-friction": wide_friction, "--wide-plugs": wide_plugs, "--onset-rates": onset_rates,
           "--guide-losses": guide_losses,
           "--ringing-pairs": ringing_pairs, "--s-gradients": s_gradients, "--bessel-lags": bessel_lags,
           "--short-gradients": short_gradients, "--few-coloured": few_coloured,
           "--unknown-material": unknown_material, "--resonant-noise": resonant_noise,
           "--filter-kinds": filter_kinds, "--butterworth-filters": butterworth_filters, "--pink-noise": pink_noise,
           "--edge-errors": edge_errors}
"""The scratch sets' flags and what each redraws (see the module's doc)."""


def run_one(label, material, effects, seed, nuisances=None):
    with tempfile.TemporaryDirectory() as tmp:
        nuisances = {"shots": SIX, **(nuisances or {})}
        tabled = material == "mpacs_c" and "record_material" not in nuisances  # its blocks' measured strengths
        db = make_campaign(Path(tmp), material, seed=seed, effects=effects, block_kpa=BLOCKS if tabled else None,
                           **nuisances)
        api.tare_runs(db, ["all"])
        api.subtract_inertia_runs(db, ["all"])
        t0 = time.perf_counter()
        result = api.diagnose(db, ["all"])
        return result, time.perf_counter() - t0


def main() -> None:
    check_options(__doc__, ("--quick", "--varied", "--nulls", "--pairs", "--only", "--sized", *REDRAWS))
    quick = "--quick" in sys.argv
    option = next((o for o in ("--varied", "--nulls", "--pairs") if o in sys.argv), None)
    if option:  # random forms and nuisances: python -m bench.bench_diagnose --varied|--nulls|--pairs 28 [SEED]
        at = sys.argv.index(option)
        count = int(sys.argv[at + 1])
        base_seed = int(sys.argv[at + 2]) if len(sys.argv) > at + 2 else 2000
        only = {"--nulls": "nulls", "--pairs": "pairs"}.get(option)
        if "--only" in sys.argv:  # one effect alone: --varied 12 SEED --only strength_gradient
            only = sys.argv[sys.argv.index("--only") + 1]
        campaigns = varied_campaigns(count, base_seed, only=only)
        for flag, redraw in REDRAWS.items():  # in this order: a later one wins where two change the same effect
            if flag in sys.argv:
                campaigns = redraw(campaigns, base_seed)
    else:
        campaigns = [(*c, None) for c in diagnosis_campaigns(quick)]
        base_seed = 500
    rows, times = [], []
    for seed, (label, material, effects, truth, nuisances) in enumerate(campaigns):
        try:
            result, seconds = run_one(label, material, effects, base_seed + seed, nuisances)
        except FitError as e:  # e.g. too many shots saturated the load cell and were discarded, as the lab would
            print(f"{label:28s} skipped: {e}", flush=True)
            continue
        ok, shrink = judge(result, truth)
        size = ""
        if "--sized" in sys.argv and effects:
            twin, _ = run_one(label, material, [], base_seed + seed, nuisances)
            rig = (nuisances or {}).get("rig_extra", {})
            noise = math.hypot(rig.get("force_noise_n", 0.0), rig.get("correlated_noise_n", 0.0)) or float("nan")
            gap = result.baseline["heldout_rms_n"] ** 2 - twin.baseline["heldout_rms_n"] ** 2
            size = f" size={math.sqrt(max(gap, 0.0)) / noise:.2f}"
        times.append(seconds)
        rows.append((label, truth, result, ok, shrink))
        top = result.effects[0] if result.effects else None
        drive = next((e for e in result.effects if e.name == "propulsion_loss"), None)
        if drive is not None:  # the drive view's t, and its dynamic shrinks in the material and from release
            size += (f" drive_t={drive.z}/{result.decision['drive_threshold_t']} dyn={drive.shrink_pct}/"
                     f"{drive.params.get('dynamic_shrink_from_release_pct')}")
        print(f"{label:28s} truth={'+'.join(sorted(truth)):45s} verdict={result.verdict:25s} "
              f"{'OK ' if ok else 'MISS'} first={top.name if top else '-':25s} shrink={top.shrink_pct if top else 0:5.1f}% "
              f"z={top.z if top else 0:5.1f}/{result.decision['effect_threshold_z']:.1f} gap_z={result.baseline['gap_z']:.1f} "
              f"own_z={result.baseline.get('own_runs_z')} "
              f"{result.verdict_effects} pair={result.baseline.get('best_pair', {}).get('effects')} "
              f"share={result.baseline.get('best_pair', {}).get('share_of_remainder')} {seconds:.1f}s{size}", flush=True)
    nulls = [r for r in rows if r[1] == {"none"}]
    extra = [r[0] for r in rows if len(r[1]) == 1 and r[1] < set(r[2].verdict_effects)]  # the truth and more
    effects = [r for r in rows if r[1] not in ({"none"}, {"unexplained"})]
    singles = [r for r in effects if len(r[1]) == 1]
    top1 = sum(r[3] for r in singles) / max(len(singles), 1)
    fp = sum(r[2].verdict != "none" for r in nulls) / max(len(nulls), 1)
    shrinks = [r[4] for r in effects if r[4] is not None and r[2].verdict not in ("none", "unexplained")]
    print()
    print(f"single-effect verdicts right:                                 {top1:.0%} of {len(singles)}")
    print(f"two-effect campaigns with both effects found:                 {sum(r[3] for r in effects if len(r[1]) > 1)} "
          f"of {sum(len(r[1]) > 1 for r in effects)}")
    print(f"single-effect campaigns with a wrong effect beside the right: {len(extra)} {extra}")
    print(f"false-positive rate on nulls:                                 {fp:.0%} of {len(nulls)}")
    print(f"outside-catalogue effect called unexplained:                  "
          f"{[r[3] for r in rows if r[1] == {'unexplained'}]}")
    print(f"median held-out shrink of the verdict (effect campaigns):     "
          f"{statistics.median(shrinks) if shrinks else float('nan'):.1f} %")
    detected = {}
    for label, truth, result, ok, _ in singles:
        name = next(iter(truth))
        if ok:
            detected.setdefault(name, []).append(label)
    print(f"effects detected at their smaller magnitude:                  "
          f"{sorted(n for n, labels in detected.items() if any(lbl.endswith('-0') for lbl in labels))}")
    print(f"median diagnosis time of a 6-run campaign:                    {statistics.median(times):.1f} s "
          f"(target under 60 s)")


if __name__ == "__main__":
    main()
