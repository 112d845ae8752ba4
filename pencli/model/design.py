"""A complete design (blade, material, launcher) in SI units.

The CLI and files speak the units of CONTRACT §1 (mm, kPa, %); the core
speaks SI.  :func:`design_from_sets` is the one place the conversion
happens, using ``si_name`` and ``si_scale`` of each parameter definition.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from pencli.lazy import lazy

from pencli.params.definitions import PARAMETERS
from pencli.params.validate import ParameterSet

np = lazy("numpy")  # imported on first use: `pen --help` does not load numpy


@dataclass(frozen=True)
class Design:
    """Every parameter of the three kinds, SI.

    The batch simulator builds one whose fields are equal-length numpy arrays (one design per element);
    the properties below are written to work on either.

    Coefficients a material file does not give are ``nan``; the simulator
    refuses to use a term whose coefficient is ``nan``.
    """

    blade_width_m: float
    """w, rectangular blade width. [m]"""
    blade_thickness_m: float
    """T, blade thickness. [m]"""
    tip_angle_rad: float
    """θ, leading-edge angle from vertical (π/2 = flat edge). [rad]"""
    penetration_depth_m: float
    """Full penetration depth (hard stops). [m]"""
    sprung_mass_kg: float
    """Accelerated body, blade included. [kg]"""
    load_cell_mass_kg: float
    """Blade + mount below the force sensor. [kg]"""
    density_kg_m3: float
    """ρ, bulk density. [kg/m³]"""
    strength_pa: float
    """S, microstructure strength. [Pa]"""
    friction_coefficient: float
    """μ, blade–material friction coefficient. [–]"""
    gravity_m_s2: float
    """g, gravitational acceleration along the penetration axis. [m/s²]"""
    strength_factor: float
    """Cs, S correction factor. [–]"""
    sidewall_pressure_pa: float
    """P, sidewall pressure. [Pa]"""
    damping_pa_s_m: float
    """C, damping per unit area. [Pa·s/m]"""
    inertia_coefficient: float
    """K, inertia coefficient. [–]"""
    spring_count: int
    """n, number of parallel springs. [–]"""
    spring_stiffness_n_m: float
    """k, stiffness per spring. [N/m]"""
    spring_mass_kg: float
    """Mass per spring. [kg]"""
    nominal_length_m: float
    """L0, spring free length. [m]"""
    compressed_length_m: float
    """Lc, spring length at release. [m]"""
    surface_offset_m: float
    """s0, blade tip to surface at release. [m]"""
    efficiency: float
    """η, propulsion efficiency as a fraction. [–]"""

    @property
    def effective_mass_kg(self) -> float:
        """m_eff = sprung mass + n·spring mass / 3 (CONTRACT §2). [kg]"""
        return self.sprung_mass_kg + self.spring_count * self.spring_mass_kg / 3.0

    @property
    def drive_stiffness_n_m(self) -> float:
        """η·n·k, the effective stiffness of the launcher. [N/m]"""
        return self.efficiency * self.spring_count * self.spring_stiffness_n_m

    @property
    def stroke_m(self) -> float:
        """max(L0 − Lc, 0), travel from release until the springs reach free length (0: springs not
        compressed at release, a gravity drop). [m]"""
        return np.maximum(self.nominal_length_m - self.compressed_length_m, 0.0)

    @property
    def frontal_area_m2(self) -> float:
        """w·T, projected frontal area of the blade. [m²]"""
        return self.blade_width_m * self.blade_thickness_m

    def stored_energy_j(self) -> float:
        """η·n·k·(L0 − Lc)²/2, what the launcher can deliver over its stroke. [J]"""
        return 0.5 * self.drive_stiffness_n_m * self.stroke_m ** 2


CREEP_DISTANCE_M = 1e-6
"""δ: a run that creeps towards its rest depth (overdamped there) ends when its tip comes this close, on
the slow mode; both simulators use this rule (docs/guide/sweeps.md, "Creep"). [m]"""

def creep_point(m, kd, xk, mg, a0, a1, b, depth):
    """(x* − δ [m], speed limit ω0·δ [m/s], x* [m], k [N/m]) of a design that can creep, else four nans.

    The rest depth x* is where drive and weight equal strength and friction,
    kd·max(xk − x, 0) + mg = a0 + a1·x (``xk``: depth where the springs reach free length).  With damping
    heavy enough that the motion is overdamped there (b² ≥ 4·m·k, k = the force's slope at x*), the tip
    approaches x* along the slow mode and never reaches it: the penetration time is then *defined* as the
    moment the tip comes within :data:`CREEP_DISTANCE_M` (δ) of x* at a speed at most ω0·δ (ω0 = √(k/m);
    a faster approach is on the fast mode and overshoots x*, then arrests).  The final depth is x*.
    Plain arithmetic on floats: both simulators use this one rule (the batch's compiled kernel as it is).
    """
    nothing = (math.nan, math.nan, math.nan, math.nan)
    if not b > 0.0:
        return nothing
    if xk > 0.0 and mg - a0 - a1 * xk <= 0.0:
        k = kd + a1
        rest = (kd * xk + mg - a0) / k
    elif a1 > 0.0:
        k = a1
        rest = (mg - a0) / a1
    else:
        return nothing
    if not (CREEP_DISTANCE_M < rest < depth) or b * b < 4.0 * m * k:
        return nothing
    return rest - CREEP_DISTANCE_M, math.sqrt(k / m) * CREEP_DISTANCE_M * (1.0 + 1e-9), rest, k


NEAR_CRITICAL_OVERSHOOT = 1e-12
"""An arrest whose overshoot of the rest depth is below this share of its approach, exp(−πζ/√(1 − ζ²)) for a
damping ratio ζ < 1 there, is a time float64 cannot give: the tip passes x* by less than the integrators
resolve (10⁻¹³ m on a 0.1 m approach), so when its speed first reaches 0 is round-off (ζ > 0.9936; at
ζ = 0.999 three integrators gave 0.62, 0.68 and 0.75 s for one design, a 45-digit one 1.08 s). [–]"""


def damping_ratio_at_rest(m, kd, xk, mg, a0, a1, b, depth):
    """ζ = b / (2√(m·k)) at the rest depth x* (where drive and weight balance strength and friction, k the net
    force's slope there, as :func:`creep_point` reads them); NaN where x* is not within the penetration depth.
    Floats or arrays (numpy broadcasting). [–]"""
    m, kd, xk, mg, a0, a1, b = (np.asarray(v, dtype=float) for v in (m, kd, xk, mg, a0, a1, b))
    pushing = (xk > 0.0) & (mg - a0 - a1 * xk <= 0.0)  # the springs still push at x*
    k = np.where(pushing, kd + a1, a1)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # no rest depth: inf or nan, dropped
        rest = np.where(pushing, (kd * xk + mg - a0) / k, (mg - a0) / a1)
        zeta = b / (2.0 * np.sqrt(m * k))
    return np.where((k > 0.0) & (rest > 0.0) & (rest < depth), zeta, np.nan)


def near_critical(m, kd, xk, mg, a0, a1, b, depth):
    """Whether a design's arrest at its rest depth is round-off (:data:`NEAR_CRITICAL_OVERSHOOT`): the motion
    there is underdamped (:func:`damping_ratio_at_rest` ζ < 1) by so little that it overshoots x* by less than
    that share of its approach.  Floats or arrays; False where there is no such rest depth."""
    zeta = damping_ratio_at_rest(m, kd, xk, mg, a0, a1, b, depth)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        overshoot = np.exp(-np.pi * zeta / np.sqrt(np.maximum(1.0 - zeta * zeta, 0.0)))
    return (zeta < 1.0) & (overshoot < NEAR_CRITICAL_OVERSHOOT)


def creep_time_constant(m, b, k):
    """The slow mode's time constant at the rest depth, τ = 2m / (b − √(b² − 4mk)): on it the distance left to
    x* falls e-fold every τ, so a creep's penetration time (to within :data:`CREEP_DISTANCE_M`) grows by
    τ·ln 10 for each tenfold-closer end.  ``m`` [kg], ``b`` the damping force per speed [N·s/m], ``k`` the
    net force's slope at x* [N/m] (overdamped: b² ≥ 4mk). [s]"""
    return 2.0 * m / (b - math.sqrt(max(b * b - 4.0 * m * k, 0.0)))


def static_work(x0, x1, xk, kd, mg, a0, a1):
    """∫ F dx from depth x0 to x1 of the force that does not depend on speed, F = kd·max(xk − x, 0) + mg −
    a0 − a1·x (drive while the springs push, weight, Eq. 9's strength and friction).  ``xk``: depth where
    the springs reach free length.  Floats or arrays. [J]"""
    spring = 0.5 * kd * (np.maximum(xk - x0, 0.0) ** 2 - np.maximum(xk - x1, 0.0) ** 2)
    return spring + (mg - a0) * (x1 - x0) - 0.5 * a1 * (x1 * x1 - x0 * x0)


FORCE_LIMIT_N = 1e30
"""Forces beyond this are outside what float64 integrates meaningfully. [N]"""


FORCE_NAMES = ("strength", "friction", "damping", "inertia", "drive", "weight")
"""The forces :func:`force_sizes` gives, in its order."""


def force_sizes(a0, a1, b, d, speed, depth, drive_stiffness, stroke, effective_mass, gravity) -> tuple:
    """The largest size of each force of the model (:data:`FORCE_NAMES`: Eq. 9 at full depth and the contact
    speed, the drive at release, the weight), to compare with :data:`FORCE_LIMIT_N`.  Plain arithmetic on
    floats or arrays, so the batch's compiled kernel uses it as it is. [N]"""
    return (a0, a1 * depth, b * speed, d * speed * speed, drive_stiffness * stroke, effective_mass * gravity)


def force_scales(design: Design, a0, a1, b, d, speed) -> dict:
    """:func:`force_sizes` of ``design`` by name.  ``a0…d``: Eq. 9's coefficients; floats, or arrays for the
    batch's designs. [N]"""
    return dict(zip(FORCE_NAMES, force_sizes(a0, a1, b, d, speed, design.penetration_depth_m,
                                             design.drive_stiffness_n_m, design.stroke_m,
                                             design.effective_mass_kg, design.gravity_m_s2)))


def beyond_limit(force):
    """True where a force (float or array) is not finite or exceeds :data:`FORCE_LIMIT_N` in size (nan
    compares false, so it is beyond too)."""
    return np.logical_not(np.abs(force) <= FORCE_LIMIT_N)


DESIGN_FIELDS: tuple[str, ...] = tuple(f.name for f in fields(Design))


def design_from_sets(penetrator: ParameterSet, material: ParameterSet, energizing: ParameterSet) -> Design:
    """Build an SI :class:`Design` from three validated parameter sets."""
    by_kind = {"penetrator": penetrator, "material": material, "energizing": energizing}
    values: dict[str, float] = {}
    for param in PARAMETERS:
        if not param.si_name or param.builds != "design":  # an alternative input (EITHER_OR), whose primary
            continue  # carries the value, or a geometry's dimension (pencli.model.geometry.geometry_of)
        held = by_kind[param.kind]
        raw = held.get(param.key)
        if raw is None and held.variant is not None and not param.belongs_to(held.variant):
            values[param.si_name] = int(param.absent) if param.dtype is int else param.absent  # no springs: 0
        elif raw is None:
            values[param.si_name] = math.nan
        elif param.dtype is int:
            values[param.si_name] = int(raw)
        else:
            values[param.si_name] = float(raw) * param.si_scale
    return Design(**values)
