r"""A free fall through a fluid (air, water): a drive of the scalar simulator.

The body (mass m, volume V, drag coefficient C_D on its largest frontal area A) is released at rest at height
s0 above the bed in a fluid of density ρ_f.  The fluid buoys it (ρ_f·V·g up), carries an added mass
m_a = C_a·ρ_f·V along with it (inertia without weight) and, until the tip meets the surface, drags it with
½·ρ_f·C_D·A·v².  Below the surface the frontal area is in the bed, whose resistance replaces the drag; the
buoyancy and the added mass stay (the bed's pore fluid and the fluid above it still surround the body).  A
tether the body pays out pulls back with a constant tension T from release to rest, which adds to the
buoyancy wherever it appears below (ρ_f·V·g stands for ρ_f·V·g + T).

Inside the bed the body displaces the bed as well as the fluid: given the bed's bulk density ρ_b (saturated,
under water), the part of the body below the surface is buoyed by (ρ_b − ρ_f)·g·V_e(x) more, V_e(x) the
volume the tip x deep has below the surface (:func:`~pencli.model.geometry.embedded_volume_m3`).  Without ρ_b
(0, the default) this soil buoyancy is not modelled, as a BlueDrop's own processing leaves it out.

The flight is closed form.  With m' = m + m_a, g' = (m − ρ_f·V)·g/m' and the terminal speed
v_t² = 2·(m − ρ_f·V)·g/(ρ_f·C_D·A):

.. math::

    v(t) = v_t \tanh(g' t / v_t), \qquad u(t) = \frac{v_t^2}{g'} \ln\cosh(g' t / v_t),
    \qquad v(u)^2 = v_t^2 \left(1 - e^{-2 g' u / v_t^2}\right),

so along the path the drag is a function of the travel u alone, and the drive's force is

.. math::

    F(u) = -\rho_f V g - \tfrac12 \rho_f C_D A\, v(u)^2 \,[u < s_0],

with its work over [u0, u1] in closed form too.  The simulator's weight is the body's own (m·g); its
inertia, m + m_a (:meth:`FreeFall.added_mass_kg`).

Pure: numpy and ``math`` only, SI units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class FreeFallFlight:
    """The closed-form fall from release (t = 0, at rest, u = 0) with buoyancy and quadratic drag."""

    mass_kg: float
    """m + m_a: what the forces accelerate. [kg]"""
    net_weight_n: float
    """(m − ρ_f·V)·g − T: the weight less the buoyancy and any tether's tension. [N]"""
    drag_n_s2_m2: float
    """½·ρ_f·C_D·A. [N·s²/m²]"""

    @property
    def _g(self) -> float:
        return self.net_weight_n / self.mass_kg

    @property
    def terminal_speed_m_s(self) -> float:
        """v_t = sqrt(net weight / (½ ρ_f C_D A)); inf without drag. [m/s]"""
        return math.sqrt(self.net_weight_n / self.drag_n_s2_m2) if self.drag_n_s2_m2 > 0.0 else math.inf

    def reach(self, u: float) -> tuple[float, float]:
        """(time [s], speed [m/s]) when the body has fallen ``u`` [m]; (inf, 0) if it floats."""
        if u <= 0.0:
            return 0.0, 0.0
        g = self._g
        if g <= 0.0:
            return math.inf, 0.0
        if self.drag_n_s2_m2 <= 0.0:
            return math.sqrt(2.0 * u / g), math.sqrt(2.0 * g * u)
        vt = self.terminal_speed_m_s
        y = g * u / (vt * vt)
        root = math.sqrt(-math.expm1(-2.0 * y))  # sqrt(1 − e^{−2y}), accurate for small y
        return vt / g * (y + math.log1p(root)), vt * root  # acosh(e^y) = y + ln(1 + sqrt(1 − e^{−2y}))

    def state(self, t):
        """(u [m], v [m/s], a [m/s²]) at time(s) ``t`` [s] since release."""
        t = np.asarray(t, dtype=float)
        g = self._g
        if g <= 0.0:
            zero = np.zeros_like(t)
            return zero, zero, zero
        if self.drag_n_s2_m2 <= 0.0:
            return 0.5 * g * t * t, g * t, np.full_like(t, g)
        vt = self.terminal_speed_m_s
        z = g * t / vt
        tanh = np.tanh(z)
        u = vt * vt / g * (z + np.log1p(np.exp(-2.0 * z)) - math.log(2.0))  # ln cosh z, without overflow
        return u, vt * tanh, g * (1.0 - tanh * tanh)

    @property
    def release_time_s(self) -> float:
        """Nothing pushes before the fall: 0. [s]"""
        return 0.0


