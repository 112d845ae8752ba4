"""The geometry and drive seams of the scalar simulator: a new penetrator or a new drive is one
class, written here as a user would write it in a module of their own, passed to ``simulate``; nothing in
pencli changes.  Each is checked against a closed form derived by hand or against an integration written
here with scipy directly, and the energy balance must close with the new energies booked.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from pencli.model.dynamics import simulate
from tests.test_dynamics_closed_forms import make_design


# ----------------------------------------------------------------------------- a cone, written as a user would
@dataclass(frozen=True)
class Cone:
    """A cone tip first, half-angle α: frontal area π(x·tan α)², pressing with the material's strength S·Cs,
    plus a rate term C·v over the same area. Not Eq. 9's form (the area grows with depth)."""

    half_angle_rad: float
    name: str = "cone"

    def law(self, design, terms):
        return None

    def resistance(self, design, terms):
        k = math.pi * math.tan(self.half_angle_rad) ** 2
        strength = design.strength_factor * design.strength_pa if "strength" in terms else 0.0
        damping = design.damping_pa_s_m if "damping" in terms else 0.0
        return lambda x, v: k * x * x * (strength + damping * v)


# ----------------------------------------------------------------------------- a gas piston, likewise
@dataclass(frozen=True)
class Piston:
    """A constant push F0 over a stroke s, nothing after (a pneumatic launcher)."""

    force_n: float
    stroke_m: float
    name: str = "piston"
    closed_form: bool = False
    keys: tuple = ("piston force",)

    def force(self, design, u):
        return np.where(np.asarray(u) < self.stroke_m, self.force_n, 0.0) if not isinstance(u, float) else (
            self.force_n if u < self.stroke_m else 0.0)

    def work(self, design, u0, u1):
        return self.force_n * (min(u1, self.stroke_m) - min(u0, self.stroke_m))

    def corners(self, design):
        return (self.stroke_m,)

    def largest_slope(self, design, beyond_m=0.0):
        return 0.0

    def largest_force(self, design):
        return self.force_n

    def flight(self, design):
        return _PistonFlight(self, design.effective_mass_kg, design.gravity_m_s2)


@dataclass(frozen=True)
class _PistonFlight:
    piston: Piston
    mass: float
    g: float

    @property
    def release_time_s(self):
        a = self.piston.force_n / self.mass + self.g
        return math.sqrt(2.0 * self.piston.stroke_m / a)

    def reach(self, u):
        a1 = self.piston.force_n / self.mass + self.g
        s = self.piston.stroke_m
        if u <= s:
            t = math.sqrt(2.0 * u / a1)
            return t, a1 * t
        t1, v1 = math.sqrt(2.0 * s / a1), math.sqrt(2.0 * a1 * s)
        disc = v1 * v1 + 2.0 * self.g * (u - s)
        if disc < 0.0:
            return math.inf, 0.0  # turns back before u
        tau = 2.0 * (u - s) / (v1 + math.sqrt(disc))
        return t1 + tau, v1 + self.g * tau

    def state(self, t):
        t = np.asarray(t, dtype=float)
        a1 = self.piston.force_n / self.mass + self.g
        t1 = self.release_time_s
        v1 = a1 * t1
        tau = np.maximum(t - t1, 0.0)
        before = t <= t1
        u = np.where(before, 0.5 * a1 * t * t, self.piston.stroke_m + v1 * tau + 0.5 * self.g * tau * tau)
        return u, np.where(before, a1 * t, v1 + self.g * tau), np.where(before, a1, self.g)


# ----------------------------------------------------------------------------- checks
def test_cone_quasi_static_arrest_depth_is_the_energy_closed_form():
    """Strength only, no drive at contact, no gravity: ½ m v0² = ∫ k S x² dx = k S x³/3 at arrest."""
    d = make_design(gravity_m_s2=0.0, surface_offset_m=0.2, penetration_depth_m=0.5)  # springs spent above
    cone = Cone(math.radians(20.0))
    v0 = 3.0
    result = simulate(d, terms=["strength"], speed_at_contact_m_s=v0, geometry=cone)
    m = d.sprung_mass_kg + d.spring_count * d.spring_mass_kg / 3
    k = math.pi * math.tan(math.radians(20.0)) ** 2 * d.strength_factor * d.strength_pa
    expected = (3.0 * 0.5 * m * v0 * v0 / k) ** (1.0 / 3.0)
    s = result.summary
    assert s.end == "arrest"
    assert s.final_depth_mm / 1e3 == pytest.approx(expected, rel=1e-8)
    assert s.energy_other_j == pytest.approx(0.5 * m * v0 * v0, rel=1e-8)
    assert s.energy_strength_j == 0.0  # nothing booked to Eq. 9's terms: the cone is not Eq. 9
    assert s.peak_resistance_n == pytest.approx(k * expected ** 2, rel=1e-6)
    assert abs(s.energy_balance_error_j) < 1e-8 * s.initial_ke_j


