r"""Diagnosing the sim-to-real gap: where the model and the runs part, which effect, how far it closes.

Two views of each run:

- **resistance view** — Eq. 9 driven by the *measured* depth and speed,
  against the measured resistance (flight and penetration window).  A gap
  here lies in the resistance law or the force chain.
- **drive view** — measured against predicted contact speed, and the fully
  predicted run from its launch.  A gap here but not in the resistance view
  lies on the drive side (the launcher).

Baseline: Eq. 9 with one strength factor per run (blocks scatter in
strength; the paper measured MPACS C per block), shared P, C, K.  Every
catalogue effect (:mod:`pencli.diagnose.effects`) is added in turn, refitted
on training runs and scored on the run left out; the held-out run keeps
only its own strength nuisance.  Significance thresholds come from null
campaigns (:data:`THRESHOLDS`, ``bench/calibrate_diagnose.py``), never from
sample counts.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import asdict, dataclass, field
from typing import Mapping, Sequence

import numpy as np
from scipy.optimize import lsq_linear, minimize_scalar

from pencli.diagnose.effects import EFFECTS, INDISTINGUISHABLE, Basis, DiagnosisRun, Effect, basis_of
from pencli.errors import FitError
from pencli.filter.inertia import effective_samples
from pencli.model.dynamics import flight_of, simulate
from pencli.fit.resistance import with_coefficients

THRESHOLDS = {
    "gap_ratio": 8.0,
    "shrink_pct": 25.0,
    "explain_pct": 50.0,
    "drive_gap": 0.01,
    "ambiguity_pct": 8.0,
}
"""Decision thresholds, set on null campaigns (noise, block scatter, no effect) by
``python -m bench.bench_diagnose`` (its null campaigns):

- ``gap_ratio``: baseline held-out RMS over the sensor noise floor above which the
  resistance view has a gap (nulls: 4.0–6.2, from derivative errors of the encoder);
