r"""Penetration resistance, paper Eq. 9 with the Table 1 strength factor.

.. math::

    R(x, \dot x) = w T \left( C_s S (\sin\theta + \mu\cos\theta)
                   + \frac{\mu P\, 2x}{T} + C \dot x + K \rho \dot x^2 \right)

for :math:`x > 0` (CONTRACT §2); the rate terms use :math:`\dot x > 0` only;
above the surface :math:`R = 0`.  Each term is a separate pure function so any
subset can be switched on or off, and so energy can be booked per term.

Units: x [m], v [m/s], forces [N].  Every function accepts floats or numpy
arrays (broadcasting).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Iterable

from pencli.lazy import lazy

from pencli.errors import ModelError
from pencli.params.definitions import BY_KEY, PARAMETERS, TERM_COEFFICIENT

np = lazy("numpy")  # imported on first use: `pen --help` does not load numpy

TERMS: tuple[str, ...] = ("strength", "friction", "damping", "inertia")
"""The four Eq. 9 terms, in the paper's order."""


def parse_terms(terms: Iterable[str] | str | None) -> tuple[str, ...]:
    """Normalise a term selection (``None`` = all; a comma list is accepted)."""
    if terms is None:
        return TERMS
    if isinstance(terms, str):
        terms = [t for t in (s.strip() for s in terms.split(",")) if t]
        if not terms:
            raise ModelError(f"no model term given; name one or more of: {', '.join(TERMS)}")
    chosen = tuple(terms)
    unknown = [t for t in chosen if t not in TERMS]
    if unknown:
        raise ModelError(f"unknown model term {unknown[0]!r}; terms are: {', '.join(TERMS)}")
    return tuple(t for t in TERMS if t in chosen)


def strength_term(x, blade_width_m, blade_thickness_m, tip_angle_rad, strength_pa,
                  strength_factor, friction_coefficient):
    r"""Microstructure-strength (tip) resistance. [N]

    .. math:: R_s = w T\, C_s S (\sin\theta + \mu\cos\theta) \quad (x > 0)

    Parameters
    ----------
    x : depth of the tip, positive down. [m]
    blade_width_m : w. [m]
    blade_thickness_m : T. [m]
    tip_angle_rad : θ from vertical. [rad]
    strength_pa : S. [Pa]
    strength_factor : Cs. [–]
    friction_coefficient : μ. [–]
    """
    value = (blade_width_m * blade_thickness_m * strength_factor * strength_pa
             * (np.sin(tip_angle_rad) + friction_coefficient * np.cos(tip_angle_rad)))  # Eq. 9 (Eq. 1)
    return np.where(np.asarray(x) > 0, value, 0.0)


def friction_term(x, blade_width_m, friction_coefficient, sidewall_pressure_pa):
    r"""Sidewall friction. [N]

    .. math:: R_f = w T\, \frac{\mu P\, 2x}{T} = 2 \mu P w x \quad (x > 0)

    Parameters
    ----------
    x : depth. [m]
    blade_width_m : w. [m]
    friction_coefficient : μ. [–]
    sidewall_pressure_pa : P. [Pa]
    """
    x = np.asarray(x, dtype=float)
    return np.where(x > 0, 2.0 * friction_coefficient * sidewall_pressure_pa * blade_width_m * x, 0.0)  # Eq. 9 (Eq. 4)


def damping_term(x, v, blade_width_m, blade_thickness_m, damping_pa_s_m):
    r"""Viscous damping. [N]

    .. math:: R_d = w T\, C \dot x \quad (x > 0,\ \dot x > 0)

    Parameters
    ----------
    x : depth. [m]
    v : speed, down positive. [m/s]
    damping_pa_s_m : C, damping per unit area. [Pa·s/m]
    """
    x = np.asarray(x, dtype=float)
    v = np.asarray(v, dtype=float)
    return np.where((x > 0) & (v > 0), blade_width_m * blade_thickness_m * damping_pa_s_m * v, 0.0)  # Eq. 9 (Eq. 8)


def inertia_term(x, v, blade_width_m, blade_thickness_m, inertia_coefficient, density_kg_m3):
    r"""Inertial (drag) resistance of displaced material. [N]

    .. math:: R_i = w T\, K \rho \dot x^2 \quad (x > 0,\ \dot x > 0)

    Parameters
    ----------
    x : depth. [m]
    v : speed, down positive. [m/s]
    inertia_coefficient : K. [–]
    density_kg_m3 : ρ. [kg/m³]
    """
    x = np.asarray(x, dtype=float)
    v = np.asarray(v, dtype=float)
    return np.where((x > 0) & (v > 0),
                    blade_width_m * blade_thickness_m * inertia_coefficient * density_kg_m3 * v * v, 0.0)  # Eq. 9 (Eq. 7)