def test_cone_with_springs_and_damping_matches_an_independent_integration():
    """Springs still pushing at contact, gravity, strength and damping on a cone: pen's integration against
    one written here (DOP853 at 1e-12, the springs' corner handled by solving across it with max_step)."""
    d = make_design(surface_offset_m=0.05, damping_pa_s_m=2.0e4, penetration_depth_m=0.3)
    cone = Cone(math.radians(30.0))
    result = simulate(d, terms=["strength", "damping"], geometry=cone)
    m = d.sprung_mass_kg + d.spring_count * d.spring_mass_kg / 3
    kd = d.efficiency * d.spring_count * d.spring_stiffness_n_m
    stroke = d.nominal_length_m - d.compressed_length_m
    k = math.pi * math.tan(math.radians(30.0)) ** 2

    def rhs(_t, y):
        x, v = y
        push = kd * max(stroke - d.surface_offset_m - x, 0.0)
        r = k * x * x * (d.strength_factor * d.strength_pa + d.damping_pa_s_m * max(v, 0.0)) if x > 0 else 0.0
        return [v, (push + m * d.gravity_m_s2 - r) / m]

    arrest = lambda _t, y: y[1]  # noqa: E731
    arrest.terminal, arrest.direction = True, -1
    s = result.summary
    ref = solve_ivp(rhs, (0.0, 5.0), [0.0, s.contact_speed_m_s], method="DOP853", rtol=1e-12, atol=1e-14,
                    events=arrest, max_step=1e-4)
    assert s.end == "arrest" and ref.status == 1
    assert s.final_depth_mm / 1e3 == pytest.approx(ref.y_events[0][0][0], rel=1e-7)
    assert s.penetration_time_s == pytest.approx(ref.t_events[0][0], rel=1e-7)
    energy_in = s.spring_energy_j + s.gravity_work_j
    assert abs(s.energy_balance_error_j) < 1e-8 * energy_in


def test_piston_drive_flight_and_push_into_the_material():
    """A constant push longer than the stand-off: contact speed from ½mv² = (F0 + m g)·s0; in the material
    the push goes on to the piston's stroke; Eq. 9 resists.  Against an integration written here."""
    d = make_design(surface_offset_m=0.02, damping_pa_s_m=0.0)
    piston = Piston(force_n=400.0, stroke_m=0.035)
    result = simulate(d, drive=piston)
    s = result.summary
    m = d.sprung_mass_kg + d.spring_count * d.spring_mass_kg / 3
    assert s.contact_speed_m_s == pytest.approx(math.sqrt(2.0 * (400.0 / m + d.gravity_m_s2) * 0.02), rel=1e-12)
    theta, mu = d.tip_angle_rad, d.friction_coefficient
    wT = d.blade_width_m * d.blade_thickness_m
    a0 = wT * d.strength_factor * d.strength_pa * (math.sin(theta) + mu * math.cos(theta))
    a1 = 2.0 * mu * d.sidewall_pressure_pa * d.blade_width_m
    dd = wT * d.inertia_coefficient * d.density_kg_m3

    def rhs(_t, y):
        x, v = y
        push = 400.0 if x + 0.02 < 0.035 else 0.0
        vp = max(v, 0.0)
        return [v, (push + m * d.gravity_m_s2 - a0 - a1 * x - dd * vp * vp) / m]

    corner = lambda _t, y: y[0] - 0.015  # noqa: E731
    corner.terminal = True
    arrest = lambda _t, y: y[1]  # noqa: E731
    arrest.terminal, arrest.direction = True, -1
    first = solve_ivp(rhs, (0.0, 5.0), [0.0, s.contact_speed_m_s], method="DOP853", rtol=1e-12, atol=1e-14,
                      events=[corner, arrest])
    assert first.status == 1 and len(first.t_events[0]) == 1  # passed the piston's end first
    t1, y1 = first.t_events[0][0], first.y_events[0][0]
    second = solve_ivp(rhs, (t1, 5.0), y1, method="DOP853", rtol=1e-12, atol=1e-14, events=arrest)
    assert s.end == "arrest"
    assert s.final_depth_mm / 1e3 == pytest.approx(second.y_events[0][0][0], rel=1e-10)
    assert s.penetration_time_s == pytest.approx(second.t_events[0][0], rel=1e-10)
    assert s.spring_energy_j == pytest.approx(400.0 * 0.035, rel=1e-12)  # the whole stroke was delivered
    assert abs(s.energy_balance_error_j) < 1e-8 * (s.spring_energy_j + s.gravity_work_j)
    assert result.trajectory.spring_force_n.max() == pytest.approx(400.0)


