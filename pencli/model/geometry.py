r"""What the material resists: the penetrator-geometry seam of the scalar simulator.

A geometry turns a design and a set of switched-on terms into the resistance R(x, v) of the material on
the penetrator, for a tip inside the material (x > 0).  :func:`~pencli.model.dynamics.simulate` asks a
geometry for nothing else (see :class:`Geometry`), so a new one is one class, passed as
``simulate(design, geometry=...)``; pen's own are registered in :data:`GEOMETRIES`.  A shape given by its
areas (:class:`Shape`) and registered with :func:`register_geometry` reaches every command: parameter files,
predict, sweep, the store, the simulated rig, fit and diagnose.

A geometry whose resistance reduces to Eq. 9's form a0 + a1·x + b·v + d·v² returns that
:class:`~pencli.model.resistance.ResistanceLaw` from :meth:`Geometry.law`; the simulator then books each
Eq. 9 term's energy separately and may use the creep rule, and the batch simulator's closed forms apply.
Any other geometry returns ``None`` there and gives its force from :meth:`Geometry.resistance`; its
dissipated energy is integrated with the motion and reported as ``energy_other_j``.

The contract's geometry is :class:`Blade` (paper Eq. 9, :mod:`pencli.model.resistance`).

Every geometry here resists by one law, written once (:func:`shape_resistance`) from three of its
properties at depth x: the frontal area A_f(x) the tip presses and the rate terms act on, the bearing area
B(x) on which the strength acts (A_f times a tip factor, in the convention the shape states), and the side
area S(x) on which the sidewall pressure acts:

.. math::

    R(x, v) = C_s S\, B(x) + \mu P\, S(x) + C\,v\,A_f(x) + K \rho\, v^2 A_f(x) \qquad (x > 0,\ v > 0
    \text{ for the rate terms})

The blade's B = w·T·(sin θ + μ cos θ), S = 2·w·x and A_f = w·T give Eq. 9 (μ·P·2·w·x = w·T·μ·P·2x/T).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Callable, Protocol

from pencli.errors import ModelError
from pencli.model.design import Design
from pencli.model.resistance import (TERMS, ResistanceLaw, coefficient_of, parse_terms, reduced, resistance_law,
                                     unit_terms)
from pencli.params.definitions import Choice, Param, Registration, choices_of, params_of, register_variant
from pencli.params.validate import ParameterSet


class Geometry(Protocol):
    name: str

    def law(self, design: Design, terms: tuple[str, ...]) -> ResistanceLaw | None:
        """Eq. 9's four coefficients when the resistance has that form, else ``None``."""

    def resistance(self, design: Design, terms: tuple[str, ...]) -> Callable[[float, float], float]:
        """R(x [m], v [m/s]) → N for x > 0; ``v`` is already clipped at 0 (the material resists motion into
        it only). Called with floats inside the integrator."""

    def frontal_area_m2(self, design: Design, x: float) -> float:
        """The area the tip presses and the rate terms act on at depth ``x`` > 0. [m²]"""

    def unit_terms(self, design: Design, x, v) -> tuple:
        """The four terms of the resistance at one file unit of each coefficient (Cs, P, C, K), at depths ``x``
        [m] and speeds ``v`` [m/s] (arrays): the columns a linear fit of the coefficients multiplies; their
        sum weighted by the coefficients is :meth:`resistance`. [N per file unit]"""

    # optional: ``corners_m(design) -> tuple[float, ...]``, read through :func:`corner_depths_m`


@dataclass(frozen=True)
class Blade:
    """CONTRACT §2's rectangular blade: Eq. 9 with the design's coefficients."""

    name: str = "blade"

    def law(self, design: Design, terms: tuple[str, ...]) -> ResistanceLaw:
        return resistance_law(design, terms)

    def resistance(self, design: Design, terms: tuple[str, ...]) -> Callable[[float, float], float]:
        law = resistance_law(design, terms)
        a0, a1, b, d = law.strength_n, law.friction_n_m, law.damping_n_s_m, law.inertia_n_s2_m2
        return lambda x, v: reduced(x, v, a0, a1, b, d)

    def frontal_area_m2(self, design: Design, x: float) -> float:
        return design.frontal_area_m2

    def unit_terms(self, design: Design, x, v) -> tuple:
        return unit_terms(design, x, v)


