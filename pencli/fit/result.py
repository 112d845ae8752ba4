"""Result objects of a fit: coefficients with uncertainties, per-run statistics, warnings."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from pencli.model.resistance import TERMS, coefficient_of

COEFFICIENT_OF: dict[str, str] = {term: coefficient_of(term).key.removeprefix("coefficients.") for term in TERMS}
"""Each Eq. 9 term's coefficient, by its CONTRACT §1 name under ``coefficients.`` (from the model core)."""
COEFFICIENTS: tuple[str, ...] = tuple(COEFFICIENT_OF.values())
"""The four Eq. 9 coefficients, in the terms' order."""
TERM_OF: dict[str, str] = {coeff: term for term, coeff in COEFFICIENT_OF.items()}


@dataclass(frozen=True)
class Coefficient:
    """One fitted coefficient (file units: –, kPa, kPa·s/m, –)."""

    name: str
    value: float
    stderr: float | None
    """Standard error from the curvature, inflated for correlated residuals; None when fixed."""
    ci95: tuple[float, float] | None
    bootstrap_ci95: tuple[float, float] | None
    """2.5–97.5 % of refits on runs resampled with replacement."""
    vary: bool
    """False when fixed (``--fix``) or its term is switched off."""

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class RunFit:
    """How well the fit describes one run (over its analysis window)."""

    run_id: str
    n_samples: int
    rms_n: float
    """RMS of measured − modelled resistance. [N]"""
    nrmse: float
    """rms_n over the run's peak measured resistance. [–]"""
    r2: float
    peak_resistance_n: float
    penetration_time_s: float | None = None
    """Measured, contact to stop. [s]"""
    model_penetration_time_s: float | None = None
    """Dynamic mode: the fully predicted run's. [s]"""
    position_rms_mm: float | None = None
    """Dynamic mode: RMS of measured − predicted depth. [mm]"""

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class FitResult:
    """A fit of the Eq. 9 coefficients over runs of one material."""

    material: str
    mode: str
    """``resistance`` or ``dynamic``."""
    terms: tuple[str, ...]
    coefficients: dict[str, Coefficient]
    correlation: np.ndarray
    """Correlation of the varying coefficients, in the order of ``varying``."""
    varying: tuple[str, ...]
    runs: tuple[RunFit, ...]
    n_samples: int
    n_effective: float
    """Samples worth of independent information (residuals at 30 kHz are correlated)."""
    aic: float
    bic: float
    loro_rms_n: float | None
    """Mean leave-one-run-out RMS: fit on the other runs, score on the one left out. [N]"""
    ranges: dict
    """What the fit saw: contact speeds [m/s], depths [mm], blade thicknesses and widths [mm], strengths [kPa]."""
    warnings: tuple[str, ...] = ()
    success: bool = True
    message: str = ""
    fixed: dict = field(default_factory=dict)
    edge_margins_ms: tuple[float, float] | None = None
    """What a resistance fit left out of each run's analysis window after contact and before the stop (less in a
    short run, :func:`pencli.filter.windows.fit_edges`); None for a dynamic fit. [ms]"""

    def values(self) -> dict[str, float]:
        return {name: c.value for name, c in self.coefficients.items()}

    def covariance(self) -> dict[str, dict[str, float]]:
        """The varying coefficients' covariance (file units) from their standard errors and correlation; empty
        when a standard error is not finite."""
        stderr = [self.coefficients[name].stderr for name in self.varying]
        if not stderr or not all(s is not None and math.isfinite(s) for s in stderr):
            return {}
        return {a: {b: float(stderr[i] * stderr[j] * (1.0 if i == j else float(np.nan_to_num(self.correlation[i, j]))))
                    for j, b in enumerate(self.varying)} for i, a in enumerate(self.varying)}

    def to_dict(self) -> dict:
        """The CONTRACT §6 record (material, coefficients, stderr) and everything else."""
        def clean(x):
            if isinstance(x, float) and not math.isfinite(x):
                return None
            return x

        corr = {a: {b: clean(float(self.correlation[i, j])) for j, b in enumerate(self.varying)}
                for i, a in enumerate(self.varying)}
        return {
            "material": self.material,
            "mode": self.mode,
            "terms": list(self.terms),
            "coefficients": {n: c.value for n, c in self.coefficients.items()},
            "stderr": {n: clean(c.stderr) if c.stderr is not None else None for n, c in self.coefficients.items()},
            "ci95": {n: list(c.ci95) if c.ci95 else None for n, c in self.coefficients.items()},
            "bootstrap_ci95": {n: list(c.bootstrap_ci95) if c.bootstrap_ci95 else None
                               for n, c in self.coefficients.items()},
            "fixed": dict(self.fixed),
            "edge_margins_ms": list(self.edge_margins_ms) if self.edge_margins_ms is not None else None,
            "correlation": corr,
            "runs": [r.to_dict() for r in self.runs],
            "n_samples": self.n_samples,
            "n_effective": self.n_effective,
            "aic": self.aic,
            "bic": self.bic,
            "loro_rms_n": self.loro_rms_n,
            "ranges": self.ranges,
            "warnings": list(self.warnings),
            "success": self.success,
            "message": self.message,
        }
