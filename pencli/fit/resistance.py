r"""Resistance-mode fit: Eq. 9 against measured resistance with measured kinematics.

With the measured depth :math:`x` and speed :math:`v` of every sample, Eq. 9
is linear in its four coefficients:

.. math::

    R = C_s\,[wTS(\sin\theta+\mu\cos\theta)] + P\,[2\mu w x] + C\,[wTv] + K\,[wT\rho v^2]

so a simultaneous fit over many runs is a bounded linear least-squares
problem (all coefficients ≥ 0).  Each run counts equally, whatever its
length.  Residuals of 30 kHz data are strongly correlated, so standard
errors use the effective number of samples (autocorrelation per run), and a
bootstrap over whole runs and, within each, blocks of samples gives a second,
assumption-light interval.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace
from typing import Callable, Iterable, Mapping, Sequence

import numpy as np
from scipy.optimize import lsq_linear

from pencli.errors import DataError, FitError
from pencli.filter.inertia import effective_samples
from pencli.filter.windows import FIT_EDGE_MARGINS_S, fit_edges
from pencli.fit.result import COEFFICIENT_OF, COEFFICIENTS, TERM_OF, Coefficient, FitResult, RunFit
from pencli.model.design import Design
from pencli.model.geometry import BLADE, Geometry
from pencli.model.resistance import TERMS, coefficient_of, parse_terms
from pencli.run import MIN_WINDOW_SAMPLES, Run

TYPICAL = {"strength_factor": 1.0, "sidewall_pressure_kpa": 10.0, "damping_kpa_s_m": 10.0, "inertia_coefficient": 30.0}
"""Typical magnitudes (file units): scales for the optimiser and for judging an uncertainty near zero."""

SEPARATE = {
    frozenset({"strength_factor", "sidewall_pressure_kpa"}):
        "strength/friction trade-off: add runs with another blade thickness (frontal strength scales with T, "
        "sidewall friction does not) or a wider depth range",
    frozenset({"strength_factor", "inertia_coefficient"}):
        "strength/inertia trade-off: add runs at another contact speed (inertia goes with v², strength not)",
    frozenset({"sidewall_pressure_kpa", "inertia_coefficient"}):
        "friction/inertia trade-off: add runs at another contact speed or to another depth",
    frozenset({"damping_kpa_s_m", "inertia_coefficient"}):
        "damping/inertia trade-off: add runs at another contact speed to separate C (∝ v) from K (∝ v²)",
    frozenset({"strength_factor", "damping_kpa_s_m"}):
        "strength/damping trade-off: add runs at another contact speed",
    frozenset({"sidewall_pressure_kpa", "damping_kpa_s_m"}):
        "friction/damping trade-off: add runs at another contact speed or to another depth",
}
"""What run would separate two correlated coefficients."""


@dataclass(frozen=True)
class _Window:
    """One run's measured analysis window as the fit reads it (SI): an adapter of a
    :class:`~pencli.run.Run` made by :func:`windows`, private to the fit."""

    run_id: str
    design: Design
    """The run's blade, material properties and launcher (coefficients unused)."""
    time_s: np.ndarray
    depth_m: np.ndarray
    velocity_m_s: np.ndarray
    resistance_n: np.ndarray
    contact_s: float
    stop_s: float
    end: str
    contact_speed_m_s: float
    record: Mapping[str, np.ndarray] | None = None
    """The whole record (time_s, depth_m, velocity_m_s, resistance_n), for model-against-data tables."""
    material: str = ""
    """The ``name:`` of the run's material file."""
    geometry: Geometry = BLADE
    """The run's penetrator geometry, whose columns the fit multiplies (:meth:`Geometry.unit_terms`)."""

    @property
    def penetration_time_s(self) -> float:
        return self.stop_s - self.contact_s


RECORD_COLUMNS = ("time_s", "depth_m", "velocity_m_s", "resistance_n")
"""The inertia-stage columns a fit reads."""


