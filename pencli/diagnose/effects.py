r"""The effect catalogue of CONTRACT §4: each unmodelled effect as a registered model extension.

An effect is an extra term of the resistance-mode model (measured x, v and
a drive Eq. 9; the load cell reads R plus what the force chain adds), with
named, bounded parameters.  Parameters that enter linearly are fitted with
the baseline coefficients; the others (a layer's depth, a lag time, a ring
frequency) are searched on a small grid, using training runs only.

Each entry's ``doc`` gives its physics and its residual signature: what the
baseline's misfit looks like when this effect is present and left out.

Adding an effect is one new :class:`Effect` in :data:`EFFECTS`.  All columns
are in newtons per unit of the effect's linear coefficient.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

import numpy as np
from scipy.signal import lfilter

from pencli.model.design import Design

# ----------------------------------------------------------------------------- run data

@dataclass(frozen=True)
class DiagnosisRun:
    """One conditioned run as the diagnosis sees it (SI, whole record)."""

    run_id: str
    design: Design
    time_s: np.ndarray
    depth_m: np.ndarray
    velocity_m_s: np.ndarray
    acceleration_m_s2: np.ndarray
    force_n: np.ndarray
    """Tared axial force F. [N]"""
    resistance_n: np.ndarray
    """F − m_lc·a with the file's load-cell mass. [N]"""
    motion_start_s: float
    contact_s: float
    stop_s: float
    window_start_s: float
    window_end_s: float
    end: str
    contact_speed_m_s: float
    load_cell_mass_kg: float
    noise_n: float
    """Standard deviation of the resistance over the pre-trigger span (sensor noise). [N]"""

    @property
    def rate_hz(self) -> float:
        return (self.time_s.size - 1) / (self.time_s[-1] - self.time_s[0])

    @property
    def flight(self) -> np.ndarray:
        """Free flight: 2 ms after the release to 0.5 ms before contact."""
        return (self.time_s > max(self.motion_start_s, 0.0) + 2e-3) & (self.time_s < self.contact_s - 0.5e-3)

    @property
    def window(self) -> np.ndarray:
        return (self.time_s >= self.window_start_s) & (self.time_s <= self.window_end_s)

    @property
    def context(self) -> np.ndarray:
        """From just before the release to the window end: where filters run."""
        return (self.time_s >= min(self.motion_start_s, 0.0) - 5e-3) & (self.time_s <= self.window_end_s)


@dataclass(frozen=True)
class Basis:
    """Eq. 9 columns of one run over its context span (N per file unit of Cs, P, C, K)."""

    strength: np.ndarray
    friction: np.ndarray
    damping: np.ndarray
    inertia: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    t: np.ndarray
    frontal: np.ndarray | None = None
    """The baseline's frontal force (Cs·strength + C·damping + K·inertia) on this run, once fitted. [N]"""

    def matrix(self) -> np.ndarray:
        return np.column_stack([self.strength, self.friction, self.damping, self.inertia])


def basis_of(run: DiagnosisRun) -> Basis:
    """The four Eq. 9 columns on the run's context span; zero above the surface."""
    c = run.context
    d = run.design
    x, v = run.depth_m[c], np.maximum(run.velocity_m_s[c], 0.0)
    inside = (x > 0) & (run.time_s[c] >= run.contact_s)
    w, T = d.blade_width_m, d.blade_thickness_m
    s = w * T * d.strength_pa * (math.sin(d.tip_angle_rad) + d.friction_coefficient * math.cos(d.tip_angle_rad))
    return Basis(np.where(inside, s, 0.0),  # Eq. 9 strength, per unit Cs
                 np.where(inside, 2 * d.friction_coefficient * 1e3 * w * x, 0.0),  # Eq. 9 friction, per kPa of P
                 np.where(inside, w * T * 1e3 * v, 0.0),  # Eq. 9 damping, per kPa·s/m
                 np.where(inside, w * T * d.density_kg_m3 * v * v, 0.0),  # Eq. 9 inertia, per unit K
                 x, v, run.acceleration_m_s2[c], run.time_s[c])


# ----------------------------------------------------------------------------- the catalogue
Columns = tuple[np.ndarray | None, np.ndarray, np.ndarray]
"""(transformed basis matrix or None, extra columns (n, k), offset to subtract from the data (n,))."""


@dataclass(frozen=True)
class Effect:
    """A registered model extension.

    ``build(run, basis, params)`` returns :data:`Columns` on the run's context
    span.  ``describe(coefficients, params, baseline)`` turns the fitted linear
    coefficients into the effect's named physical parameters (``baseline``:
    the baseline fit's mean strength factor ``cs_mean``, sidewall pressure
    ``p_kpa`` and ``load_cell_mass_kg``).  ``extra(coefficients, params, run)``
    (law effects only) gives the extra resistance f(x [m], v [m/s]) → N for
    the dynamic model.
    """

    name: str
    side: str
    """``law`` (resistance law), ``chain`` (force measurement) or ``drive`` (launcher)."""
    doc: str
    grid: Sequence[Mapping[str, float]]
    build: Callable[[DiagnosisRun, Basis, Mapping[str, float]], Columns] | None
    describe: Callable[[np.ndarray, Mapping[str, float], Mapping[str, float]], dict]
    extra: Callable[[np.ndarray, Mapping[str, float], DiagnosisRun],
                    Callable[[float, float], float]] | None = None


