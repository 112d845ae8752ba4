r"""What pushes the body: the drive seam of the scalar simulator, and CONTRACT §2's spring launcher.

A drive is the force that acts on the moving body besides gravity and the material's resistance, as a
function of its travel ``u`` from release (u = x + s0), together with the flight it gives from release to
contact.  :func:`~pencli.model.dynamics.simulate` asks a drive for nothing else (see :class:`Drive`), so a
new one (a pneumatic piston, a constant-force push) is one new module with one class, passed as
``simulate(design, drive=...)``; nothing else changes.

The contract's drive is :class:`Springs`: n parallel springs of stiffness k and propulsion efficiency η
push with η·n·k·(L0 − L) while compressed, nothing beyond free length,

.. math::

    F(u) = \eta n k \max(\text{stroke} - u, 0), \qquad \text{stroke} = \max(L_0 - L_c, 0),

and its flight is closed form (:class:`Flight`).  A stroke of 0 is a gravity drop.

Pure: numpy and ``math`` only, SI units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from pencli.model.design import Design, static_work
from pencli.model.flight import reach


class FlightPath(Protocol):
    """A drive's motion from release (t = 0, at rest, u = 0) until contact, with no resistance."""

    def reach(self, u: float) -> tuple[float, float]:
        """(time [s], speed [m/s]) when the body has moved ``u`` [m] from release; (inf, 0) if never."""

    def state(self, t):
        """(u [m], v [m/s], a [m/s²]) at time(s) ``t`` [s] since release, arrays."""

    @property
    def release_time_s(self) -> float:
        """When the drive stops pushing (the end of the span :func:`state` needs to show a drive that never
        brings the body to the surface). [s]"""


class Drive(Protocol):
    """The seam: every method takes the :class:`~pencli.model.design.Design` it drives."""

    name: str
    closed_form: bool
    """True when the drive is CONTRACT §2's linear springs: the creep rule (:func:`~pencli.model.dynamics.
    creep_target`) and the batch simulator's closed forms assume exactly that force."""
    keys: tuple[str, ...]
    """Parameter-file keys the drive reads (named when its force is out of range)."""

    def force(self, design: Design, u):
        """Push on the body at travel ``u`` [m] from release (float or array). [N]"""

    def work(self, design: Design, u0: float, u1: float) -> float:
        """∫ force du from travel u0 to u1. [J]"""

    def corners(self, design: Design) -> tuple[float, ...]:
        """Travels where the force or its slope jumps, which the integrator must not step across. [m]"""

    def largest_slope(self, design: Design, beyond_m: float = 0.0) -> float:
        """Largest |dF/du| at travels past ``beyond_m`` [m] from release, for the stiffness test of the
        integrator (which asks again past each corner). [N/m]"""

    def largest_force(self, design: Design) -> float:
        """Largest |F|, for the float64 range check. [N]"""

    def flight(self, design: Design) -> FlightPath:
        """The motion from release to contact (no resistance above the surface)."""

    # optional: added_mass_kg(design) -> float, mass the drive adds to the body's inertia but not to its weight
    # (fluid carried along) [kg]; a drive without it adds none (:func:`inertia_of`)


# --------------------------------------------------------------------------- CONTRACT §2: springs
@dataclass(frozen=True)
class Flight:
    """Closed-form flight of the spring launcher from release (t = 0, at rest) to contact.

    ``u`` is the displacement from the release position (= x + s0).
    """

    mass_kg: float
    stiffness_n_m: float
    stroke_m: float
    gravity_m_s2: float
    surface_offset_m: float

    @property
    def omega_rad_s(self) -> float:
        """Angular frequency of the spring phase, sqrt(η n k / m_eff). [rad/s]"""
        return math.sqrt(self.stiffness_n_m / self.mass_kg)

    @property
    def amplitude_m(self) -> float:
        """U = stroke + m g/(η n k): the harmonic motion is u = U(1 − cos ωt). [m]"""
        return self.stroke_m + self.mass_kg * self.gravity_m_s2 / self.stiffness_n_m

    def time_to_reach(self, u: float) -> float:
        """Time at which the body has moved ``u`` from release (``inf`` if never). [s]"""
        return self.reach(u)[0]

    def reach(self, u: float) -> tuple[float, float]:
        """(time [s], speed [m/s]) when the body has moved ``u`` from release; (inf, 0) if never."""
        return reach(u, self.mass_kg, self.stiffness_n_m, self.stroke_m, self.gravity_m_s2)

    @property
    def release_time_s(self) -> float:
        """When the springs reach free length. [s]"""
        return self.time_to_reach(self.stroke_m)

    def state(self, t):
        """(u, v, a) at time(s) ``t`` since release. [m, m/s, m/s²]"""
        t = np.asarray(t, dtype=float)
        U, w = self.amplitude_m, self.omega_rad_s
        t_rel = 2.0 * math.asin(math.sqrt(self.stroke_m / (2.0 * U))) / w
        ta = np.minimum(t, t_rel)
        u = 2.0 * U * np.sin(0.5 * w * ta) ** 2
        v = U * w * np.sin(w * ta)
        a = U * w * w * np.cos(w * ta)
        tau = np.maximum(t - t_rel, 0.0)
        after = t > t_rel
        v_rel = U * w * math.sin(w * t_rel)
        u = np.where(after, self.stroke_m + v_rel * tau + 0.5 * self.gravity_m_s2 * tau * tau, u)
        v = np.where(after, v_rel + self.gravity_m_s2 * tau, v)
        a = np.where(after, self.gravity_m_s2, a)
        return u, v, a