BLADE = Blade()
"""The contract's geometry, the default of every simulation."""


def shape_resistance(x: float, v: float, frontal_m2: float, bearing_m2: float, side_m2: float, design: Design,
                     terms: tuple[str, ...]) -> float:
    """R = Cs·S·B + μ·P·S_side + C·v·A_f + K·ρ·v²·A_f for a tip at depth ``x`` > 0 [m], speed ``v`` [m/s]
    (clipped at 0 here), with the shape's frontal, bearing and side areas at that depth [m²] and the
    material of ``design``; 0 above the surface. Only ``terms`` are on. [N]"""
    if x <= 0.0:
        return 0.0
    vp = v if v > 0.0 else 0.0
    out = 0.0
    if "strength" in terms:
        out += design.strength_factor * design.strength_pa * bearing_m2
    if "friction" in terms:
        out += design.friction_coefficient * design.sidewall_pressure_pa * side_m2
    if "damping" in terms:
        out += design.damping_pa_s_m * vp * frontal_m2
    if "inertia" in terms:
        out += design.inertia_coefficient * design.density_kg_m3 * vp * vp * frontal_m2
    return out


def shape_unit_terms(areas: Callable[[float], tuple[float, float, float]], design: Design, x, v) -> tuple:
    """:func:`shape_resistance`'s four terms at one file unit of each coefficient (Cs, P, C, K; as
    :func:`pencli.model.resistance.unit_terms` gives the blade's), from a shape's ``areas(x)`` → (frontal,
    bearing, side) [m²] evaluated at each depth of ``x`` [m]; ``v`` [m/s].  0 outside the material, and the
    rate terms 0 where ``v`` ≤ 0. [N per file unit]"""
    import numpy as np

    x, v = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(v, dtype=float))
    frontal, bearing, side = (np.asarray(a, dtype=float) for a in np.vectorize(areas, otypes=[float] * 3)(x))
    inside, moving = x > 0.0, (x > 0.0) & (v > 0.0)
    unit = {term: coefficient_of(term).si_scale for term in TERMS}  # one file unit of each coefficient, SI
    return (np.where(inside, unit["strength"] * design.strength_pa * bearing, 0.0),
            np.where(inside, unit["friction"] * design.friction_coefficient * side, 0.0),
            np.where(moving, unit["damping"] * v * frontal, 0.0),
            np.where(moving, unit["inertia"] * design.density_kg_m3 * v * v * frontal, 0.0))


def _tip_factor(angle_rad: float, mu: float) -> float:
    """Eq. 1's sin θ + μ·cos θ: the strength's push on a face at θ from the vertical, with friction on it, per
    unit of its projected area. [–]"""
    return math.sin(angle_rad) + mu * math.cos(angle_rad)


class Shape:
    """A geometry given by its areas alone: subclass it, write :meth:`areas`, register it
    (:func:`register_geometry`).  The resistance, its linear columns and the frontal area follow from the one
    law, :func:`shape_resistance`; its resistance is not Eq. 9's form (:meth:`law` is ``None``)."""

    name: str = "shape"

    def areas(self, design: Design, x: float) -> tuple[float, float, float]:
        """(frontal A_f, bearing B, side S) at depth ``x`` > 0 [m]: the area the rate terms act on, the one the
        strength acts on (A_f times the tip's factor, with ``design``'s friction coefficient where the
        convention has one), the one the sidewall pressure acts on. [m²]"""
        raise NotImplementedError

    def law(self, design: Design, terms: tuple[str, ...]) -> None:
        return None

    def resistance(self, design: Design, terms: tuple[str, ...]) -> Callable[[float, float], float]:
        chosen = parse_terms(terms)

        def r(x: float, v: float) -> float:
            return shape_resistance(x, v, *self.areas(design, x), design, chosen) if x > 0.0 else 0.0
        return r

    def frontal_area_m2(self, design: Design, x: float) -> float:
        return self.areas(design, x)[0]

    def unit_terms(self, design: Design, x, v) -> tuple:
        return shape_unit_terms(lambda depth: self.areas(design, depth), design, x, v)

    def corners_m(self, design: Design) -> tuple[float, ...]:
        """Depths where an area's slope jumps, so that the resistance has a corner there (none unless the shape
        says so; :func:`corner_depths_m`). [m]"""
        return ()


