r"""A push at a constant rate (a cone penetration test, a SnowMicroPen): a drive that prescribes the motion.

A rig that pushes the body at a set rate v (CPT's 20 mm/s) holds the speed whatever the material does: there
is no equation of motion to integrate.  The body meets the surface at v and goes to full depth at v,

.. math::

    x(t) = v\,t, \qquad 0 \le t \le d / v,

and the rig's push is what that takes, F(x) = R(x, v) − m·g (the weight pushes too; the acceleration is 0).
Every resistance term is read along that path: the strength, friction and geometry terms at depth x, the
rate terms at the one speed v (so one sounding cannot tell a rate term from a strength; soundings at several
rates can, :mod:`pencli.fit.rate_effect`).  The push's work is the resistance's less gravity's, so the
energy balance closes by construction.

:func:`pencli.model.dynamics.simulate` takes a drive with ``prescribed_speed_m_s``
(:func:`pencli.model.drive.prescribed_speed`) on this path; the
launcher file names it ``drive: constant_rate`` with ``push_rate_mm_s`` (and a stand-off, crossed at the same
rate; 0: the push starts with the tip at the surface).

Pure: numpy only, SI units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pencli.model.design import Design


@dataclass(frozen=True)
class PushFlight:
    """The push from release: the body moves at the rate from the start (u = v·t), so it meets a surface a
    stand-off s0 away after s0/v, at v (a stand-off of 0: at once)."""

    rate_m_s: float

    def reach(self, u: float) -> tuple[float, float]:
        """(u/v, v): when the push has moved the body ``u`` [m], and its speed. [s, m/s]"""
        return max(u, 0.0) / self.rate_m_s, self.rate_m_s

    def state(self, t):
        t = np.asarray(t, dtype=float)
        return self.rate_m_s * t, np.full_like(t, self.rate_m_s), np.zeros_like(t)

    @property
    def release_time_s(self) -> float:
        return 0.0


@dataclass(frozen=True)
class ConstantRate:
    """A push at ``rate_m_s`` from the surface to full depth.  Its force follows from the resistance along the
    prescribed path (:func:`pencli.model.dynamics.simulate`), not from the travel alone; the methods the
    force-driven integrator asks for describe a drive that does nothing before contact."""

    rate_m_s: float
    name: str = "constant_rate"
    closed_form: bool = False
    keys: tuple[str, ...] = ("push_rate_mm_s",)

    @property
    def prescribed_speed_m_s(self) -> float:
        """The speed the push holds from the surface to full depth. [m/s]"""
        return self.rate_m_s

    def force(self, design: Design, u):
        return 0.0 if isinstance(u, float) else np.zeros_like(np.asarray(u, dtype=float))

    def work(self, design: Design, u0: float, u1: float) -> float:
        return 0.0

    def corners(self, design: Design) -> tuple[float, ...]:
        return ()

    def largest_slope(self, design: Design, beyond_m: float = 0.0) -> float:
        return 0.0

    def largest_force(self, design: Design) -> float:
        return 0.0

    def flight(self, design: Design) -> PushFlight:
        return PushFlight(self.rate_m_s)


__all__ = ["ConstantRate", "PushFlight"]