@dataclass(frozen=True)
class FreeFall:
    """A drop from the stand-off (the design's ``surface_offset_m``) through a fluid.  Built from a launcher file
    of ``drive: free_fall`` (:data:`pencli.model.drive.DRIVES`); ``drag_area_m2`` is the geometry's largest
    frontal area."""

    fluid_density_kg_m3: float
    drag_coefficient: float
    displaced_volume_m3: float
    drag_area_m2: float
    added_mass_coefficient: float = 0.0
    tether_force_n: float = 0.0
    """The tension of a line the body pays out as it falls (a spool's drag), constant from release to rest. [N]"""
    bed_density_kg_m3: float = 0.0
    """ρ_b, the bed's bulk density the body displaces below the surface (0: soil buoyancy not modelled). [kg/m³]"""
    geometry: object = None
    """The body's geometry, whose embedded volume the bed buoys (needed when ``bed_density_kg_m3`` > 0)."""
    name: str = "free_fall"
    closed_form: bool = False
    keys: tuple[str, ...] = ("fluid_density_kg_m3", "drag_coefficient", "displaced_volume_l",
                             "added_mass_coefficient", "tether_force_n", "bed_density_kg_m3")

    def __post_init__(self):
        if self.bed_density_kg_m3 > 0.0 and self.geometry is None:
            raise ValueError("a free fall with a bed density needs the body's geometry (its embedded volume)")

    def _bed_factor(self, design) -> float:
        """(ρ_b − ρ_f)·g: the soil buoyancy per unit of embedded volume; 0 when not modelled. [N/m³]"""
        if self.bed_density_kg_m3 <= 0.0:
            return 0.0
        return (self.bed_density_kg_m3 - self.fluid_density_kg_m3) * float(design.gravity_m_s2)

    def bed_buoyancy_n(self, design, depth_m: float) -> float:
        """(ρ_b − ρ_f)·g·V_e(x): the bed's buoyancy on the body with its tip ``depth_m`` into the bed. [N]"""
        factor = self._bed_factor(design)
        if not factor or depth_m <= 0.0:  # the integrator's hot path without a bed density: nothing more
            return 0.0
        from pencli.model.geometry import embedded_volume_m3

        return factor * embedded_volume_m3(self.geometry, design, depth_m)

    def added_mass_kg(self, design) -> float:
        """m_a = C_a·ρ_f·V: fluid the body carries along (inertia, no weight). [kg]"""
        return self.added_mass_coefficient * self.fluid_density_kg_m3 * self.displaced_volume_m3

    def upward_n(self, design) -> float:
        """ρ_f·V·g + T: the buoyancy and the tether's tension, the drive's constant upward forces. [N]"""
        return self.fluid_density_kg_m3 * self.displaced_volume_m3 * float(design.gravity_m_s2) + self.tether_force_n

    def drag_n_s2_m2(self) -> float:
        """½·ρ_f·C_D·A. [N·s²/m²]"""
        return 0.5 * self.fluid_density_kg_m3 * self.drag_coefficient * self.drag_area_m2

    def flight(self, design) -> FreeFallFlight:
        mass = float(design.effective_mass_kg) + self.added_mass_kg(design)
        return FreeFallFlight(mass, float(design.effective_mass_kg) * float(design.gravity_m_s2)
                              - self.upward_n(design), self.drag_n_s2_m2())

    def _drag_scale(self, design) -> tuple[float, float]:
        """(v_t², the travel scale v_t²/(2 g')) of the flight; (inf, inf) without drag or when it floats."""
        flight = self.flight(design)
        g = flight.net_weight_n / flight.mass_kg
        if flight.drag_n_s2_m2 <= 0.0 or g <= 0.0:
            return math.inf, math.inf
        vt2 = flight.net_weight_n / flight.drag_n_s2_m2
        return vt2, vt2 / (2.0 * g)

    def force(self, design, u):
        vt2, scale = self._drag_scale(design)
        s0 = float(design.surface_offset_m)
        upward = self.upward_n(design)
        k = self.drag_n_s2_m2()
        if isinstance(u, float):
            if u >= s0:
                return -upward - self.bed_buoyancy_n(design, u - s0)
            if not math.isfinite(scale) or u <= 0.0:
                return -upward
            return -upward - k * vt2 * -math.expm1(-u / scale)
        u = np.asarray(u, dtype=float)
        bed = (np.vectorize(lambda x: self.bed_buoyancy_n(design, float(x)), otypes=[float])(u - s0)
               if self._bed_factor(design) else 0.0)
        if not math.isfinite(scale):
            return np.full_like(u, -upward) - bed
        inside = (u > 0.0) & (u < s0)
        return -upward - np.where(inside, k * vt2 * -np.expm1(-np.clip(u, 0.0, None) / scale), 0.0) - bed

    def work(self, design, u0: float, u1: float) -> float:
        """−(ρ_f·V·g + T)·(u1 − u0) less the drag's work over the part of [u0, u1] above the surface and the
        bed's buoyancy's over the part below it. [J]"""
        s0 = float(design.surface_offset_m)
        total = -self.upward_n(design) * (u1 - u0)
        vt2, scale = self._drag_scale(design)
        if math.isfinite(scale):
            a, b = min(max(u0, 0.0), s0), min(max(u1, 0.0), s0)
            # ∫ k·v_t²·(1 − e^{−u/L}) du = k·v_t²·[Δu + L·(e^{−b/L} − e^{−a/L})]
            total -= self.drag_n_s2_m2() * vt2 * ((b - a) + scale * (math.exp(-b / scale) - math.exp(-a / scale)))
        factor = self._bed_factor(design)
        if factor and u1 > s0:
            from pencli.model.geometry import embedded_volume_integral_m4

            total -= factor * embedded_volume_integral_m4(self.geometry, design, u0 - s0, u1 - s0)
        return float(total)

    def corners(self, design) -> tuple[float, ...]:
        """The surface, where the drag stops. [m]"""
        return (float(design.surface_offset_m),) if self.drag_n_s2_m2() > 0.0 else ()

    def largest_slope(self, design, beyond_m: float = 0.0) -> float:
        vt2, scale = self._drag_scale(design)
        drag = self.drag_n_s2_m2() * vt2 / scale if math.isfinite(scale) else 0.0
        return drag + abs(self._bed_factor(design)) * self.drag_area_m2  # the bed's: (ρ_b − ρ_f)·g·A_f at most

    def largest_force(self, design) -> float:
        vt2, _ = self._drag_scale(design)
        drag = self.drag_n_s2_m2() * vt2 if math.isfinite(vt2) else 0.0
        return float(self.upward_n(design) + drag
                     + abs(self.bed_buoyancy_n(design, float(design.penetration_depth_m))))


__all__ = ["FreeFall", "FreeFallFlight"]
