r"""Dynamic-mode fit: the fully predicted run against measured force and position.

Each run is simulated from its own launch (CONTRACT §2 with the run's
blade, material properties and launcher, :func:`pencli.model.dynamics.simulate`);
the coefficients are those that bring the predicted resistance *and* depth,
against time, closest to the measurements over every run's analysis window
(nonlinear least squares, started from the resistance-mode fit).  Unlike the
resistance mode, errors in the launcher model show up here.
"""

from __future__ import annotations

from typing import Iterable, Mapping, Sequence

import numpy as np
from scipy.optimize import least_squares

from pencli.errors import FitError, ModelError
from pencli.filter.inertia import effective_samples
from pencli.fit.resistance import TYPICAL, _Window, determinacy_warnings, ranges_of, windows, with_coefficients
from pencli.fit.result import COEFFICIENTS, TERM_OF, Coefficient, FitResult, RunFit
from pencli.model.dynamics import simulate
from pencli.model.resistance import parse_terms
from pencli.run import Run

FIT_RTOL = 1e-8
"""Integration tolerance inside the fit: 100× below the smallest misfit it resolves, 100× cheaper than 1e-10."""

POSITION_SCALE_M = 1e-3
"""Depth misfit that weighs as much as a force misfit of the run's resistance scale. [m]"""


def predicted_on(series: _Window, values: Mapping[str, float], terms: Sequence[str],
                 times: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, float]:
    """Predicted depth [m] and resistance [N] at ``times`` (default: the window), and penetration time [s].

    After the predicted stop the body rests: at arrest the material holds the
    springs and the weight (R = η·n·k·(L0 − L) + m_eff·g), at the hard stops R = 0.
    """
    design = with_coefficients(series.design, values)
    rate = (series.time_s.size - 1) / max(series.time_s[-1] - series.time_s[0], 1e-9)
    result = simulate(design, terms, output_rate_hz=max(rate, 10_000.0), rtol=FIT_RTOL, geometry=series.geometry)
    traj = result.trajectory
    t = series.time_s if times is None else times
    x = np.interp(t, traj.time_s, traj.depth_m)
    r = np.interp(t, traj.time_s, traj.resistance_n)
    after = t > traj.time_s[-1]
    if after.any():
        x_end = float(traj.depth_m[-1])
        x[after] = x_end
        if result.summary.end in ("arrest", "creep"):  # held at rest: R balances drive and weight
            r[after] = float(traj.spring_force_n[-1]) + design.effective_mass_kg * design.gravity_m_s2
        else:
            r[after] = 0.0
    before = t < result.summary.contact_time_s
    r[before] = 0.0
    return x, r, result.summary.penetration_time_s


def fit_dynamic(runs: Sequence[Run], material: str, start: Mapping[str, float], *,
                terms: Iterable[str] | str | None = None, fixed: Mapping[str, float] | None = None,
                force_scale_n: Mapping[str, float] | None = None) -> FitResult:
    """Fit the varying coefficients so the predicted runs match force and position (dynamic mode).

    Parameters
    ----------
    start : starting values of all four coefficients (file units), e.g. the resistance-mode fit.
    fixed : coefficients held (file units); switched-off terms are held at 0.
    force_scale_n : per run, the force misfit that counts as one unit (default: 2 % of its peak). [N]
    """
    series = windows(runs)
    chosen = parse_terms(terms)
    held = {name: 0.0 for name in COEFFICIENTS if TERM_OF[name] not in chosen}
    held.update({k: v for k, v in (fixed or {}).items() if k not in held})
    varying = tuple(c for c in COEFFICIENTS if c not in held)
    if not varying:
        raise FitError("every coefficient is fixed or switched off: nothing to fit")
    scales = {s.run_id: (force_scale_n or {}).get(s.run_id, 0.02 * max(float(np.max(s.resistance_n)), 1.0))
              for s in series}

    def values_of(theta):
        out = dict(start)
        out.update(held)
        out.update(dict(zip(varying, theta)))
        return out

    def residuals(theta):
        values = values_of(theta)
        parts = []
        for s in series:
            x, r, _ = predicted_on(s, values, chosen)
            weight = 1.0 / np.sqrt(len(s.time_s))
            parts.append((r - s.resistance_n) / scales[s.run_id] * weight)
            parts.append((x - s.depth_m) / POSITION_SCALE_M * weight)
        return np.concatenate(parts)

    theta0 = np.array([max(float(start[name]), 0.0) for name in varying])
    typical = np.array([TYPICAL[n] for n in varying])
    try:
        solution = least_squares(residuals, theta0, bounds=(0.0, np.inf), x_scale=np.maximum(np.abs(theta0), typical),
                                 diff_step=1e-4, xtol=1e-10, ftol=1e-10, max_nfev=200)
    except ModelError as exc:
        raise FitError(f"dynamic fit failed: {exc}") from None
    values = values_of(solution.x)

    J = solution.jac
    resid = solution.fun
    n_total = resid.size
    runs, per_run_eff, total = [], [], 0
    for s in series:
        x, r, t_model = predicted_on(s, values, chosen)
        err = s.resistance_n - r
        per_run_eff.append(2 * effective_samples(err))  # force and position residual series
        rms = float(np.sqrt(np.mean(err ** 2)))
        peak = float(np.max(s.resistance_n))
        ss_tot = float(np.sum((s.resistance_n - s.resistance_n.mean()) ** 2))
        runs.append(RunFit(s.run_id, len(err), rms, rms / peak if peak > 0 else float("nan"),
                           1 - float(np.sum(err ** 2)) / ss_tot if ss_tot > 0 else float("nan"), peak,
                           s.penetration_time_s, t_model, float(np.sqrt(np.mean((s.depth_m - x) ** 2)) * 1e3)))
        total += len(err)
    n_eff = float(sum(per_run_eff))
    dof = max(n_total - len(varying), 1)
    sigma2 = float(resid @ resid) / dof
    cov = np.linalg.pinv(J.T @ J) * sigma2 * (n_total / n_eff)
    stderr = np.sqrt(np.maximum(np.diag(cov), 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(stderr, stderr)
    coefficients = {}
    for name in COEFFICIENTS:
        if name in varying:
            k = varying.index(name)
            ci = (float(values[name] - 1.96 * stderr[k]), float(values[name] + 1.96 * stderr[k]))
            coefficients[name] = Coefficient(name, float(values[name]), float(stderr[k]), ci, None, True)
        else:
            coefficients[name] = Coefficient(name, float(values[name]), None, None, None, False)
    mean_sq = float(resid @ resid) / len(series)
    aic = n_eff * np.log(max(mean_sq, 1e-300)) + 2 * len(varying)
    bic = n_eff * np.log(max(mean_sq, 1e-300)) + len(varying) * np.log(n_eff)
    warnings = determinacy_warnings(coefficients, varying, corr, len(series))
    for run in runs:
        if run.model_penetration_time_s is not None and run.penetration_time_s:
            gap = run.model_penetration_time_s / run.penetration_time_s - 1
            if abs(gap) > 0.05:
                warnings.append(f"{run.run_id}: predicted penetration time {run.model_penetration_time_s * 1e3:.2f} ms "
                                f"vs measured {run.penetration_time_s * 1e3:.2f} ms ({gap:+.0%}); the launcher or the "
                                f"resistance law misses something here (pen diagnose)")
    return FitResult(material, "dynamic", chosen, coefficients, corr, varying, tuple(runs), total, n_eff,
                     float(aic), float(bic), None, ranges_of(series), tuple(warnings), bool(solution.success),
                     str(solution.message), held)