@dataclass(frozen=True)
class Cone(Shape):
    """A cone tip on a cylindrical shaft, axis along the motion (a penetrometer's cone).

    The tip is a cone of half-angle α, blunted to a flat of radius ``tip_radius_m`` (0: sharp), that widens to
    the shaft's radius r_s over L_c = (r_s − r_t)/tan α; the shaft follows.  At depth x the radius in the
    material is r(x) = min(r_t + x·tan α, r_s) and the frontal area A_f = π·r².  The sidewall pressure acts on
    the shaft in the material, S = 2π·r_s·max(x − L_c, 0): the cone's face carries the strength.

    ``area`` is the convention for the strength on the cone's face:

    - ``projected``: Eq. 1's blade convention on the frontal area, B = A_f·(sin α + μ·cos α), with α taking
      the blade's θ (for a blade's wedge, the same law);
    - ``mantle``: the strength is a pressure normal to the face, with friction μ along it, so its axial push is
      (sin α + μ·cos α) per unit of face area, and the face (A_f − π·r_t²)/sin α: B = π·r_t² + (A_f − π·r_t²)·
      (1 + μ/tan α).  The flat presses with the strength alone.
    """

    half_angle_rad: float
    shaft_radius_m: float
    tip_radius_m: float = 0.0
    area: str = "projected"
    name: str = "cone"

    def __post_init__(self):
        if not 0.0 < self.half_angle_rad < math.pi / 2:
            raise ModelError(f"cone half-angle {math.degrees(self.half_angle_rad):g}°: expected between 0 and 90°")
        if not 0.0 <= self.tip_radius_m < self.shaft_radius_m:
            raise ModelError(f"cone tip radius {self.tip_radius_m * 1e3:g} mm: expected from 0 to below the shaft "
                             f"radius ({self.shaft_radius_m * 1e3:g} mm)")
        if self.area not in CONE_AREAS:
            raise ModelError(f"cone area convention {self.area!r}: expected one of {', '.join(CONE_AREAS)}")

    @property
    def cone_length_m(self) -> float:
        """L_c, depth at which the shaft enters the material. [m]"""
        return (self.shaft_radius_m - self.tip_radius_m) / math.tan(self.half_angle_rad)

    def areas(self, design: Design, x: float) -> tuple[float, float, float]:
        return self.section_areas(x, design.friction_coefficient)

    def corners_m(self, design: Design) -> tuple[float, ...]:
        """The shoulder, L_c: the frontal area stops growing and the shaft's side area starts. [m]"""
        return (self.cone_length_m,)

    def frontal_area_m2(self, design: Design | None, x: float) -> float:
        """π·min(r_t + x·tan α, r_s)²: the cone's alone (no design's friction enters it). [m²]"""
        return self.section_areas(x, 0.0)[0]

    def section_areas(self, x: float, mu: float) -> tuple[float, float, float]:
        """(frontal A_f, bearing B, side S) at depth ``x`` [m] for friction coefficient ``mu``. [m²]"""
        a, rt, rs = self.half_angle_rad, self.tip_radius_m, self.shaft_radius_m
        r = min(rt + x * math.tan(a), rs)
        frontal = math.pi * r * r
        flat = math.pi * rt * rt
        if self.area == "projected":
            bearing = frontal * _tip_factor(a, mu)
        else:
            bearing = flat + (frontal - flat) * (1.0 + mu / math.tan(a))
        return frontal, bearing, 2.0 * math.pi * rs * max(x - self.cone_length_m, 0.0)