def windows(runs: Sequence[Run | _Window], margins_s: tuple[float, float] = (0.0, 0.0)) -> list[_Window]:
    """Each run's analysis window (a window is passed on as it is), less ``margins_s`` after contact and before
    the stop (:func:`pencli.filter.windows.fit_edges`); a run with fewer than
    :data:`~pencli.run.MIN_WINDOW_SAMPLES` samples left is refused with its id."""
    out = []
    for run in runs:
        if isinstance(run, _Window):
            out.append(run)
            continue
        events = run.require_events()
        reading = run.reading()
        record = dict(zip(RECORD_COLUMNS, (reading.time_s, reading.travel_m, reading.speed_m_s, reading.force_n)))
        keep = run.window
        if any(margins_s):
            first, last = fit_edges(events.contact_s, events.stop_s, margins_s)
            keep = keep & (record["time_s"] >= first) & (record["time_s"] <= last)
        if keep.sum() < MIN_WINDOW_SAMPLES:
            less = " less the fit's edge margins" if any(margins_s) else ""
            raise DataError(f"run '{run.name}': only {int(keep.sum())} samples in the analysis window{less}; a fit "
                            f"needs at least {MIN_WINDOW_SAMPLES}")
        out.append(_Window(run.run_id, run.design, *(record[name][keep] for name in RECORD_COLUMNS),
                           events.contact_s, events.stop_s, events.end, events.contact_speed_m_s, record,
                           run.material.name, run.geometry))
    return out


def basis(series: _Window) -> np.ndarray:
    """Columns of Eq. 9 per file unit of each coefficient, shape (n, 4), on the run's geometry (the blade's are
    Eq. 9's own). [N per unit]"""
    x, v = np.maximum(series.depth_m, 1e-12), series.velocity_m_s  # in the window the tip is in the material
    return np.column_stack(np.broadcast_arrays(*series.geometry.unit_terms(series.design, x, v)))


def _solve(X: np.ndarray, y: np.ndarray) -> np.ndarray:
    scale = np.linalg.norm(X, axis=0)
    scale[scale == 0] = 1.0
    result = lsq_linear(X / scale, y, bounds=(0.0, np.inf), method="bvls")
    return result.x / scale


@dataclass(frozen=True)
class _Problem:
    X: np.ndarray
    y: np.ndarray
    weights: np.ndarray
    run_index: np.ndarray
    varying: tuple[str, ...]
    fixed_part: np.ndarray


def _problem(series: Sequence[_Window], varying: Sequence[str], fixed: Mapping[str, float]) -> _Problem:
    blocks, ys, ws, idx, fixed_parts = [], [], [], [], []
    cols = [COEFFICIENTS.index(name) for name in varying]
    for i, s in enumerate(series):
        B = basis(s)
        fixed_part = sum((B[:, COEFFICIENTS.index(n)] * v for n, v in fixed.items()), np.zeros(len(s.time_s)))
        blocks.append(B[:, cols])
        ys.append(s.resistance_n)
        fixed_parts.append(fixed_part)
        ws.append(np.full(len(s.time_s), 1.0 / np.sqrt(len(s.time_s))))
        idx.append(np.full(len(s.time_s), i))
    return _Problem(np.vstack(blocks), np.concatenate(ys), np.concatenate(ws), np.concatenate(idx), tuple(varying),
                    np.concatenate(fixed_parts))


def _fit_values(p: _Problem, mask: np.ndarray | None = None) -> np.ndarray:
    """The fit's coefficients on the rows ``mask`` selects (a boolean mask or row indices, repeats allowed)."""
    rows = slice(None) if mask is None else mask
    w = p.weights[rows][:, None]
    return _solve(p.X[rows] * w, (p.y[rows] - p.fixed_part[rows]) * w[:, 0])


BLOCK_CORRELATION_TIMES = 2.0
"""The bootstrap resamples a run's samples in blocks this many of its residuals' correlation times long
(n / n_eff, :func:`~pencli.filter.inertia.effective_samples`), so each block is nearly independent of the next. [–]"""


def _resampled_rows(run_index: np.ndarray, blocks: Sequence[int], rng: np.random.Generator) -> np.ndarray:
    """One bootstrap sample's rows: runs drawn with replacement, and in each drawn run its samples drawn again as
    blocks of ``blocks[run]`` neighbouring samples (a moving-block bootstrap), as many as the run has.

    Resampling whole runs alone cannot see a residual pattern every run shares (derivative errors at the
    same place in every run); within runs, the blocks where the pattern sits are drawn more or less often, so a
    coefficient that leans on them varies, and its interval widens."""
    starts = np.concatenate([[0], np.cumsum(np.bincount(run_index, minlength=len(blocks)))])
    rows = []
    for r in rng.integers(0, len(blocks), len(blocks)):
        n, length = int(starts[r + 1] - starts[r]), min(int(blocks[r]), int(starts[r + 1] - starts[r]))
        first = rng.integers(0, n - length + 1, int(np.ceil(n / length)))
        rows.append(starts[r] + (first[:, None] + np.arange(length)[None, :]).ravel()[:n])
    return np.concatenate(rows)


