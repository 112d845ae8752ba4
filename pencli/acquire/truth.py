r"""The "real world" of the simulated rig: true physics with hidden effects.

This is deliberately *not* :mod:`pencli.model`.  It is a separate
implementation of the rig (fixed-step RK4 on its own force law) so that a
fit or a diagnosis tested on simulated runs is not tested on data made by
its own code path.  With no effects and the same coefficients it agrees with
CONTRACT §2 to the accuracy of its integrator; with effects it departs from
it in ways the model does not know about.

The true forms of the effects deliberately differ from the forms the
diagnosis catalogue fits (a plateau layer with soft edges where the
catalogue has a step; a power-law rate dependence where it has a logarithm;
a two-pole sensor lag where it has one pole; ...), so that recovering them
does not rely on an exact match.

Units: SI inside (m, s, N, kg, Pa); effect parameters carry their unit in
their name.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping

import numpy as np

from pencli.errors import ParameterError

# ---------------------------------------------------------------------------- effects
# An effect is a name (CONTRACT §4) with named parameters.  Each "kind" of
# effect modifies one ingredient of the true world; TRUE_EFFECTS says which,
# with defaults and a docstring-like description.


@dataclass(frozen=True)
class EffectSpec:
    """A hidden effect the simulated world can carry."""

    name: str
    description: str
    defaults: Mapping[str, float]
    shapes: int = 1
    """How many forms ``shape`` may choose (0 … shapes − 1); 1: the effect has one form."""


TRUE_EFFECTS: dict[str, EffectSpec] = {spec.name: spec for spec in (
    EffectSpec("strength_layer", "strength takes ratio × S in a layer from depth_mm to depth_mm + thickness_mm "
               "(a plateau), with smooth edges edge_mm wide", {"depth_mm": 60.0, "ratio": 0.5,
                                                              "thickness_mm": 50.0, "edge_mm": 2.0}),
    EffectSpec("strength_gradient", "strength changes smoothly with depth, by change_per_100mm at 100 mm; shape 0: "
               "exponential S·(1 + change)^(x/0.1 m); 1: power S·(1 + change·(x/0.1 m)^exponent); 2: saturating "
               "S·(1 + change·(1 − exp(−x/length_mm))/(1 − exp(−0.1 m/length_mm))); 3: two slopes, the second "
               "slope_ratio × the first below kink_mm; 4: an S-shaped rise "
               "S·(1 + change·(s(x) − s(0))/(s(0.1 m) − s(0))), s(x) = tanh((x − length_mm)/width_mm)",
               {"change_per_100mm": 0.5, "shape": 0.0, "exponent": 1.5, "length_mm": 40.0, "kink_mm": 40.0,
                "slope_ratio": 0.2, "width_mm": 20.0}, 5),
    EffectSpec("plug_growth", "a crushed plug widens the frontal thickness to T + growth_mm·h(x); shape 0: "
               "hyperbolic h = (x/length_mm)/(1 + x/length_mm); 1: exponential h = 1 − exp(−x/length_mm); 2: "
               "linear until length_mm, then constant; 3: a power (x/length_mm)^exponent until length_mm, then "
               "constant", {"growth_mm": 1.5, "length_mm": 30.0, "shape": 0.0, "exponent": 1.0}, 4),
    EffectSpec("sidewall_pressure_growth", "sidewall pressure rises with depth; shape 0: power "
               "P·(1 + (x/scale_mm)^exponent); 1: saturating P·(1 + rise·(1 − exp(−x/scale_mm)))",
               {"scale_mm": 60.0, "exponent": 1.5, "shape": 0.0, "rise": 2.0}, 2),
    EffectSpec("velocity_friction", "friction changes with sliding speed, by up to −drop (a negative drop is a "
               "rise); shape 0: Stribeck-like μ·(1 − drop·(1 − exp(−v/speed_m_s))); 1: hyperbolic "
               "μ·(1 − drop·v/(v + speed_m_s)); 2: logarithmic μ·(1 − drop·ln(1 + v/speed_m_s)/ln(1 + 10 m/s / "
               "speed_m_s)); 3: power μ·(1 − drop·(v/10 m/s)^exponent); 4: Stribeck with a viscous rise "
               "μ·(1 − drop·(1 − exp(−v/speed_m_s)) + viscous·v/10 m/s)",
               {"drop": 0.4, "speed_m_s": 3.0, "shape": 0.0, "exponent": 1.0, "viscous": 0.0}, 5),
    EffectSpec("rate_strength", "strength rises with penetration rate; shape 0: power "
               "S·(1 + coefficient·(v/1 m/s)^exponent); 1: logarithmic S·(1 + 4·coefficient·ln(1 + v/speed_m_s)); "
               "2: saturating S·(1 + 5·coefficient·(1 − exp(−v/speed_m_s))); 3: onset, flat below speed_m_s "
               "S·(1 + coefficient·(max(v − speed_m_s, 0)/1 m/s)^exponent)",
               {"coefficient": 0.05, "exponent": 1.5, "shape": 0.0, "speed_m_s": 3.0}, 4),
    EffectSpec("load_cell_mass_error", "the mass below the load cell is ratio × the file's value",
               {"ratio": 1.5}),
    EffectSpec("sensor_lag", "the force channel lags; shape 0: two first-order poles of tau_ms each; 1: one pole "
               "of tau_ms; 2: a pure delay of tau_ms; 3: a fourth-order Bessel low-pass of group delay tau_ms",
               {"tau_ms": 0.3, "shape": 0.0}, 4),
    EffectSpec("rig_ringing", "two damped structural modes are struck at contact: amplitude_n_per_m_s × contact "
               "speed at frequency_hz, and second_amplitude of it at second_ratio × frequency_hz (twice the decay)",
               {"amplitude_n_per_m_s": 40.0, "frequency_hz": 900.0, "damping_ratio": 0.03,
                "second_amplitude": 0.3, "second_ratio": 2.7}),
    EffectSpec("force_drift", "the force offset drifts from the release on; shape 0: "
               "amplitude_n·(1 − exp(−t/time_constant_s)); 1: linear, amplitude_n per time_constant_s; 2: "
               "logarithmic, amplitude_n·ln(1 + t/time_constant_s)",
               {"amplitude_n": 30.0, "time_constant_s": 0.05, "shape": 0.0}, 3),
    EffectSpec("propulsion_loss", "the launcher loses energy: efficiency × (1 − loss) and a guide friction of "
               "guide_friction_n along the whole travel", {"loss": 0.15, "guide_friction_n": 10.0}),
    EffectSpec("brittle_bursts", "(outside the diagnosis catalogue) strength collapses and recovers in "
               "saw-tooth bursts every period_mm of depth, by depth ratio", {"period_mm": 20.0, "ratio": 0.5}),
    EffectSpec("gauge_nonlinearity", "(outside the diagnosis catalogue) the load cell's gain changes with the force "
               "it carries: it reads F·(1 + gain_per_kn·F / 1 kN)", {"gain_per_kn": 0.1}),
)}


def validate_effects(effects: Any, where: str) -> tuple[tuple[str, dict[str, float]], ...]:
    """Check a list of ``{name: ..., param: value}`` mappings; fill defaults."""
    if effects is None:
        return ()
    if not isinstance(effects, (list, tuple)):
        raise ParameterError(f"{where}: key 'effects': expected a list of mappings with a 'name'")
    out = []
    for i, item in enumerate(effects):
        if not isinstance(item, Mapping) or "name" not in item:
            raise ParameterError(f"{where}: effects[{i}]: expected a mapping with a 'name'")
        name = item["name"]
        spec = TRUE_EFFECTS.get(name)
        if spec is None:
            raise ParameterError(f"{where}: effects[{i}]: unknown effect {name!r}; known: {', '.join(TRUE_EFFECTS)}")
        params = dict(spec.defaults)
        for key, value in item.items():
            if key == "name":
                continue
            if key not in spec.defaults:
                raise ParameterError(f"{where}: effects[{i}] ({name}): unknown parameter {key!r}; "
                                     f"expected: {', '.join(spec.defaults)}")
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ParameterError(f"{where}: effects[{i}] ({name}): {key} = {value!r}; expected a number")
            params[key] = float(value)
        shape = params.get("shape", 0.0)
        if shape not in range(spec.shapes):
            raise ParameterError(f"{where}: effects[{i}] ({name}): shape = {shape:g}; expected one of "
                                 f"{', '.join(map(str, range(spec.shapes)))}")
        if name == "strength_gradient" and shape == 3:  # stated against its change at 100 mm: must change by then
            kink, ratio = params["kink_mm"], params["slope_ratio"]
            if kink < 0 or ratio < 0 or kink == ratio == 0:
                raise ParameterError(f"{where}: effects[{i}] ({name}): kink_mm = {kink:g}, slope_ratio = {ratio:g}; "
                                     f"expected both ≥ 0, not both 0")
        if name in ("plug_growth", "velocity_friction") and shape == 3 and params["exponent"] <= 0:
            # a power of depth or speed from 0: a non-positive exponent is infinite at the surface or at rest
            raise ParameterError(f"{where}: effects[{i}] ({name}): exponent = {params['exponent']:g}; expected > 0")
        if name == "strength_gradient" and shape == 4 and params["width_mm"] <= 0:
            raise ParameterError(f"{where}: effects[{i}] ({name}): width_mm = {params['width_mm']:g}; expected > 0")
        out.append((name, params))
    return tuple(out)


# ---------------------------------------------------------------------------- the true world
@dataclass(frozen=True)
class TrueWorld:
    """Everything the simulated rig's world is made of, SI.

    ``effects`` are (name, parameters) pairs from :data:`TRUE_EFFECTS`.
    """

    blade_width_m: float
    blade_thickness_m: float
    tip_angle_rad: float
    penetration_depth_m: float
    sprung_mass_kg: float
    load_cell_mass_kg: float
    density_kg_m3: float
    strength_pa: float
    friction_coefficient: float
    gravity_m_s2: float
    strength_factor: float
    sidewall_pressure_pa: float
    damping_pa_s_m: float
    inertia_coefficient: float
    spring_count: int
    spring_stiffness_n_m: float
    spring_mass_kg: float
    nominal_length_m: float
    compressed_length_m: float
    surface_offset_m: float
    efficiency: float
    effects: tuple[tuple[str, dict[str, float]], ...] = field(default_factory=tuple)
    cone: tuple[float, float, float, str] | None = None
    """A cone tip in place of the blade: (half-angle [rad], shaft radius [m], flat tip radius [m], ``projected`` or
    ``mantle``); the blade's dimensions are then unused."""
    taper: tuple[float, float] | None = None
    """The blade's thickness grows from the first [m] at its tip to its full thickness over the second [m]
    (a tapered blade); None: a plain blade."""
    shape: Callable[[float], tuple[float, float, float]] | None = None
    """Another shape in place of the blade: its (frontal, bearing, side) areas at a depth [m → m²], as the
    shape's author wrote them (a geometry registered with pen that the rig does not know by name); the rig's own
    law of the material acts on them, with the bearing area's friction at the material's static μ."""

    def effect(self, name: str) -> dict[str, float] | None:
        """Parameters of effect ``name`` when present."""
        for effect_name, params in self.effects:
            if effect_name == name:
                return params
        return None

    @property
    def moving_mass_kg(self) -> float:
        """Sprung mass plus a third of the springs' mass. [kg]"""
        return self.sprung_mass_kg + self.spring_count * self.spring_mass_kg / 3.0

    @property
    def true_load_cell_mass_kg(self) -> float:
        """The real mass below the load cell (load_cell_mass_error changes it). [kg]"""
        err = self.effect("load_cell_mass_error")
        return self.load_cell_mass_kg * (err["ratio"] if err else 1.0)