CONE_AREAS = ("projected", "mantle")
"""The conventions for the strength on a cone's face (:class:`Cone`)."""


@dataclass(frozen=True)
class TaperedBlade(Shape):
    """A blade whose thickness grows from ``tip_thickness_m`` at the tip to the design's T over
    ``taper_length_m`` (a sharpened or wedge-ended plate); width w and tip angle θ as the design's.

    A_f(x) = w·T(x), T(x) = min(T_tip + (T − T_tip)·x/L_t, T); B = A_f·(sin θ + μ·cos θ); S = 2·w·x (both faces,
    as Eq. 9's).  Past the taper it is Eq. 9's blade."""

    tip_thickness_m: float
    taper_length_m: float
    name: str = "tapered_blade"

    def __post_init__(self):
        if self.tip_thickness_m < 0.0 or self.taper_length_m <= 0.0:
            raise ModelError(f"tapered blade: tip thickness {self.tip_thickness_m * 1e3:g} mm (expected ≥ 0) and "
                             f"taper length {self.taper_length_m * 1e3:g} mm (expected > 0)")

    def areas(self, design: Design, x: float) -> tuple[float, float, float]:
        """(frontal, bearing, side) at depth ``x`` [m]. [m²]"""
        t = design.blade_thickness_m
        thickness = min(self.tip_thickness_m + (t - self.tip_thickness_m) * x / self.taper_length_m, t)
        frontal = design.blade_width_m * thickness
        return (frontal, frontal * _tip_factor(design.tip_angle_rad, design.friction_coefficient),
                2.0 * design.blade_width_m * x)

    def corners_m(self, design: Design) -> tuple[float, ...]:
        """The taper's end: the frontal area stops growing. [m]"""
        return (self.taper_length_m,)


GEOMETRIES = {"blade": Blade, "cone": Cone, "tapered_blade": TaperedBlade}
"""Every geometry by the name a parameter file's ``geometry:`` gives it; its constructor's keywords are the SI
names of the parameters that build it (``builds="geometry"`` in :data:`pencli.params.definitions.PARAMETERS`,
and the named choices' ``si_name``).  More are added by :func:`register_geometry`."""


@dataclass(frozen=True)
class GeometryRegistration:
    """What :func:`register_geometry` added; :meth:`undo` takes it out (also as a context manager)."""

    name: str
    keys: Registration

    def undo(self) -> None:
        GEOMETRIES.pop(self.name, None)
        self.keys.undo()

    def __enter__(self) -> "GeometryRegistration":
        return self

    def __exit__(self, *exc) -> None:
        self.undo()


def register_geometry(cls: type, help: str, params: tuple[Param, ...] = (), choices: tuple[Choice, ...] = ()
                      ) -> GeometryRegistration:
    """Make a geometry available to every command: a penetrator file's ``geometry: <cls.name>`` then validates
    with ``params`` (and ``choices``) as its keys, and predict, sweep, the store, the simulated rig, fit and
    diagnose use it.  ``cls`` is a :class:`Shape` (or any :class:`Geometry`) whose constructor takes the
    ``si_name`` of each parameter with ``builds="geometry"``; ``help`` is one line on it.  A new geometry is its
    module plus this one call::

        register_geometry(Wedge, "a blade whose width grows from its tip", params=(Param(...), ...))
    """
    name = cls.name
    if name in GEOMETRIES:
        raise ValueError(f"a geometry named {name!r} is already registered")
    keys = register_variant("penetrator", name, help, params, choices)
    GEOMETRIES[name] = cls
    return GeometryRegistration(name, keys)


def force_steps_at_contact(geometry: Geometry, design: Design) -> bool:
    """Whether the resistance jumps when the tip meets the material (a blade's edge, a blunt cone's flat), so that
    the force's onset marks the contact; a sharp tip's rises from nothing, and its onset lags the contact by
    however deep the tip goes before the force clears the noise."""
    return geometry.frontal_area_m2(design, 0.0) > 0.0