def _no_offset(basis: Basis) -> np.ndarray:
    return np.zeros(basis.t.size)


def _layer(run, b, p):
    step = (b.x >= p["depth_mm"] * 1e-3).astype(float)
    return None, (b.strength * step)[:, None], _no_offset(b)


def _gradient(run, b, p):
    # S·(1 + g1·x + g2·x²): a smooth profile, not only a straight line (which the sidewall term would absorb)
    return None, np.column_stack([b.strength * b.x, b.strength * b.x * b.x]), _no_offset(b)


def _plug(run, b, p):
    # every frontal term scales with the frontal thickness T + g·L·(1 − exp(−x/L)):
    # one column, the baseline's frontal force × L·(1 − exp(−x/L))/T
    frontal = b.frontal if b.frontal is not None else b.strength
    length = p["length_mm"] * 1e-3
    widening = length * -np.expm1(-np.maximum(b.x, 0.0) / length)
    return None, (frontal * widening / run.design.blade_thickness_m)[:, None], _no_offset(b)


def _pressure_growth(run, b, p):
    # P(x) = P·(1 + β x): friction = 2 μ w ∫P = 2 μ w P (x + β x²/2): extra column friction·x/2 (coefficient P·β)
    return None, (b.friction * b.x / 2)[:, None], _no_offset(b)


def _velocity_friction(run, b, p):
    return None, (b.friction * b.v)[:, None], _no_offset(b)


def _rate_strength(run, b, p):
    return None, (b.strength * np.log1p(b.v / p["speed_m_s"]))[:, None], _no_offset(b)


def _mass_error(run, b, p):
    return None, b.a[:, None], _no_offset(b)


def _lag(run, b, p):
    # F_meas = lag(R + m a); R_meas = F_meas − m a = lag(R) + (lag(m a) − m a)
    alpha = math.exp(-1.0 / (p["tau_ms"] * 1e-3 * run.rate_hz))

    def lag(signal):
        return lfilter([1 - alpha], [1, -alpha], signal, axis=0)

    inertia_force = run.load_cell_mass_kg * b.a
    return lag(b.matrix()), np.zeros((b.t.size, 0)), -(lag(inertia_force) - inertia_force)


def _ringing(run, b, p):
    tc = np.maximum(b.t - run.contact_s, 0.0)
    w0 = 2 * math.pi * p["frequency_hz"]
    zeta = p["damping_ratio"]
    wd = w0 * math.sqrt(1 - zeta ** 2)
    env = np.where(b.t > run.contact_s, np.exp(-zeta * w0 * tc), 0.0) * run.contact_speed_m_s
    return None, np.column_stack([env * np.sin(wd * tc), env * np.cos(wd * tc)]), _no_offset(b)


def _drift(run, b, p):
    return None, np.maximum(b.t, 0.0)[:, None], _no_offset(b)