def test_piston_that_stops_short_of_the_surface_with_no_gravity_never_arrives():
    d = make_design(gravity_m_s2=-9.81, surface_offset_m=0.5)
    result = simulate(d, drive=Piston(force_n=40.0, stroke_m=0.01))
    assert result.summary.end == "no_contact"
    assert result.summary.spring_energy_j == pytest.approx(40.0 * 0.01, rel=1e-12)


# ----------------------------------------------------------------------------- pen's own geometries
def test_the_blade_through_the_shape_law_is_eq9_to_machine_precision():
    """Frontal area w·T, bearing w·T·(sin θ + μ cos θ), side 2·w·x in the one shape law against Eq. 9's own
    term functions (pencli.model.resistance), over random designs, depths, speeds and term subsets."""
    from pencli.model.geometry import shape_resistance
    from pencli.model.resistance import TERM_FUNCTIONS, TERMS, term_at

    rng = np.random.default_rng(17)
    for _ in range(300):
        d = make_design(blade_width_m=rng.uniform(0.02, 0.3), blade_thickness_m=rng.uniform(5e-4, 0.01),
                        tip_angle_rad=rng.uniform(0.1, 1.57), friction_coefficient=rng.uniform(0, 1.2),
                        strength_pa=rng.uniform(1e5, 1e7), strength_factor=rng.uniform(0.2, 2.0),
                        sidewall_pressure_pa=rng.uniform(0, 5e4), damping_pa_s_m=rng.uniform(0, 5e4),
                        inertia_coefficient=rng.uniform(0, 80), density_kg_m3=rng.uniform(50, 1500))
        terms = tuple(t for t in TERMS if rng.uniform() < 0.7)
        x, v = rng.uniform(1e-4, 0.3), rng.uniform(-1.0, 20.0)
        wT = d.blade_width_m * d.blade_thickness_m
        shaped = shape_resistance(x, v, wT, wT * (math.sin(d.tip_angle_rad)
                                                  + d.friction_coefficient * math.cos(d.tip_angle_rad)),
                                  2.0 * d.blade_width_m * x, d, terms)
        eq9 = sum(float(term_at(t, d, x, v)) for t in terms)
        assert shaped == pytest.approx(eq9, rel=1e-14, abs=1e-300), (terms, x, v)
    assert set(TERM_FUNCTIONS) == set(TERMS)


def _cone_work(x, cone, d):
    """∫R dx of a sharp cone in the projected convention, strength and shaft friction, by hand: the tip's bearing
    k·x² (k = Cs·S·(sin α + μ cos α)·π·tan²α) up to L_c, the shaft's after it. [J]"""
    a, rs, L = cone.half_angle_rad, cone.shaft_radius_m, cone.cone_length_m
    bearing = d.strength_factor * d.strength_pa * (math.sin(a) + d.friction_coefficient * math.cos(a))
    if x <= L:
        return bearing * math.pi * math.tan(a) ** 2 * x ** 3 / 3.0
    shaft = d.friction_coefficient * d.sidewall_pressure_pa * 2.0 * math.pi * rs
    return bearing * math.pi * (math.tan(a) ** 2 * L ** 3 / 3.0 + rs ** 2 * (x - L)) + shaft * (x - L) ** 2 / 2.0


def test_a_cone_arrests_where_its_work_equals_the_energy_at_contact_past_its_shaft():
    """Strength and sidewall friction on a sharp 30° cone of 17.8 mm radius (a 10 cm² penetrometer's), no
    gravity, the springs spent above the surface: the arrest depth solves ∫R dx = ½mv0² (closed form, the shaft
    in the material), and the work is booked as the geometry's."""
    from scipy.optimize import brentq

    from pencli.model.geometry import Cone

    d = make_design(gravity_m_s2=0.0, surface_offset_m=0.2, penetration_depth_m=0.6, strength_pa=1e5,
                    friction_coefficient=0.5, sidewall_pressure_pa=2e4)
    cone = Cone(math.radians(30.0), 0.0178)
    v0 = 3.0
    m = d.effective_mass_kg
    expected = brentq(lambda x: _cone_work(x, cone, d) - 0.5 * m * v0 ** 2, 1e-6, 0.6, xtol=1e-15)
    assert expected > 2 * cone.cone_length_m  # the shaft is well in
    s = simulate(d, terms=["strength", "friction"], speed_at_contact_m_s=v0, geometry=cone).summary
    assert s.end == "arrest"
    assert s.final_depth_mm / 1e3 == pytest.approx(expected, rel=1e-7)
    assert s.energy_other_j == pytest.approx(0.5 * m * v0 ** 2, rel=1e-8)
    assert abs(s.energy_balance_error_j) < 1e-8 * s.initial_ke_j