def corner_depths_m(geometry: Geometry, design: Design) -> tuple[float, ...]:
    """Depths where the geometry's resistance has a corner (an area's slope jumps: a cone's shoulder, a taper's
    end), sorted; none for Eq. 9's blade or a geometry that declares none.  The acceleration's slope jumps where
    the tip passes one, which the inertia stage's derivatives join at
    (:func:`pencli.filter.inertia.corner_times`). [m]"""
    corners = getattr(geometry, "corners_m", None)
    return tuple(sorted(float(c) for c in corners(design) if c > 0.0)) if corners else ()


EMBEDDED_NODES = 8
"""Gauss–Legendre nodes per piece between a geometry's corners in :func:`embedded_volume_m3`: exact for areas
polynomial in depth up to degree 15 (a cone's is 2, its embedded volume 3). [–]"""


def embedded_volume_m3(geometry: Geometry, design: Design, x: float) -> float:
    """V(x) = ∫₀ˣ A_f(s) ds: the volume of the body below the bed's surface when its tip is ``x`` [m] deep (the
    frontal area at depth s is the body's section s above its tip).  Gauss–Legendre on the pieces between the
    geometry's corners (:func:`corner_depths_m`). [m³]"""
    return _piecewise_integral(lambda s: geometry.frontal_area_m2(design, s), 0.0, x,
                               corner_depths_m(geometry, design))


def embedded_volume_integral_m4(geometry: Geometry, design: Design, x0: float, x1: float) -> float:
    """∫ V(s) ds over [x0, x1] (depths ≥ 0): what a force proportional to the embedded volume does over that
    travel, per unit of its factor (:func:`embedded_volume_m3`). [m⁴]"""
    corners = corner_depths_m(geometry, design)
    return _piecewise_integral(lambda s: embedded_volume_m3(geometry, design, s), max(x0, 0.0), max(x1, 0.0),
                               corners)


def _piecewise_integral(f: Callable[[float], float], a: float, b: float, corners: tuple[float, ...]) -> float:
    """∫ f over [a, b], Gauss–Legendre (:data:`EMBEDDED_NODES`) on each piece between ``corners``."""
    if b <= a:
        return 0.0
    nodes, weights = _gauss_legendre(EMBEDDED_NODES)
    edges = [a, *(c for c in corners if a < c < b), b]
    total = 0.0
    for lo, hi in zip(edges[:-1], edges[1:]):
        half, mid = 0.5 * (hi - lo), 0.5 * (hi + lo)
        total += half * sum(w * f(mid + half * n) for n, w in zip(nodes, weights))
    return total


@lru_cache(maxsize=None)
def _gauss_legendre(n: int) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """(nodes, weights) of the n-point Gauss–Legendre rule on [−1, 1] (numpy imported here, not at the CLI's
    start)."""
    import numpy as np

    nodes, weights = np.polynomial.legendre.leggauss(n)
    return tuple(map(float, nodes)), tuple(map(float, weights))


def geometry_of(penetrator: ParameterSet) -> Geometry:
    """The geometry a penetrator file names, built from its keys (SI, by each definition's scale)."""
    name = penetrator.geometry
    kwargs: dict = {p.si_name: float(penetrator.values[p.key]) * p.si_scale
                    for p in params_of("penetrator", name) if p.builds == "geometry" and p.key in penetrator.values}
    kwargs.update({c.si_name: penetrator.choice(c.key) for c in choices_of("penetrator", name) if c.si_name})
    try:
        return GEOMETRIES[name](**kwargs)
    except ModelError as exc:
        raise ModelError(f"{penetrator.source}: {exc}") from None


__all__ = ["BLADE", "Blade", "CONE_AREAS", "Cone", "GEOMETRIES", "Geometry", "GeometryRegistration", "Shape",
           "TaperedBlade", "force_steps_at_contact", "geometry_of", "register_geometry",
           "shape_resistance", "shape_unit_terms"]