EFFECTS: dict[str, Effect] = {e.name: e for e in (
    Effect("strength_layer", "law",
           "Microstructural strength steps to ratio × S below depth_mm. Signature: the resistance jumps up or down "
           "at one depth in every run, whatever its speed; the misfit is a step in depth.",
           [{"depth_mm": d} for d in np.arange(5.0, 131.0, 2.5)], _layer,
           lambda c, p, base: {"depth_mm": p["depth_mm"], "ratio": 1.0 + float(c[0]) / base["cs_mean"]},
           lambda c, p, run: (lambda x, v, k=float(c[0]) * _strength_n(run), d=p["depth_mm"] * 1e-3:
                              k if x >= d else 0.0)),
    Effect("strength_gradient", "law",
           "Strength varies continuously with depth, S·(1 + g1·x + g2·x²). Signature: a misfit growing smoothly "
           "with depth in proportion to the blade's frontal area (so it differs between thicknesses).",
           [{}], _gradient,
           lambda c, p, base: {"change_per_100mm": (float(c[0]) * 0.1 + float(c[1]) * 0.01) / base["cs_mean"],
                               "g1_per_m": float(c[0]) / base["cs_mean"], "g2_per_m2": float(c[1]) / base["cs_mean"]},
           lambda c, p, run: (lambda x, v, k1=float(c[0]) * _strength_n(run), k2=float(c[1]) * _strength_n(run):
                              k1 * x + k2 * x * x)),
    Effect("plug_growth", "law",
           "A crushed plug widens the effective frontal thickness with depth, saturating: T + g·L·(1 − exp(−x/L)). "
           "Signature: every frontal term grows with depth, early, and more so for thin blades (relative to T).",
           [{"length_mm": L} for L in (10.0, 20.0, 40.0, 80.0, 160.0, 1000.0)], _plug,
           lambda c, p, base: {"growth_mm": float(c[0]) * p["length_mm"], "length_mm": p["length_mm"]},
           None),
    Effect("sidewall_pressure_growth", "law",
           "Sidewall pressure rises with depth, P·(1 + β·x): friction grows faster than x. Signature: a misfit "
           "growing with depth squared, the same for every blade thickness.",
           [{}], _pressure_growth,
           lambda c, p, base: {"beta_per_100mm": float(c[0]) * 0.1 / base["p_kpa"]},
           lambda c, p, run: (lambda x, v, k=float(c[0]) * 2e3 * run.design.friction_coefficient
                              * run.design.blade_width_m: k * x * x / 2)),
    Effect("velocity_friction", "law",
           "Blade–material friction varies with sliding speed, μ·(1 + α·v). Signature: a misfit in proportion to "
           "depth × speed: largest mid-run in fast runs.",
           [{}], _velocity_friction,
           lambda c, p, base: {"alpha_per_m_s": float(c[0]) / base["p_kpa"]},
           lambda c, p, run: (lambda x, v, k=float(c[0]) * 2e3 * run.design.friction_coefficient
                              * run.design.blade_width_m: k * x * v)),
    Effect("rate_strength", "law",
           "Strength rises with penetration rate, S·(1 + a·ln(1 + v/v0)). Signature: the strength misfit is "
           "highest at contact and fades as the blade slows, in proportion to frontal area.",
           [{"speed_m_s": s} for s in (0.5, 2.0, 8.0)], _rate_strength,
           lambda c, p, base: {"coefficient": float(c[0]) / base["cs_mean"], "speed_m_s": p["speed_m_s"]},
           lambda c, p, run: (lambda x, v, k=float(c[0]) * _strength_n(run), s=p["speed_m_s"]:
                              k * math.log1p(v / s))),
    Effect("load_cell_mass_error", "chain",
           "The inertia subtraction used the wrong mass below the load cell. Signature: the 'resistance' follows the "
           "acceleration: non-zero in free flight, jumping at contact.",
           [{}], _mass_error,
           lambda c, p, base: {"delta_kg": float(c[0]), "ratio": 1.0 + float(c[0]) / base["load_cell_mass_kg"]}),
    Effect("sensor_lag", "chain",
           "The force channel lags the true force through a first-order low-pass of tau_ms. Signature: the measured "
           "rise at contact is late and rounded; the misfit is the model's time derivative.",
           [{"tau_ms": t} for t in (0.05, 0.1, 0.15, 0.2, 0.3, 0.45, 0.7, 1.0, 1.5)], _lag,
           lambda c, p, base: {"tau_ms": p["tau_ms"]}),
    Effect("rig_ringing", "chain",
           "A structural resonance is struck at contact. Signature: a decaying oscillation after contact whose "
           "amplitude scales with the contact speed.",
           [{"frequency_hz": f, "damping_ratio": z} for f in np.geomspace(150, 4000, 28) for z in (0.01, 0.03, 0.1)],
           _ringing,
           lambda c, p, base: {"frequency_hz": p["frequency_hz"], "damping_ratio": p["damping_ratio"],
                               "amplitude_n_per_m_s": float(math.hypot(c[0], c[1]))}),
    Effect("force_drift", "chain",
           "The force offset drifts during the run. Signature: a misfit growing with time since the release, in "
           "flight as much as in the material.",
           [{}], _drift,
           lambda c, p, base: {"rate_n_per_s": float(c[0])}),
    Effect("propulsion_loss", "drive",
           "The launcher delivers less energy than modelled (efficiency × (1 − loss)). Signature: measured contact "
           "speeds below the predicted ones; resistance with measured kinematics fits, the fully predicted run "
           "does not.",
           [{}], None, lambda c, p, base: {"loss": float(c[0])}),
)}
"""The catalogue by name (CONTRACT §4)."""


def _strength_n(run: DiagnosisRun) -> float:
    """w·T·S·(sinθ + μ cosθ): the strength term per unit Cs. [N]"""
    d = run.design
    return d.blade_width_m * d.blade_thickness_m * d.strength_pa * (
        math.sin(d.tip_angle_rad) + d.friction_coefficient * math.cos(d.tip_angle_rad))


INDISTINGUISHABLE: dict[frozenset, str] = {
    frozenset({"strength_gradient", "sidewall_pressure_growth"}):
        "runs of another blade thickness: sidewall friction does not scale with T, frontal strength does",
    frozenset({"strength_gradient", "plug_growth"}):
        "runs of another blade thickness: a plug adds a fixed width, a strength gradient scales with T",
    frozenset({"plug_growth", "sidewall_pressure_growth"}):
        "runs of another blade thickness: sidewall friction does not scale with T",
    frozenset({"rate_strength", "velocity_friction"}):
        "runs at other contact speeds into the same depths, and of another blade thickness",
    frozenset({"strength_layer", "strength_gradient"}):
        "runs reaching past the suspected layer depth, at other speeds",
    frozenset({"force_drift", "load_cell_mass_error"}):
        "a longer free flight (more stand-off) or runs with other launcher energies",
    frozenset({"sensor_lag", "rig_ringing"}):
        "runs at other contact speeds (ringing scales with speed, lag with the force's rate of change)",
}
"""Effects that can look alike, and what run separates them."""