- ``shrink_pct``: held-out shrink an effect needs to count (nulls' best effect: under 1 %);
- ``explain_pct``: an effect (or pair) that closes less than this leaves the gap ``unexplained``;
- ``drive_gap``: RMS relative contact-speed error above which the drive side has a gap
  (nulls: 0.33–0.44 %, the flight fit's bias);
- ``ambiguity_pct``: effects within this many points of the best are reported as
  indistinguishable when their terms are alike.
"""


# ----------------------------------------------------------------------------- linear machinery
@dataclass(frozen=True)
class _Prepared:
    run: DiagnosisRun
    basis: Basis
    use: np.ndarray
    """Analysis samples (flight ∪ window) within the context span."""
    y: np.ndarray
    """Measured resistance on the context span."""


def _prepare(run: DiagnosisRun) -> _Prepared:
    c = run.context
    use = (run.flight | run.window)[c]
    return _Prepared(run, basis_of(run), use, run.resistance_n[c])


def _with_frontal(prep: _Prepared, strength_factor: float, shared: np.ndarray) -> _Prepared:
    """Attach the baseline's frontal force to a run (the plug term scales it)."""
    from dataclasses import replace

    b = prep.basis
    frontal = strength_factor * b.strength + shared[1] * b.damping + shared[2] * b.inertia
    return replace(prep, basis=replace(b, frontal=frontal))


def _blocks(prep: _Prepared, effects: Sequence[tuple[Effect, Mapping[str, float]]]):
    """(B (n,4), E (n,k), offset (n,)) on the analysis samples for a set of effects."""
    B = prep.basis.matrix()
    extras, offset = [], np.zeros(B.shape[0])
    for effect, params in effects:
        transformed, E, off = effect.build(prep.run, prep.basis, params)
        if transformed is not None:
            B = transformed
        extras.append(E)
        offset = offset + off
    E = np.concatenate(extras, axis=1) if extras else np.zeros((B.shape[0], 0))
    u = prep.use
    return B[u], E[u], offset[u], prep.y[u]


def _solve(rows: list, n_extra: int) -> tuple[np.ndarray, np.ndarray, float]:
    """Fit per-run strength factors and shared P, C, K (≥ 0) and effect coefficients (free).

    Returns (per-run Cs, shared [P, C, K, effect...], weighted RSS).
    """
    n_runs = len(rows)
    sizes = [r[0].shape[0] for r in rows]
    total = sum(sizes)
    n_cols = n_runs + 3 + n_extra
    X = np.zeros((total, n_cols))
    y = np.zeros(total)
    start = 0
    for i, (B, E, off, yy) in enumerate(rows):
        w = 1.0 / math.sqrt(max(len(yy), 1))
        sl = slice(start, start + len(yy))
        X[sl, i] = B[:, 0] * w
        X[sl, n_runs:n_runs + 3] = B[:, 1:] * w
        X[sl, n_runs + 3:] = E * w
        y[sl] = (yy - off) * w
        start += len(yy)
    scale = np.linalg.norm(X, axis=0)
    scale[scale == 0] = 1.0
    Xs = X / scale
    # fast path: unconstrained least squares; bounded only when a physical coefficient comes out negative
    theta, *_ = np.linalg.lstsq(Xs, y, rcond=None)
    if np.any(theta[:n_runs + 3] < 0):
        lower = np.r_[np.zeros(n_runs + 3), np.full(n_extra, -np.inf)]
        theta = lsq_linear(Xs, y, bounds=(lower, np.inf), method="bvls").x
    theta = theta / scale
    rss = float(np.sum((X @ theta - y) ** 2))
    return theta[:n_runs], theta[n_runs:], rss


def _held_out_residual(row, shared: np.ndarray) -> tuple[np.ndarray, float]:
    """Residual of a run left out: only its strength factor is refitted (≥ 0)."""
    B, E, off, yy = row
    rest = yy - off - B[:, 1:] @ shared[:3] - (E @ shared[3:] if E.shape[1] else 0.0)
    s = B[:, 0]
    denom = float(s @ s)
    cs = max(float(s @ rest) / denom, 0.0) if denom > 0 else 0.0
    return rest - cs * s, cs


@dataclass(frozen=True)
class Candidate:
    """A model (baseline, one effect or a pair) scored by leaving one run out."""

    names: tuple[str, ...]
    params: dict
    """Chosen grid parameters of each effect (all runs), by effect."""
    heldout_rms_n: float
    residuals: tuple[np.ndarray, ...]
    """Held-out residual of each run on its analysis samples."""
    shared: np.ndarray
    """P, C, K and effect coefficients fitted on all runs."""
    strength_factors: np.ndarray
    grid_spread: dict
    """Per effect and grid parameter: [min, max] chosen across the folds."""
    covariance: np.ndarray | None = None


def _score(preps: Sequence[_Prepared], effects: Sequence[Effect], *, fixed_params: Mapping[str, dict] | None = None
           ) -> Candidate:
    """Leave-one-run-out score of the baseline plus ``effects`` (grid parameters searched on training runs)."""
    grids = [[fixed_params[e.name]] if fixed_params and e.name in fixed_params else list(e.grid) for e in effects]
    combos = [dict(zip([e.name for e in effects], combo)) for combo in itertools.product(*grids)] if effects else [{}]
    rows_by_combo = []
    for combo in combos:
        rows_by_combo.append([_blocks(p, [(e, combo[e.name]) for e in effects]) for p in preps])
    n_extra = rows_by_combo[0][0][1].shape[1]

    def best_on(indices):
        best = None
        for combo, rows in zip(combos, rows_by_combo):
            cs, shared, rss = _solve([rows[i] for i in indices], n_extra)
            if best is None or rss < best[3]:
                best = (combo, cs, shared, rss, rows)
        return best

    everything = list(range(len(preps)))
    combo_all, cs_all, shared_all, _, rows_all = best_on(everything)
    residuals, spread = [], {}
    for k in everything:
        combo, _, shared, _, rows = best_on([i for i in everything if i != k])
        res, _ = _held_out_residual(rows[k], shared)
        residuals.append(res)
        for name, params in combo.items():
            for key, value in params.items():
                lo, hi = spread.setdefault(name, {}).get(key, (value, value))
                spread[name][key] = (min(lo, value), max(hi, value))
    mean_sq = [float(np.mean(r ** 2)) for r in residuals]
    cov = _covariance(rows_all, cs_all, shared_all, n_extra)
    return Candidate(tuple(e.name for e in effects), combo_all, math.sqrt(float(np.mean(mean_sq))),
                     tuple(residuals), shared_all, cs_all, spread, cov)


def _covariance(rows, cs, shared, n_extra) -> np.ndarray | None:
    """Covariance of the shared coefficients (P, C, K, effect…), inflated for correlated residuals."""
    n_runs = len(rows)
    blocks, resid, eff = [], [], 0.0
    for i, (B, E, off, yy) in enumerate(rows):
        w = 1.0 / math.sqrt(max(len(yy), 1))
        X = np.zeros((len(yy), n_runs + 3 + n_extra))
        X[:, i] = B[:, 0]
        X[:, n_runs:n_runs + 3] = B[:, 1:]
        X[:, n_runs + 3:] = E
        r = yy - off - X @ np.r_[cs, shared]
        blocks.append(X * w)
        resid.append(r * w)
        eff += effective_samples(r)
    X = np.vstack(blocks)
    r = np.concatenate(resid)
    n = X.shape[0]
    sigma2 = float(r @ r) / max(n - X.shape[1], 1)
    try:
        cov = np.linalg.pinv(X.T @ X) * sigma2 * n / max(eff, 1.0)
    except np.linalg.LinAlgError:  # pragma: no cover
        return None
    return cov[n_runs:, n_runs:]


# ----------------------------------------------------------------------------- drive side
def _predicted_contact_speed(run: DiagnosisRun, loss: float = 0.0) -> float:
    from dataclasses import replace

    design = replace(run.design, efficiency=run.design.efficiency * (1.0 - loss))
    flight = flight_of(design)
    t = flight.time_to_reach(design.surface_offset_m)
    return float(flight.state(t)[1]) if math.isfinite(t) else 0.0


def _fit_loss(runs: Sequence[DiagnosisRun]) -> float:
    def cost(loss):
        return sum((_predicted_contact_speed(r, loss) / r.contact_speed_m_s - 1) ** 2 for r in runs)

    return float(minimize_scalar(cost, bounds=(-0.5, 0.9), method="bounded", options={"xatol": 1e-6}).x)


def _dynamic_rms(run: DiagnosisRun, values: Mapping[str, float], loss: float = 0.0, extra=None) -> float:
    """RMS of measured − fully predicted resistance over the run's window, launched with efficiency × (1 − loss)."""
    from dataclasses import replace

    design = replace(with_coefficients(run.design, values), efficiency=run.design.efficiency * (1.0 - loss))
    result = simulate(design, output_rate_hz=run.rate_hz, rtol=1e-8, extra_resistance=extra)
    traj = result.trajectory
    w = run.window
    t = run.time_s[w]
    r = np.interp(t, traj.time_s, traj.resistance_n)
    r[t > traj.time_s[-1]] = float(traj.resistance_n[-1]) if result.summary.end == "arrest" else 0.0
    r[t < result.summary.contact_time_s] = 0.0
    return float(np.sqrt(np.mean((run.resistance_n[w] - r) ** 2)))


# ----------------------------------------------------------------------------- the report
@dataclass(frozen=True)
class EffectReport:
    """One catalogue effect, scored."""

    name: str
    side: str
    view: str
    """``resistance`` or ``drive``: which held-out RMS it is scored on."""
    params: dict
    intervals: dict
    heldout_rms_n: float
    shrink_pct: float
    significant: bool
    trajectory_change: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class Diagnosis:
    """What ``pen diagnose`` found (CONTRACT §4)."""

    runs: tuple[str, ...]
    baseline: dict
    where: tuple[dict, ...]
    effects: tuple[EffectReport, ...]
    verdict: str
    verdict_effects: tuple[str, ...]
    ambiguities: tuple[dict, ...]
    noise_floor_n: float
    notes: tuple[str, ...] = ()
    success: bool = True
    message: str = ""
    series: tuple[dict, ...] = ()
    """Per run, for figures: time_s, depth_m, time_since_contact_s and the held-out residual [N] of the
    baseline and of the verdict's first effect (not in the JSON)."""

    def to_dict(self) -> dict:
        return {
            "runs": list(self.runs),
            "baseline": self.baseline,
            "where": list(self.where),
            "effects": [e.to_dict() for e in self.effects],
            "verdict": self.verdict,
            "verdict_effects": list(self.verdict_effects),
            "ambiguities": list(self.ambiguities),
            "noise_floor_n": self.noise_floor_n,
            "thresholds": dict(THRESHOLDS),
            "notes": list(self.notes),
        }


def _where(preps: Sequence[_Prepared], residuals: Sequence[np.ndarray], floor: float) -> list[dict]:
    """Split the baseline's held-out misfit by phase, with depth, time and speed bands."""
    phases: dict[str, dict[str, list]] = {}
    for prep, res in zip(preps, residuals):
        run = prep.run
        ctx = run.context
        t = run.time_s[ctx][prep.use]
        x = run.depth_m[ctx][prep.use]
        v = run.velocity_m_s[ctx][prep.use]
        phase = np.where(t < run.contact_s, "flight", np.where(t < run.contact_s + 3e-3, "contact", "penetration"))
        for name in ("flight", "contact", "penetration"):
            sel = phase == name
            if sel.any():
                d = phases.setdefault(name, {"r": [], "t": [], "x": [], "v": [], "tc": []})
                d["r"].append(res[sel])
                d["t"].append(t[sel])
                d["x"].append(x[sel])
                d["v"].append(v[sel])
                d["tc"].append(t[sel] - run.contact_s)
        # rest: after the stop the material holds the drive (arrest) or the stops take it (full depth)
        rest = (run.time_s > run.stop_s + 20e-3) & (run.time_s < run.stop_s + 150e-3)
        if rest.sum() > 10:
            d_ = run.design
            x_end = float(np.median(run.depth_m[rest]))
            held = (d_.drive_stiffness_n_m * max(d_.stroke_m - x_end - d_.surface_offset_m, 0.0)
                    + d_.effective_mass_kg * d_.gravity_m_s2) if run.end == "arrest" else 0.0
            d = phases.setdefault("rest", {"r": [], "t": [], "x": [], "v": [], "tc": []})
            d["r"].append(run.resistance_n[rest] - held)
            d["t"].append(run.time_s[rest])
            d["x"].append(run.depth_m[rest])
            d["v"].append(np.zeros(int(rest.sum())))
            d["tc"].append(run.time_s[rest] - run.contact_s)
    excess = {}
    for name, d in phases.items():
        r = np.concatenate(d["r"])
        excess[name] = max(float(np.sum(r ** 2)) - r.size * floor ** 2, 0.0)
    total = sum(excess.values())
    out = []
    for name, d in phases.items():
        if total <= 0 or excess[name] / total < 0.05:
            continue
        r = np.concatenate(d["r"])
        t = np.concatenate(d["t"])
        x = np.concatenate(d["x"])
        v = np.concatenate(d["v"])
        tc = np.concatenate(d["tc"])
        weight = r ** 2
        band = _dense_band(x, weight) if name not in ("flight", "rest") else None
        time_band = _dense_band(t, weight)
        out.append({
            "phase": name,
            "depth_mm": None if band is None else [round(band[0] * 1e3, 1), round(band[1] * 1e3, 1)],
            "time_ms": [round(time_band[0] * 1e3, 2), round(time_band[1] * 1e3, 2)],
            "time_since_contact_ms": [round(float(np.min(tc)) * 1e3, 2), round(float(np.max(tc)) * 1e3, 2)],
            "speed_m_s": [round(float(np.min(v)), 2), round(float(np.max(v)), 2)],
            "rms_n": float(np.sqrt(np.mean(r ** 2))),
            "share_of_gap": round(excess[name] / total, 3),
            "above_noise": bool(np.sqrt(np.mean(r ** 2)) > THRESHOLDS["gap_ratio"] * floor),
        })
    out.sort(key=lambda item: -item["share_of_gap"])
    return out


def _dense_band(values: np.ndarray, weight: np.ndarray, share: float = 0.8) -> tuple[float, float]:
    """The narrowest value range holding ``share`` of the weight (sorted, two-pointer)."""
    order = np.argsort(values)
    v, w = values[order], weight[order]
    cum = np.concatenate([[0.0], np.cumsum(w)])
    total = cum[-1]
    if total <= 0:
        return float(v[0]), float(v[-1])
    best = (float(v[0]), float(v[-1]))
    j = 0
    for i in range(v.size):
        while j < v.size and cum[j + 1] - cum[i] < share * total:
            j += 1
        if j >= v.size:
            break
        if v[j] - v[i] < best[1] - best[0]:
            best = (float(v[i]), float(v[j]))
    return best


def _trajectory_change(effect: Effect, cand: Candidate, preps: Sequence[_Prepared], values: Mapping[str, float],
                       loss: float = 0.0) -> dict:
    """Change of the CONTRACT §5 figures of the median-speed run once the effect is in the dynamic model."""
    if effect.side == "chain":
        return {"note": "a measurement effect: the trajectory does not change"}
    runs = sorted((p.run for p in preps), key=lambda r: r.contact_speed_m_s)
    run = runs[len(runs) // 2]
    base_design = with_coefficients(run.design, values)
    before = simulate(base_design, rtol=1e-8).summary
    if effect.side == "drive":
        from dataclasses import replace

        after = simulate(replace(base_design, efficiency=base_design.efficiency * (1 - loss)), rtol=1e-8).summary
    else:
        k = cand.names.index(effect.name)
        coefs = cand.shared[3:][_coef_slice(cand.names, k)]
        if effect.name == "plug_growth":  # the frontal force grows by g·L·(1 − exp(−x/L))/T
            g = float(coefs[0])
            T = run.design.blade_thickness_m
            length = cand.params[effect.name]["length_mm"] * 1e-3
            law = base_design
            frontal = (lambda x, v, d=law: (d.strength_factor * d.blade_width_m * d.blade_thickness_m * d.strength_pa
                                            * (math.sin(d.tip_angle_rad) + d.friction_coefficient
                                               * math.cos(d.tip_angle_rad))
                                            + d.blade_width_m * d.blade_thickness_m * (d.damping_pa_s_m * v
                                            + d.inertia_coefficient * d.density_kg_m3 * v * v)))
            extra = (lambda x, v, f=frontal: f(x, v) * g * length * -math.expm1(-max(x, 0.0) / length) / T)
        else:
            extra = effect.extra(coefs, cand.params[effect.name], run)
        after = simulate(base_design, rtol=1e-8, extra_resistance=extra).summary
    return {
        "run": run.run_id,
        "penetration_time_pct": 100 * (after.penetration_time_s / before.penetration_time_s - 1)
        if before.penetration_time_s > 0 else None,
        "final_depth_mm": after.final_depth_mm - before.final_depth_mm,
        "peak_resistance_pct": 100 * (after.peak_resistance_n / before.peak_resistance_n - 1)
        if before.peak_resistance_n > 0 else None,
    }


_N_COEFS = {"rig_ringing": 2, "sensor_lag": 0, "strength_gradient": 2}


def _coef_slice(names: Sequence[str], k: int) -> slice:
    start = sum(_N_COEFS.get(n, 1) for n in names[:k])
    return slice(start, start + _N_COEFS.get(names[k], 1))


def diagnose(runs: Sequence[DiagnosisRun], *, effects: Sequence[str] | None = None) -> Diagnosis:
    """Locate, explain and size the gap between the reference model and ``runs``."""
    if len(runs) < 3:
        raise FitError(f"diagnosis needs at least 3 runs to hold one out and still fit (got {len(runs)})")
    names = list(effects or EFFECTS)
    unknown = [n for n in names if n not in EFFECTS]
    if unknown:
        raise FitError(f"unknown effect {unknown[0]!r}; the catalogue: {', '.join(EFFECTS)}")
    preps = [_prepare(r) for r in runs]
    floor = math.sqrt(float(np.mean([r.noise_n ** 2 for r in runs])))
    base = _score(preps, [])
    preps = [_with_frontal(p, cs, base.shared) for p, cs in zip(preps, base.strength_factors)]
    values = {"strength_factor": float(np.mean(base.strength_factors)), "sidewall_pressure_kpa": float(base.shared[0]),
              "damping_kpa_s_m": float(base.shared[1]), "inertia_coefficient": float(base.shared[2])}
    context = {"cs_mean": max(values["strength_factor"], 1e-9), "p_kpa": max(values["sidewall_pressure_kpa"], 1e-9),
               "load_cell_mass_kg": float(np.mean([r.load_cell_mass_kg for r in runs]))}
    gap_ratio = base.heldout_rms_n / max(floor, 1e-9)
    resistance_gap = gap_ratio > THRESHOLDS["gap_ratio"]

    # drive view: contact speeds, then the fully predicted runs
    ratios = np.array([r.contact_speed_m_s / max(_predicted_contact_speed(r), 1e-9) - 1 for r in runs])
    drive_gap_value = float(np.sqrt(np.mean(ratios ** 2)))
    drive_gap = drive_gap_value > THRESHOLDS["drive_gap"]

    reports: list[EffectReport] = []
    candidates: dict[str, Candidate] = {}
    for name in names:
        effect = EFFECTS[name]
        if effect.side == "drive":
            continue
        cand = _score(preps, [effect])
        candidates[name] = cand
        shrink = 100.0 * (1 - cand.heldout_rms_n / base.heldout_rms_n) if base.heldout_rms_n > 0 else 0.0
        coefs = cand.shared[3:]
        params = effect.describe(coefs, cand.params.get(name, {}), context)
        intervals = {k: [float(a), float(b)] for k, (a, b) in cand.grid_spread.get(name, {}).items()}
        if cand.covariance is not None and coefs.size:
            se = np.sqrt(np.maximum(np.diag(cand.covariance)[3:], 0.0))
            intervals["coefficients_95"] = [[float(c - 1.96 * s), float(c + 1.96 * s)] for c, s in zip(coefs, se)]
        reports.append(EffectReport(name, effect.side, "resistance", params, intervals, cand.heldout_rms_n,
                                    round(shrink, 2), resistance_gap and shrink >= THRESHOLDS["shrink_pct"]))

    dyn_base = None
    if "propulsion_loss" in names:
        base_rms, loss_rms, losses = [], [], []
        for k, run in enumerate(runs):
            loss = _fit_loss([r for i, r in enumerate(runs) if i != k])
            losses.append(loss)
            vals = dict(values, strength_factor=float(base.strength_factors[k]))
            base_rms.append(_dynamic_rms(run, vals) ** 2)
            loss_rms.append(_dynamic_rms(run, vals, loss) ** 2)
        dyn_base = math.sqrt(float(np.mean(base_rms)))
        dyn_loss = math.sqrt(float(np.mean(loss_rms)))
        loss_all = _fit_loss(runs)
        shrink = 100.0 * (1 - dyn_loss / dyn_base) if dyn_base > 0 else 0.0
        reports.append(EffectReport("propulsion_loss", "drive", "drive", EFFECTS["propulsion_loss"].describe(
            np.array([loss_all]), {}, context), {"loss": [float(min(losses)), float(max(losses))]}, dyn_loss,
            round(shrink, 2), drive_gap and shrink >= THRESHOLDS["shrink_pct"]))

    reports.sort(key=lambda e: (-int(e.significant), -e.shrink_pct))
    significant = [e for e in reports if e.significant]
    verdict, verdict_effects, notes = "none", (), []
    best_pair = None
    if resistance_gap or drive_gap:
        top = significant[0] if significant else None
        single_ok = top is not None and top.shrink_pct >= THRESHOLDS["explain_pct"]
        remaining = None
        if top is not None and top.view == "resistance":
            remaining = candidates[top.name].heldout_rms_n / max(floor, 1e-9)
        need_pair = top is None or not single_ok or (remaining is not None and remaining > THRESHOLDS["gap_ratio"])
        if need_pair:
            best_pair = _best_pair(preps, base, candidates, reports)
        if best_pair is not None and (not single_ok or best_pair[1] >= (top.shrink_pct if top else 0)
                                      + THRESHOLDS["shrink_pct"] / 2):
            pair_names, pair_shrink = best_pair
            if pair_shrink >= THRESHOLDS["explain_pct"]:
                verdict = pair_names[0] if top is None or top.name not in pair_names else top.name
                verdict_effects = tuple(pair_names)
                notes.append(f"no single effect closes the gap; together {pair_names[0]} and {pair_names[1]} "
                             f"shrink it by {pair_shrink:.0f} %")
            elif single_ok:
                verdict, verdict_effects = top.name, (top.name,)
            else:
                verdict = "unexplained"
        elif single_ok:
            verdict, verdict_effects = top.name, (top.name,)
            if drive_gap and resistance_gap:  # both views have a gap: name the best effect of each
                other = next((e for e in significant if e.view != top.view), None)
                if other is not None:
                    verdict_effects = (top.name, other.name)
        else:
            verdict = "unexplained"
        if verdict == "unexplained":
            notes.append("a gap stands above the noise that no catalogue effect (nor pair) closes by half; see where")

    # how far: trajectory change of the reported effects
    final_reports = []
    loss_value = next((e.params["loss"] for e in reports if e.name == "propulsion_loss"), 0.0)
    for e in reports:
        change = {}
        if e.significant or e.name in verdict_effects:
            effect = EFFECTS[e.name]
            cand = candidates.get(e.name)
            if effect.side == "drive" or cand is not None:
                change = _trajectory_change(effect, cand, preps, values, loss_value)
        final_reports.append(EffectReport(e.name, e.side, e.view, e.params, e.intervals, e.heldout_rms_n,
                                          e.shrink_pct, e.significant, change))

    ambiguities = _ambiguities(final_reports, candidates, preps)
    where = _where(preps, base.residuals, floor)
    if drive_gap:
        where.insert(0, {"phase": "flight", "depth_mm": None, "time_ms": [0.0, round(float(np.mean(
            [r.contact_s for r in runs])) * 1e3, 2)], "contact_speed_error_pct": [round(100 * float(ratios.min()), 2),
                                                                               round(100 * float(ratios.max()), 2)],
            "share_of_gap": None, "above_noise": True, "view": "drive"})
    baseline = {
        "heldout_rms_n": base.heldout_rms_n,
        "heldout_nrmse": base.heldout_rms_n / float(np.mean([np.max(r.resistance_n[r.window]) for r in runs])),
        "gap_ratio": gap_ratio,
        "resistance_gap": bool(resistance_gap),
        "contact_speed_error_rms": drive_gap_value,
        "drive_gap": bool(drive_gap),
        "dynamic_heldout_rms_n": dyn_base,
        "coefficients": values,
        "strength_factor_per_run": {r.run_id: float(c) for r, c in zip(runs, base.strength_factors)},
    }
    if best_pair is not None:
        baseline["best_pair"] = {"effects": list(best_pair[0]), "shrink_pct": best_pair[1]}
    after = candidates.get(verdict_effects[0]) if verdict_effects else None
    series = []
    for i, prep in enumerate(preps):
        ctx = prep.run.context
        t = prep.run.time_s[ctx][prep.use]
        series.append({"run_id": prep.run.run_id, "time_s": t, "depth_m": prep.run.depth_m[ctx][prep.use],
                       "time_since_contact_s": t - prep.run.contact_s, "baseline_residual_n": base.residuals[i],
                       "effect_residual_n": after.residuals[i] if after is not None else None})
    return Diagnosis(tuple(r.run_id for r in runs), baseline, tuple(where), tuple(final_reports), verdict,
                     tuple(verdict_effects), tuple(ambiguities), floor, tuple(notes), series=tuple(series))


def _best_pair(preps, base: Candidate, candidates: Mapping[str, Candidate], reports) -> tuple[tuple[str, str], float] | None:
    """Best two-effect model: the best single effect with every other, and pairs among the four best.

    A second effect can rank low on its own when the first dominates the held-out misfit.
    """
    ranked = [e.name for e in reports if e.view == "resistance"]
    pairs = {tuple(sorted(p)) for p in itertools.combinations(ranked[:4], 2)}
    pairs |= {tuple(sorted((ranked[0], other))) for other in ranked[1:]} if ranked else set()
    best = None
    for a, b in sorted(pairs):
        # re-search grids jointly when small; otherwise search the larger grid with the other held at its best
        ga, gb = len(EFFECTS[a].grid), len(EFFECTS[b].grid)
        if ga * gb <= 100:
            fixed = {}
        elif ga >= gb:
            fixed = {b: candidates[b].params.get(b, {})}
        else:
            fixed = {a: candidates[a].params.get(a, {})}
        cand = _score(preps, [EFFECTS[a], EFFECTS[b]], fixed_params=fixed)
        shrink = 100.0 * (1 - cand.heldout_rms_n / base.heldout_rms_n)
        if best is None or shrink > best[1]:
            best = ((a, b), round(shrink, 2))
    return best


def _ambiguities(reports: Sequence[EffectReport], candidates: Mapping[str, Candidate], preps) -> list[dict]:
    """Effects scoring within ``ambiguity_pct`` of the best whose misfit shapes are alike."""
    significant = [e for e in reports if e.significant]
    if len(significant) < 2:
        return []
    top = significant[0]
    out = []
    for other in significant[1:]:
        if top.shrink_pct - other.shrink_pct > THRESHOLDS["ambiguity_pct"]:
            continue
        alike = 1.0
        if top.name in candidates and other.name in candidates:
            a = np.concatenate(candidates[top.name].residuals)
            b = np.concatenate(candidates[other.name].residuals)
            base_r = a - b
            alike = 1.0 - float(np.sqrt(np.mean(base_r ** 2)) / max(np.sqrt(np.mean(a ** 2)), 1e-12))
        advice = INDISTINGUISHABLE.get(frozenset({top.name, other.name}),
                                       "runs that vary blade thickness, contact speed and depth")
        out.append({"effects": [top.name, other.name], "shrink_pct": [top.shrink_pct, other.shrink_pct],
                    "residual_similarity": round(alike, 3), "separate_with": advice})
    return out