def ranges_of(series: Sequence[_Window]) -> dict:
    """The conditions a fit saw, for ``predict`` to warn outside them."""
    def span(values):
        return [float(np.min(values)), float(np.max(values))]

    out = {
        "contact_speed_m_s": span([s.contact_speed_m_s for s in series]),
        "depth_mm": [0.0, float(max(np.max((s.record or {"depth_m": s.depth_m})["depth_m"]) for s in series) * 1e3)],
        "blade_thickness_mm": span([s.design.blade_thickness_m * 1e3 for s in series]),
        "blade_width_mm": span([s.design.blade_width_m * 1e3 for s in series]),
        "microstructure_strength_kpa": span([s.design.strength_pa / 1e3 for s in series]),
    }
    return {key: pair for key, pair in out.items() if all(np.isfinite(pair))}  # a cone has no blade width


def fit_resistance(runs: Sequence[Run], material: str, *, terms: Iterable[str] | str | None = None,
                   fixed: Mapping[str, float] | None = None, bootstrap: int = 200, seed: int = 0,
                   leave_one_out: bool = True, n_effective: float | None = None,
                   progress: Callable[[int, int], None] | None = None) -> FitResult:
    """Fit Cs, P, C, K simultaneously over ``series`` (resistance mode).

    Parameters
    ----------
    runs : conditioned runs (inertia stage); each is fitted over its analysis window less the edge margins
        (:data:`~pencli.filter.windows.FIT_EDGE_MARGINS_S`), where the encoder's derivatives are least reliable.
    material : name recorded in the result.
    terms : Eq. 9 terms switched on (others are 0).
    fixed : coefficients held at a value (file units), e.g. ``{"damping_kpa_s_m": 0}``.
    bootstrap : refits on runs resampled with replacement, each run's samples resampled in blocks (0: none).
    n_effective : sample count for AIC/BIC; models compared must share one (default: from these residuals).
    progress : called with (bootstrap refits done, bootstrap) as they finish.
    """
    if not runs:
        raise FitError("no runs to fit")
    series = windows(runs, FIT_EDGE_MARGINS_S)
    chosen = parse_terms(terms)
    fixed = dict(fixed or {})
    for name in fixed:
        if name not in COEFFICIENTS:
            raise FitError(f"--fix {name}: unknown coefficient; coefficients: {', '.join(COEFFICIENTS)}")
    off = {COEFFICIENT_OF[t]: 0.0 for t in TERMS if t not in chosen}
    held = {**off, **{k: v for k, v in fixed.items() if k not in off}}
    varying = tuple(c for c in COEFFICIENTS if c not in held)
    if not varying:
        raise FitError("every coefficient is fixed or switched off: nothing to fit")
    p = _problem(series, varying, held)
    n_params = len(varying)
    if len(p.y) <= n_params:
        raise FitError(f"only {len(p.y)} samples in the analysis windows for {n_params} coefficients")
    values = _fit_values(p)

    model = p.X @ values + p.fixed_part
    resid = p.y - model
    per_run_eff = [effective_samples(resid[p.run_index == i]) for i in range(len(series))]
    n_eff = float(sum(per_run_eff))
    # Weighted normal equations; correlated residuals inflate the variance by n / n_eff.
    A = p.X * p.weights[:, None]
    rw = resid * p.weights
    dof = max(len(p.y) - n_params, 1)
    sigma2 = float(rw @ rw) / dof
    try:
        cov = np.linalg.pinv(A.T @ A) * sigma2 * (len(p.y) / n_eff)
    except np.linalg.LinAlgError:  # pragma: no cover - pinv does not raise for finite input
        cov = np.full((n_params, n_params), np.nan)
    stderr = np.sqrt(np.maximum(np.diag(cov), 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(stderr, stderr)

    boot = None
    if bootstrap and len(series) >= 3:
        blocks = [max(1, int(np.ceil(BLOCK_CORRELATION_TIMES * np.sum(p.run_index == i) / e)))
                  for i, e in enumerate(per_run_eff)]
        rng = np.random.default_rng(seed)
        draws = []
        for k in range(bootstrap):
            draws.append(_fit_values(p, _resampled_rows(p.run_index, blocks, rng)))
            if progress is not None and (k % 10 == 9 or k == bootstrap - 1):
                progress(k + 1, bootstrap)
        boot = np.percentile(np.array(draws), [2.5, 97.5], axis=0)

    coefficients: dict[str, Coefficient] = {}
    for name in COEFFICIENTS:
        if name in varying:
            k = varying.index(name)
            ci = (float(values[k] - 1.96 * stderr[k]), float(values[k] + 1.96 * stderr[k]))
            bci = (float(boot[0, k]), float(boot[1, k])) if boot is not None else None
            coefficients[name] = Coefficient(name, float(values[k]), float(stderr[k]), ci, bci, True)
        else:
            coefficients[name] = Coefficient(name, float(held[name]), None, None, None, False)

    runs = []
    for i, s in enumerate(series):
        sel = p.run_index == i
        r = resid[sel]
        meas = p.y[sel]
        rms = float(np.sqrt(np.mean(r ** 2)))
        peak = float(np.max(meas))
        ss_tot = float(np.sum((meas - meas.mean()) ** 2))
        runs.append(RunFit(s.run_id, int(sel.sum()), rms, rms / peak if peak > 0 else float("nan"),
                           1 - float(np.sum(r ** 2)) / ss_tot if ss_tot > 0 else float("nan"), peak,
                           s.penetration_time_s))

    loro = None
    if leave_one_out and len(series) >= 2:
        scores = []
        for i in range(len(series)):
            keep = p.run_index != i
            v = _fit_values(p, keep)
            left = ~keep
            r = p.y[left] - (p.X[left] @ v + p.fixed_part[left])
            scores.append(float(np.sqrt(np.mean(r ** 2))))
        loro = float(np.mean(scores))

    rss_norm = float(rw @ rw) / float(np.sum(p.weights ** 2))  # mean squared residual, runs weighted equally
    n_ic = n_effective or n_eff
    aic = n_ic * np.log(rss_norm) + 2 * n_params
    bic = n_ic * np.log(rss_norm) + n_params * np.log(n_ic)
    warnings = determinacy_warnings(coefficients, varying, corr, len(series))
    return FitResult(material, "resistance", chosen, coefficients, corr, varying, tuple(runs), len(p.y), n_eff,
                     float(aic), float(bic), loro, ranges_of(series), tuple(warnings), True, "", held,
                     tuple(1e3 * m for m in FIT_EDGE_MARGINS_S))


def determinacy_warnings(coefficients: Mapping[str, Coefficient], varying: Sequence[str], corr: np.ndarray,
                         n_runs: int) -> list[str]:
    """Name coefficients the runs do not determine, and the run that would."""
    warnings = []
    for i, a in enumerate(varying):
        for j in range(i + 1, len(varying)):
            b = varying[j]
            if np.isfinite(corr[i, j]) and abs(corr[i, j]) > 0.9:
                advice = SEPARATE.get(frozenset({a, b}), "add runs that vary speed, depth and blade thickness")
                warnings.append(f"{a} and {b} are not separately determined (correlation {corr[i, j]:+.2f}): {advice}")
    for name in varying:
        c = coefficients[name]
        if c.stderr is None or not np.isfinite(c.stderr):
            warnings.append(f"{name} is not determined by these runs")
        elif c.stderr > 0.5 * abs(c.value) and c.stderr > 0.05 * TYPICAL[name]:
            relative = f"relative error {c.stderr / abs(c.value):.0%}" if c.value else "at its bound of 0"
            warnings.append(f"{name} = {c.value:.4g} ± {c.stderr:.2g} is poorly determined ({relative})")
    if n_runs == 1:
        warnings.append("single-run fit: the coefficients describe this run; fit several runs of different blades "
                        "and speeds before trusting them elsewhere")
    return warnings


def all_subsets(runs: Sequence[Run], material: str, *, terms: Iterable[str] | str | None = None,
                fixed: Mapping[str, float] | None = None) -> list[FitResult]:
    """BAM's table: the fit for every non-empty combination of the enabled terms (resistance mode).

    AIC and BIC share the effective sample count of the fit with every enabled
    term, so they compare models on the same data.
    """
    chosen = parse_terms(terms)
    series = windows(runs, FIT_EDGE_MARGINS_S)
    full = fit_resistance(series, material, terms=chosen, fixed=fixed, bootstrap=0, leave_one_out=False)
    out = []
    for k in range(1, len(chosen) + 1):
        for subset in itertools.combinations(chosen, k):
            held = {n: v for n, v in (fixed or {}).items() if TERM_OF[n] in subset}
            if all(COEFFICIENT_OF[t] in held for t in subset):
                continue
            out.append(fit_resistance(series, material, terms=subset, fixed=held, bootstrap=0,
                                      n_effective=full.n_effective))
    return out


def with_coefficients(design: Design, values: Mapping[str, float]) -> Design:
    """``design`` with Eq. 9 coefficients (file units) set."""
    return replace(design, **{coefficient_of(t).si_name: values[COEFFICIENT_OF[t]] * coefficient_of(t).si_scale
                              for t in TERMS})