@dataclass(frozen=True)
class ResistanceLaw:
    r"""Eq. 9 reduced to four numbers for fast evaluation in contact.

    .. math:: R(x, v) = a_0 + a_1 x + b\,v + d\,v^2 \qquad (x > 0, v > 0)

    Attributes
    ----------
    strength_n : a0, constant tip resistance. [N]
    friction_n_m : a1, sidewall friction per depth. [N/m]
    damping_n_s_m : b, damping per speed. [N·s/m]
    inertia_n_s2_m2 : d, inertial resistance per speed squared. [N·s²/m²]
    """

    strength_n: float
    friction_n_m: float
    damping_n_s_m: float
    inertia_n_s2_m2: float

    def terms_in_contact(self, x, v):
        """The four terms for a tip in the material (x ≥ 0), as arrays. [N]"""
        v_pos = np.maximum(np.asarray(v, dtype=float), 0.0)
        x = np.asarray(x, dtype=float)
        return (np.full_like(x, self.strength_n), self.friction_n_m * x,
                self.damping_n_s_m * v_pos, self.inertia_n_s2_m2 * v_pos * v_pos)


TERM_FUNCTIONS = {"strength": strength_term, "friction": friction_term, "damping": damping_term,
                  "inertia": inertia_term}
"""Each Eq. 9 term's function; its arguments are named after the :class:`~pencli.model.design.Design` fields."""


def reduced(x, vp, a0, a1, b, d):
    """Eq. 9 in contact from its four coefficients (:func:`eq9_coefficients`): a0 + a1·x + (b + d·v)·v, with
    ``vp`` the speed already clipped at 0 (the rate terms act for v > 0 only).  Plain arithmetic, so it
    serves floats in the scalar integrator's right-hand side and arrays in the batch alike. [N]"""
    return a0 + a1 * x + (b + d * vp) * vp


@functools.cache
def _arguments(term: str) -> tuple[str, ...]:
    """The :class:`~pencli.model.design.Design` fields a term function reads (its arguments beyond x, v)."""
    import inspect

    return tuple(a for a in inspect.signature(TERM_FUNCTIONS[term]).parameters if a not in ("x", "v"))


def coefficient_of(term: str):
    """The parameter definition of the coefficient an Eq. 9 term multiplies (its key, unit, SI scale)."""
    return BY_KEY[TERM_COEFFICIENT[term]]


def term_at(term: str, design, x, v, **values):
    """One Eq. 9 term of ``design`` at depth ``x`` [m] and speed ``v`` [m/s], with any of the design's fields
    replaced by ``values`` (SI). [N]"""
    fields = {a: values[a] if a in values else getattr(design, a) for a in _arguments(term)}
    if _takes_speed(term):
        fields["v"] = v
    return TERM_FUNCTIONS[term](x, **fields)


@functools.cache
def _takes_speed(term: str) -> bool:
    import inspect

    return "v" in inspect.signature(TERM_FUNCTIONS[term]).parameters


def unit_terms(design, x, v) -> tuple:
    """The four Eq. 9 terms of ``design``, each at one file unit of its coefficient (Cs = 1, P = 1 kPa,
    C = 1 kPa·s/m, K = 1; from the parameter definitions): the columns that a linear fit of the coefficients,
    in file units, multiplies.  ``x`` [m], ``v`` [m/s] arrays or floats. [N per file unit]"""
    out = []
    for term in TERMS:
        unit = coefficient_of(term)
        out.append(term_at(term, design, x, v, **{unit.si_name: unit.si_scale}))
    return tuple(out)


def term_keys(term: str) -> tuple[str, ...]:
    """The parameter-file keys an Eq. 9 term depends on, read from its function's arguments."""
    arguments = _arguments(term)
    return tuple(p.key for p in PARAMETERS if p.si_name and p.si_name in arguments)


def resistance_law(design, terms: Iterable[str] | None = None) -> ResistanceLaw:
    """Eq. 9 coefficients of ``design`` with only ``terms`` switched on.

    Raises
    ------
    ModelError
        A switched-on term whose coefficient the material does not give.
    """
    chosen = parse_terms(terms)
    for term in chosen:
        coefficient = coefficient_of(term)
        if not math.isfinite(getattr(design, coefficient.si_name)):
            key = coefficient.key
            raise ModelError(
                f"the material gives no {key}, needed by the {term} term; fit it (pen fit), "
                f"set it (--set {key}=VALUE) or leave the term out (--terms)")
    a0, a1, b, d = eq9_coefficients(design, chosen)
    return ResistanceLaw(float(a0), float(a1), float(b), float(d))


def eq9_coefficients(design, terms: Iterable[str] = TERMS) -> tuple:
    """(a0 [N], a1 [N/m], b [N·s/m], d [N·s²/m²]) of R = a0 + a1·x + b·v + d·v² in contact, from the term
    functions themselves (at x = 1 m, v = 1 m/s), 0 for a term switched off.

    ``design`` is a :class:`~pencli.model.design.Design` whose fields may be numpy arrays (the batch
    simulator's designs): the coefficients are then arrays too.
    """
    zero = np.zeros(np.shape(design.blade_width_m))
    return tuple(term_at(term, design, 1.0, 1.0) if term in terms else zero for term in TERMS)