def flight_of(design: Design) -> Flight:
    """The closed-form flight of ``design`` on its springs."""
    return Flight(design.effective_mass_kg, design.drive_stiffness_n_m, design.stroke_m,
                  design.gravity_m_s2, design.surface_offset_m)


@dataclass(frozen=True)
class Springs:
    """CONTRACT §2's launcher: η·n·k·max(stroke − u, 0). The design's fields carry all its parameters."""

    name: str = "springs"
    closed_form: bool = True
    keys: tuple[str, ...] = ("spring_stiffness_kn_m", "spring_count", "spring_nominal_length_mm",
                             "spring_compressed_length_mm")

    def force(self, design: Design, u):
        if isinstance(u, float):  # the integrator's right-hand side: plain float arithmetic
            compression = design.stroke_m - u
            return design.drive_stiffness_n_m * compression if compression > 0.0 else 0.0
        return design.drive_stiffness_n_m * np.maximum(design.stroke_m - np.asarray(u, dtype=float), 0.0)

    def work(self, design: Design, u0: float, u1: float) -> float:
        return float(static_work(u0, u1, design.stroke_m, design.drive_stiffness_n_m, 0.0, 0.0, 0.0))

    def corners(self, design: Design) -> tuple[float, ...]:
        return (float(design.stroke_m),) if design.stroke_m > 0.0 else ()

    def largest_slope(self, design: Design, beyond_m: float = 0.0) -> float:
        return float(design.drive_stiffness_n_m) if beyond_m < design.stroke_m else 0.0

    def largest_force(self, design: Design) -> float:
        return float(design.drive_stiffness_n_m * design.stroke_m)

    def flight(self, design: Design) -> Flight:
        return flight_of(design)

    def added_mass_kg(self, design: Design) -> float:
        return 0.0


SPRINGS = Springs()
"""The contract's drive, the default of every simulation."""


def prescribed_speed(drive: Drive) -> float | None:
    """The speed a drive holds from the surface to full depth (a push at a constant rate, :mod:`pencli.model.push`),
    or None for a drive that pushes with a force and leaves the motion to the equation of motion. [m/s]"""
    return getattr(drive, "prescribed_speed_m_s", None)


def inertia_of(drive: Drive, design: Design) -> float:
    """What the forces accelerate: the body's effective mass and any mass its drive adds (fluid carried along,
    which has no weight). [kg]"""
    added = getattr(drive, "added_mass_kg", None)
    return design.effective_mass_kg + (added(design) if added is not None else 0.0)


def _free_fall(**kwargs):
    from pencli.model.freefall import FreeFall

    return FreeFall(**kwargs)


def _constant_rate(**kwargs):
    from pencli.model.push import ConstantRate

    return ConstantRate(**kwargs)


DRIVES = {"springs": Springs, "free_fall": _free_fall, "constant_rate": _constant_rate}
"""Every drive by the name a launcher file's ``drive:`` gives it; its constructor's keywords are the SI names of
the parameters that build it (``builds="drive"`` in :data:`pencli.params.definitions.PARAMETERS`) and, for a
drive in :data:`IN_A_FLUID`, ``drag_area_m2`` and ``geometry``."""
IN_A_FLUID = frozenset({"free_fall"})
"""The drives that move the body through a fluid: :func:`build_drive` gives them the geometry's largest frontal
area, on which the fluid drags."""


def drive_of(energizing, design: Design, geometry) -> Drive:
    """The drive a launcher file names, built from its keys (SI, by each definition's scale); a drive in a fluid
    (:data:`IN_A_FLUID`) drags on the geometry's largest frontal area (at full depth)."""
    return build_drive(energizing.drive, energizing.values, design, geometry)


def build_drive(name: str, values, design: Design, geometry) -> Drive:
    """The drive ``name`` from a launcher's file-unit ``values`` by key (absent or NaN: the drive's default), as
    :func:`drive_of` builds it; a sweep builds each design's this way."""
    from pencli.params.definitions import params_of

    if name == "springs":
        return SPRINGS
    kwargs = {p.si_name: float(values[p.key]) * p.si_scale for p in params_of("energizing", name)
              if p.builds == "drive" and p.key in values and not math.isnan(float(values[p.key]))}
    if name in IN_A_FLUID:
        kwargs["drag_area_m2"] = float(geometry.frontal_area_m2(design, float(design.penetration_depth_m)))
        kwargs["geometry"] = geometry  # the bed buoys its embedded volume
    return DRIVES[name](**kwargs)


__all__ = ["DRIVES", "IN_A_FLUID", "SPRINGS", "Drive", "Flight", "FlightPath", "Springs", "build_drive", "drive_of", "flight_of",
           "inertia_of", "prescribed_speed"]