def _resistance_function(world: TrueWorld) -> Callable[[float, float], float]:
    """The true resistance R(x, v) [N] of a tip in the material, effects included."""
    w, T = world.blade_width_m, world.blade_thickness_m
    theta, mu0 = world.tip_angle_rad, world.friction_coefficient
    S0, Cs, P0 = world.strength_pa, world.strength_factor, world.sidewall_pressure_pa
    C, K, rho = world.damping_pa_s_m, world.inertia_coefficient, world.density_kg_m3
    layer = world.effect("strength_layer")
    gradient = world.effect("strength_gradient")
    plug = world.effect("plug_growth")
    pgrowth = world.effect("sidewall_pressure_growth")
    vfric = world.effect("velocity_friction")
    rate = world.effect("rate_strength")
    bursts = world.effect("brittle_bursts")
    sin_t, cos_t = math.sin(theta), math.cos(theta)

    def gradient_factor(x: float) -> float:
        change, shape = gradient["change_per_100mm"], gradient["shape"]
        if shape == 0:
            return math.exp(math.log1p(change) * x / 0.1)
        if shape == 1:
            return 1.0 + change * (x / 0.1) ** gradient["exponent"]
        if shape == 3:
            kink, ratio = gradient["kink_mm"] * 1e-3, gradient["slope_ratio"]
            span = min(x, kink) + ratio * max(x - kink, 0.0)
            return 1.0 + change * span / (min(0.1, kink) + ratio * max(0.1 - kink, 0.0))
        length = gradient["length_mm"] * 1e-3
        if shape == 4:
            width = gradient["width_mm"] * 1e-3
            s0 = math.tanh(-length / width)
            return 1.0 + change * (math.tanh((x - length) / width) - s0) / (math.tanh((0.1 - length) / width) - s0)
        return 1.0 + change * -math.expm1(-x / length) / -math.expm1(-0.1 / length)

    def rate_factor(v: float) -> float:
        c, shape = rate["coefficient"], rate["shape"]
        if shape == 0:
            return 1.0 + c * v ** rate["exponent"]
        if shape == 1:
            return 1.0 + 4.0 * c * math.log1p(v / rate["speed_m_s"])
        if shape == 3:
            return 1.0 + c * max(v - rate["speed_m_s"], 0.0) ** rate["exponent"]
        return 1.0 + 5.0 * c * -math.expm1(-v / rate["speed_m_s"])

    def strength(x: float, v: float) -> float:
        s = S0
        if layer:
            top = layer["depth_mm"] * 1e-3
            bottom = top + layer["thickness_mm"] * 1e-3
            edge = max(layer["edge_mm"], 1e-3) * 1e-3
            inside = 0.5 * (math.tanh((x - top) / edge) - math.tanh((x - bottom) / edge))
            s *= 1.0 + (layer["ratio"] - 1.0) * inside
        if gradient:
            s *= gradient_factor(x)
        if rate and v > 0:
            s *= rate_factor(v)
        if bursts:
            phase = (x / (bursts["period_mm"] * 1e-3)) % 1.0
            s *= 1.0 - (1.0 - bursts["ratio"]) * phase
        return s

    def friction_coefficient(v: float) -> float:
        if vfric and v > 0:
            s, shape = vfric["speed_m_s"], vfric["shape"]
            if shape == 0:
                law = -math.expm1(-v / s)
            elif shape == 1:
                law = v / (v + s)
            elif shape == 2:
                law = math.log1p(v / s) / math.log1p(10.0 / s)
            elif shape == 3:
                law = (v / 10.0) ** vfric["exponent"]
            else:
                return mu0 * (1.0 - vfric["drop"] * -math.expm1(-v / s) + vfric["viscous"] * v / 10.0)
            return mu0 * (1.0 - vfric["drop"] * law)
        return mu0

    def sidewall_integral(x: float) -> float:
        """∫0^x P(z) dz [Pa·m]."""
        if not pgrowth:
            return P0 * x
        a, n = pgrowth["scale_mm"] * 1e-3, pgrowth["exponent"]
        if pgrowth["shape"] == 1:
            return P0 * (x + pgrowth["rise"] * (x + a * math.expm1(-x / a)))
        return P0 * (x + x ** (n + 1) / ((n + 1) * a ** n))

    def thickness(x: float) -> float:
        if world.taper is not None:  # the edge in the material: thinner while the taper enters
            tip, length = world.taper
            return min(tip + (T - tip) * x / length, T)
        if plug:
            ratio = x / (plug["length_mm"] * 1e-3)
            shape = plug["shape"]
            if shape == 3:
                h = min(ratio, 1.0) ** plug["exponent"]
            else:
                h = ratio / (1.0 + ratio) if shape == 0 else -math.expm1(-ratio) if shape == 1 else min(ratio, 1.0)
            return T + plug["growth_mm"] * 1e-3 * h
        return T

    def resistance(x: float, v: float) -> float:
        """In contact (the caller knows); x is clipped at the surface."""
        x = x if x > 0.0 else 0.0
        vp = v if v > 0.0 else 0.0
        mu = friction_coefficient(vp)
        t_front = thickness(x)
        frontal = w * t_front * (Cs * strength(x, vp) * (sin_t + mu * cos_t) + C * vp + K * rho * vp * vp)
        sidewall = 2.0 * mu * w * sidewall_integral(x)
        return frontal + sidewall

    if world.shape is not None:
        if plug or pgrowth:
            raise ParameterError("the simulated rig's plug growth and sidewall pressure growth act on a blade, "
                                 "not on another shape")

        def shape_resistance(x: float, v: float) -> float:
            """The strength on the bearing area, P on the side area, the rate terms on the frontal area."""
            x = x if x > 0.0 else 0.0
            vp = v if v > 0.0 else 0.0
            frontal, bearing, side = world.shape(x)
            return (Cs * strength(x, vp) * bearing + friction_coefficient(vp) * P0 * side
                    + frontal * (C * vp + K * rho * vp * vp))

        return shape_resistance
    if world.cone is None:
        return resistance
    if plug or pgrowth:
        raise ParameterError("the simulated cone carries no plug growth or sidewall pressure growth (blade effects)")
    # (a tapered blade is the blade's law with its thickness from :func:`thickness`, above)
    alpha, r_shaft, r_tip, area = world.cone
    slope = math.tan(alpha)
    cone_length = (r_shaft - r_tip) / slope

    def cone_resistance(x: float, v: float) -> float:
        """A cone tip blunted to a flat, then its shaft: the strength pushes on the face (its projection times
        sin α + μ cos α, or the face normal to it with friction along it) and on the flat, P on the shaft in the
        material, the rate terms on the cross-section."""
        x = x if x > 0.0 else 0.0
        vp = v if v > 0.0 else 0.0
        mu = friction_coefficient(vp)
        radius = min(r_tip + slope * x, r_shaft)
        section, flat = math.pi * radius ** 2, math.pi * r_tip ** 2
        face = section * (math.sin(alpha) + mu * math.cos(alpha)) if area == "projected" else (
            flat + (section - flat) * (1.0 + mu / slope))
        shaft = 2.0 * math.pi * r_shaft * mu * P0 * max(x - cone_length, 0.0)
        return Cs * strength(x, vp) * face + section * (C * vp + K * rho * vp * vp) + shaft

    return cone_resistance