def test_the_mantle_convention_is_the_face_pressure_summed_ring_by_ring():
    """A blunted cone (tip flat of 3 mm radius) with the shaft in: the strength as a pressure normal to each
    ring of the face, with friction μ·p up the slant against the motion, summed over 20,000 rings as vectors
    (axial components taken from the face's normal and tangent), plus the flat's p·π·r_t²."""
    from pencli.model.geometry import Cone

    d = make_design(friction_coefficient=0.45)
    a, rt, rs = math.radians(25.0), 0.003, 0.0178
    cone = Cone(a, rs, tip_radius_m=rt, area="mantle")
    p = d.strength_factor * d.strength_pa
    slant = (rs - rt) / math.sin(a)
    s = (np.arange(20000) + 0.5) * slant / 20000  # ring centres along the slant
    r = rt + s * math.sin(a)
    ring_area = 2.0 * math.pi * r * slant / 20000
    normal = np.array([math.cos(a), math.sin(a)])  # (radial, axial): the face pushes the material out and down
    tangent = np.array([math.sin(a), -math.cos(a)])  # up the slant: the friction on the tip opposes its motion
    axial = float(np.sum(ring_area * p * (normal[1] - d.friction_coefficient * tangent[1])))
    expected = axial + p * math.pi * rt ** 2
    depth = cone.cone_length_m + 0.01
    assert cone.resistance(d, ("strength",))(depth, 1.0) == pytest.approx(expected, rel=1e-7)


def test_a_tapered_blade_arrests_where_its_work_equals_the_energy_at_contact():
    """A blade whose thickness grows from 0.2 mm to T over 20 mm: the strength's work ∫ w·T(x) dx, friction
    μ·P·w·x², by hand; the arrest inside and past the taper against the simulation; past the taper its
    resistance is Eq. 9's."""
    from scipy.optimize import brentq

    from pencli.model.geometry import BLADE, TaperedBlade

    d = make_design(gravity_m_s2=0.0, surface_offset_m=0.2, penetration_depth_m=0.5)
    taper = TaperedBlade(tip_thickness_m=0.0002, taper_length_m=0.02)
    w, T, t0, L = d.blade_width_m, d.blade_thickness_m, 0.0002, 0.02
    bearing = d.strength_factor * d.strength_pa * (math.sin(d.tip_angle_rad)
                                                   + d.friction_coefficient * math.cos(d.tip_angle_rad))

    def work(x):
        inside = min(x, L)
        area = w * (t0 * inside + (T - t0) * inside ** 2 / (2 * L)) + w * T * max(x - L, 0.0)
        return bearing * area + d.friction_coefficient * d.sidewall_pressure_pa * w * x ** 2

    m = d.effective_mass_kg
    for v0 in (1.0, 6.0):
        expected = brentq(lambda x: work(x) - 0.5 * m * v0 ** 2, 1e-9, 0.5, xtol=1e-15)
        s = simulate(d, terms=["strength", "friction"], speed_at_contact_m_s=v0, geometry=taper).summary
        assert s.final_depth_mm / 1e3 == pytest.approx(expected, rel=1e-7), v0
    past = taper.resistance(d, ("strength", "friction", "inertia"))(0.05, 4.0)
    assert past == pytest.approx(BLADE.resistance(d, ("strength", "friction", "inertia"))(0.05, 4.0), rel=1e-14)


@pytest.mark.parametrize("make, words", [
    (lambda: __import__("pencli.model.geometry", fromlist=["Cone"]).Cone(math.radians(95), 0.01), ("half-angle",)),
    (lambda: __import__("pencli.model.geometry", fromlist=["Cone"]).Cone(0.5, 0.01, tip_radius_m=0.02),
     ("tip radius", "shaft")),
    (lambda: __import__("pencli.model.geometry", fromlist=["Cone"]).Cone(0.5, 0.01, area="surface"),
     ("projected", "mantle")),
    (lambda: __import__("pencli.model.geometry", fromlist=["TaperedBlade"]).TaperedBlade(0.001, 0.0),
     ("taper length",)),
])
def test_a_geometry_with_impossible_dimensions_is_one_line(make, words):
    from pencli.errors import ModelError

    with pytest.raises(ModelError) as caught:
        make()
    assert "\n" not in str(caught.value) and all(w in str(caught.value) for w in words)
