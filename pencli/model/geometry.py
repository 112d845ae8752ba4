r"""What the material resists: the penetrator-geometry seam of the scalar simulator.

A geometry turns a design and a set of switched-on terms into the resistance R(x, v) of the material on
the penetrator, for a tip inside the material (x > 0).  :func:`~pencli.model.dynamics.simulate` asks a
geometry for nothing else (see :class:`Geometry`), so a new one (a cone, a tapered blade) is one new module
with one class, passed as ``simulate(design, geometry=...)``.

A geometry whose resistance reduces to Eq. 9's form a0 + a1·x + b·v + d·v² returns that
:class:`~pencli.model.resistance.ResistanceLaw` from :meth:`Geometry.law`; the simulator then books each
Eq. 9 term's energy separately and may use the creep rule, and the batch simulator's closed forms apply.
Any other geometry returns ``None`` there and gives its force from :meth:`Geometry.resistance`; its
dissipated energy is integrated with the motion and reported as ``energy_other_j``.

The contract's geometry is :class:`Blade` (paper Eq. 9, :mod:`pencli.model.resistance`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Protocol

from pencli.model.design import Design
from pencli.model.resistance import ResistanceLaw, reduced, resistance_law


class Geometry(Protocol):
    name: str

    def law(self, design: Design, terms: tuple[str, ...]) -> ResistanceLaw | None:
        """Eq. 9's four coefficients when the resistance has that form, else ``None``."""

    def resistance(self, design: Design, terms: tuple[str, ...]) -> Callable[[float, float], float]:
        """R(x [m], v [m/s]) → N for x > 0; ``v`` is already clipped at 0 (the material resists motion into
        it only). Called with floats inside the integrator."""


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


BLADE = Blade()
"""The contract's geometry, the default of every simulation."""

__all__ = ["BLADE", "Blade", "Geometry"]