@dataclass(frozen=True)
class TrueMotion:
    """The true motion sampled on the recording grid (time 0 = release)."""

    time_s: np.ndarray
    displacement_m: np.ndarray
    """From the release position, down positive. [m]"""
    velocity_m_s: np.ndarray
    acceleration_m_s2: np.ndarray
    resistance_n: np.ndarray
    drive_n: np.ndarray
    """Spring push + weight of the moving body (what the material must hold at rest). [N]"""
    contact_time_s: float
    contact_speed_m_s: float
    stop_time_s: float
    final_depth_m: float
    end: str
    """``arrest`` or ``full_depth``."""


def true_motion(world: TrueWorld, sample_rate_hz: float, *, substeps: int = 8, max_time_s: float = 3.0) -> TrueMotion:
    """Integrate the true rig from release with fixed-step RK4 on the sampling grid.

    Each sampling interval is split into ``substeps`` RK4 steps; the step that
    crosses the surface is split exactly at the crossing (found by bisection on
    the flight, where the force is smooth).  Arrest (v reaching 0 in the
    material) and full depth end the motion; the body then rests.
    """
    m = world.moving_mass_kg
    stroke = world.nominal_length_m - world.compressed_length_m
    s0 = world.surface_offset_m
    loss = world.effect("propulsion_loss")
    eta = world.efficiency * (1.0 - (loss["loss"] if loss else 0.0))
    guide = loss["guide_friction_n"] if loss else 0.0
    kd = eta * world.spring_count * world.spring_stiffness_n_m
    weight = m * world.gravity_m_s2
    depth_full = world.penetration_depth_m
    resistance = _resistance_function(world)

    def drive(u: float) -> float:
        compression = stroke - u
        return (kd * compression if compression > 0.0 else 0.0) + weight

    def accel(u: float, v: float, inside: bool) -> float:
        moving = guide if v > 0.0 else 0.0
        return (drive(u) - moving - (resistance(u - s0, v) if inside else 0.0)) / m

    def rk4(u: float, v: float, h: float) -> tuple[float, float]:
        inside = u >= s0  # a step never crosses the surface: the crossing step is split
        k1u, k1v = v, accel(u, v, inside)
        k2u, k2v = v + 0.5 * h * k1v, accel(u + 0.5 * h * k1u, v + 0.5 * h * k1v, inside)
        k3u, k3v = v + 0.5 * h * k2v, accel(u + 0.5 * h * k2u, v + 0.5 * h * k2v, inside)
        k4u, k4v = v + h * k3v, accel(u + h * k3u, v + h * k3v, inside)
        return u + h * (k1u + 2 * k2u + 2 * k3u + k4u) / 6.0, v + h * (k1v + 2 * k2v + 2 * k3v + k4v) / 6.0

    dt = 1.0 / sample_rate_hz
    h = dt / substeps
    n_max = int(max_time_s * sample_rate_hz) + 1
    us, vs = [0.0], [0.0]
    u, v, t = 0.0, 0.0, 0.0
    contact_t, contact_v = math.nan, math.nan
    end, stop_t = "", math.nan
    for _ in range(n_max):
        for _ in range(substeps):
            if u < s0:
                u_new, v_new = rk4(u, v, h)
                if u_new >= s0:  # split the step at the surface
                    lo, hi = 0.0, h
                    for _ in range(60):
                        mid = 0.5 * (lo + hi)
                        if rk4(u, v, mid)[0] < s0:
                            lo = mid
                        else:
                            hi = mid
                    u_c, v_c = rk4(u, v, hi)
                    contact_t, contact_v = t + hi, v_c
                    u, v = rk4(s0, v_c, h - hi)
                else:
                    u, v = u_new, v_new
            else:
                u_new, v_new = rk4(u, v, h)
                if v_new <= 0.0 and u_new > s0:  # arrest: interpolate the zero crossing of v
                    frac = v / (v - v_new) if v != v_new else 1.0
                    u = u + frac * (u_new - u)
                    v = 0.0
                    end, stop_t = "arrest", t + frac * h
                    break
                if u_new - s0 >= depth_full:
                    frac = (s0 + depth_full - u) / (u_new - u) if u_new != u else 1.0
                    u, v = s0 + depth_full, 0.0
                    end, stop_t = "full_depth", t + frac * h
                    break
                u, v = u_new, v_new
            t += h
        us.append(u)
        vs.append(v)
        if end:
            break
    else:
        end, stop_t = "arrest", t  # gave up: treat as at rest where it is
    u_arr = np.array(us)
    v_arr = np.array(vs)
    time = np.arange(u_arr.size) * dt
    if end:
        v_arr[-1] = 0.0
    inside = u_arr >= s0
    acc = np.array([accel(a, b, c) for a, b, c in zip(u_arr, v_arr, inside)])
    res = np.array([resistance(a - s0, b) if c else 0.0 for a, b, c in zip(u_arr, v_arr, inside)])
    drv = np.array([drive(a) for a in u_arr])
    # at rest the body does not move; the material (or the stops) hold the drive
    acc[-1] = 0.0
    res[-1] = drv[-1] if end == "arrest" else 0.0
    return TrueMotion(time, u_arr, v_arr, acc, res, drv, contact_t, contact_v, stop_t, float(u_arr[-1] - s0), end)
