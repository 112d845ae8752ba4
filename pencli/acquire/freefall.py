"""A simulated free-fall penetrometer: a cone dropped through water into a bed, read by a BlueDrop's sensor chain.

The true world: a probe of mass m and volume V hangs at rest, is released
``drop_height_m`` above the bed and falls through water (weight less
buoyancy ρ_w·V·g, drag ½·ρ_w·C_D·A·v|v| on the shaft's section A, added
mass C_a·ρ_w·V), then enters the bed, which resists the cone's frontal
area A_f(z) = π·min(z·tan α, r)² at depth z with a pressure that grows
with depth and speed, q = σ + b·z + c·v (:class:`Bed`).  Buoyancy, drag
and added mass are kept at their values in water throughout (the probe is
mostly above the bed); a bed of a given bulk density also buoys the part of
the cone below its surface, by (ρ_b − ρ_w)·g times that volume.  The motion is integrated to 10⁻¹⁰ (scipy's
DOP853) and ends where the probe stops; it then rests on the bed.

The sensors: each axial accelerometer reads the specific force along the
axis, (g − a)/g in g (1 at rest, 0 in a vacuum's free fall), plus its own
bias and white noise, clipped to its range and rounded to its counts.  The
bias may drift in time (a warming sensor) and may shift at the impact (the
zero offset a shock leaves in a strained sensing element), by a sensor's
own amounts.  The pore pressure is the water's at the probe's depth; the
tilt channels (lateral accelerometers) read noise about zero while the
probe is vertical.  Once stopped, the probe may lean (``rest_tilt_deg``):
the axial sensors then read cos θ of gravity and the tilt channels the
rest.  The counts follow the calibration (raw = value·scale −
offset) and are written in the BlueDrop format
(:func:`pencli.io.bluedrop.bluedrop_bytes`).  This is the truth the
free-fall filters and fit (:mod:`pencli.filter.freefall`) are checked
against; it shares no code with them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pencli.io.bluedrop import ACCELEROMETER_RANGES_G, CHANNELS, RATE_HZ, ChannelCalibration

G = 9.80665
"""Standard gravity. [m/s²]"""

PSI_KPA = 6.894757
"""kPa per psi (the BlueDrop's pressure unit)."""


@dataclass(frozen=True)
class Probe:
    """A free-fall penetrometer: mass [kg], volume [m³], cone half-angle [rad] and shaft radius [m], drag and
    added-mass coefficients [–].  Defaults: a BlueDrop with its cone tip (7.71 kg, 2.473 L, cone 75.5 mm long
    on a 43.75 mm radius)."""

    mass_kg: float = 7.71
    volume_m3: float = 2.473e-3
    half_angle_rad: float = math.atan(43.75 / 75.5)
    shaft_radius_m: float = 0.04375
    drag_coefficient: float = 0.8
    added_mass_coefficient: float = 0.3

    def frontal_area_m2(self, depth_m: float) -> float:
        """The cone's section at the bed's surface when its tip is ``depth_m`` into the bed. [m²]"""
        r = min(max(depth_m, 0.0) * math.tan(self.half_angle_rad), self.shaft_radius_m)
        return math.pi * r * r

    def volume_below_m3(self, depth_m: float) -> float:
        """The probe's volume below the bed's surface when its tip is ``depth_m`` into the bed: the sharp cone's
        π·r³/(3·tan α) up to its base, then the shaft's cylinder. [m³]"""
        length = self.shaft_radius_m / math.tan(self.half_angle_rad)
        z = max(depth_m, 0.0)
        r = min(z, length) * math.tan(self.half_angle_rad)
        return math.pi * r ** 3 / (3.0 * math.tan(self.half_angle_rad)) + math.pi * self.shaft_radius_m ** 2 * max(
            z - length, 0.0)


@dataclass(frozen=True)
class Bed:
    """The bed's resistance per unit of frontal area, q = σ + b·z + c·v: σ [kPa], b [kPa/m], c [kPa·s/m]; with a
    layer, q changes by ``layer_step_kpa`` below ``layer_depth_m`` (the depth the cone's base has reached, where
    its frontal area is)."""

    strength_kpa: float
    gradient_kpa_m: float
    damping_kpa_s_m: float
    layer_depth_m: float = math.inf
    layer_step_kpa: float = 0.0
    density_kg_m3: float = 0.0
    """The bed's bulk density, which buoys the probe's volume below its surface (0: no such buoyancy). [kg/m³]"""

    def pressure_pa(self, depth_m: float, speed_m_s: float) -> float:
        step = self.layer_step_kpa if depth_m >= self.layer_depth_m else 0.0
        return 1e3 * (self.strength_kpa + self.gradient_kpa_m * depth_m + self.damping_kpa_s_m * speed_m_s + step)


@dataclass(frozen=True)
class Sensors:
    """The sensor chain: each accelerometer's bias [g] (a missing one is 0), its drift in time [g/s] and its shift
    from the impact on [g], the white noise [g], the pressure noise [psi], and the calibration (offset, scale)
    of every channel."""

    bias_g: dict[str, float] = field(default_factory=dict)
    drift_g_per_s: dict[str, float] = field(default_factory=dict)
    impact_shift_g: dict[str, float] = field(default_factory=dict)
    noise_g: float = 0.002
    pressure_noise_psi: float = 0.01
    calibration: dict[str, ChannelCalibration] = field(default_factory=lambda: default_calibration())


def default_calibration() -> dict[str, ChannelCalibration]:
    """Counts per unit that give each channel about 2¹⁹ counts over its range, and small offsets."""
    out = {name: ChannelCalibration(offset=-1200.0 + 100.0 * k, scale=(1 << 19) / rng, unit="g")
           for k, (name, rng) in enumerate(ACCELEROMETER_RANGES_G.items())}
    out["pore_pressure"] = ChannelCalibration(offset=350.0, scale=2500.0, unit="psi")
    out["tilt_x"] = ChannelCalibration(offset=-40.0, scale=(1 << 19) / 55.0, unit="g")
    out["tilt_y"] = ChannelCalibration(offset=25.0, scale=(1 << 19) / 55.0, unit="g")
    return out


@dataclass(frozen=True)
class Drop:
    """A simulated drop: the raw counts (rows, 10) at ``RATE_HZ``, and the truth: release time [s], time and
    speed at impact [s, m/s], time the probe stopped [s], its final depth in the bed [m]."""

    raw: np.ndarray
    release_s: float
    impact_s: float
    impact_speed_m_s: float
    stop_s: float
    penetration_m: float
    travel_m: np.ndarray | None = None
    """The true travel from the release at each sample (what any other sensor chain would read). [m]"""
    speed_m_s: np.ndarray | None = None
    """The true speed at each sample. [m/s]"""
    bed_force_n: np.ndarray | None = None
    """The bed's true force on the probe at each sample: A_f·q and the bed's buoyancy while it moves, the
    submerged weight once it rests. [N]"""


def _motion(probe: Probe, bed: Bed, drop_height_m: float, water_density: float):
    """The fall from release: (solution, its right-hand side, impact time, impact speed, stop time, final depth in
    the bed)."""
    from scipy.integrate import solve_ivp

    m_eff = probe.mass_kg + probe.added_mass_coefficient * water_density * probe.volume_m3
    submerged = (probe.mass_kg - water_density * probe.volume_m3) * G
    section = math.pi * probe.shaft_radius_m ** 2

    def rhs(_t, y):
        x, v = y
        force = submerged - 0.5 * water_density * probe.drag_coefficient * section * v * abs(v)
        z = x - drop_height_m
        if z > 0.0:
            force -= probe.frontal_area_m2(z) * bed.pressure_pa(z, v)
            if bed.density_kg_m3 > 0.0:
                force -= (bed.density_kg_m3 - water_density) * G * probe.volume_below_m3(z)
        return [v, force / m_eff]

    def stopped(_t, y):
        return y[1] if y[0] > drop_height_m else 1.0
    stopped.terminal, stopped.direction = True, -1

    def impact(_t, y):
        return y[0] - drop_height_m

    solution = solve_ivp(rhs, (0.0, 60.0), [0.0, 0.0], method="DOP853", rtol=1e-10, atol=1e-12,
                         dense_output=True, events=(stopped, impact))
    if solution.t_events[0].size == 0:
        raise ValueError(f"the bed does not stop the probe within {solution.t[-1]:.0f} s: its strength on the shaft's "
                         f"section, {section * bed.strength_kpa:.1f} kN, is below the submerged weight "
                         f"{submerged / 1e3:.3f} kN, and its resistance balances the weight only as the speed dies")
    t_stop = float(solution.t_events[0][0])
    t_impact = float(solution.t_events[1][0])
    return (solution, rhs, t_impact, float(solution.sol(t_impact)[1]), t_stop,
            float(solution.sol(t_stop)[0]) - drop_height_m)


SETTLE_S = 0.02
"""Time a probe takes to lean to its resting tilt once it has stopped in the bed. [s]"""


def simulate_drop(probe: Probe, bed: Bed, drop_height_m: float, *, sensors: Sensors | None = None,
                  water_depth_m: float = 10.0, water_density: float = 1025.0, hold_s: float = 0.5,
                  rest_s: float = 0.5, seed: int = 0, rest_tilt_deg: float = 0.0,
                  tilt_azimuth_deg: float = 0.0) -> Drop:
    """A drop released ``drop_height_m`` above the bed, with ``hold_s`` at rest before and ``rest_s`` on the bed
    after, sampled at ``RATE_HZ`` and read by ``sensors``; the bed lies ``water_depth_m`` below the surface.
    Once stopped, the probe leans over ``SETTLE_S`` to ``rest_tilt_deg`` from the vertical, towards
    ``tilt_azimuth_deg`` between the tilt channels' axes: the axial accelerometers then read gravity's share
    along the axis, cos θ, and the tilt channels the rest, sin θ·(cos φ, sin φ)."""
    sensors = sensors or Sensors()
    rng = np.random.default_rng(seed)
    solution, rhs, t_impact, v_impact, t_stop, final = _motion(probe, bed, drop_height_m, water_density)
    n = int((hold_s + t_stop + rest_s) * RATE_HZ)
    t = np.arange(n) / RATE_HZ
    falling = (t >= hold_s) & (t <= hold_s + t_stop)
    x = np.where(t < hold_s, 0.0, drop_height_m + final)
    accel = np.zeros(n)
    x[falling] = solution.sol(t[falling] - hold_s)[0]
    speed = np.zeros(n)
    speed[falling] = solution.sol(t[falling] - hold_s)[1]
    bed_force = np.where(t > hold_s + t_stop, (probe.mass_kg - water_density * probe.volume_m3) * G, 0.0)
    in_bed = falling & (x > drop_height_m)
    bed_force[in_bed] = _bed_force(probe, bed, x[in_bed] - drop_height_m, speed[in_bed], water_density)
    accel[falling] = [rhs(tt - hold_s, solution.sol(tt - hold_s))[1] for tt in t[falling]]  # the equation's own
    lean = math.radians(rest_tilt_deg) * np.clip((t - hold_s - t_stop) / SETTLE_S, 0.0, 1.0)  # at rest only
    specific = (G - accel) / G * np.cos(lean)
    raw = np.zeros((n, len(CHANNELS)), dtype=np.int64)
    raw[:, 0] = np.arange(n) % (1 << 23)
    after_impact = t >= hold_s + t_impact
    for name, span in ACCELEROMETER_RANGES_G.items():
        bias = (sensors.bias_g.get(name, 0.0) + sensors.drift_g_per_s.get(name, 0.0) * t
                + np.where(after_impact, sensors.impact_shift_g.get(name, 0.0), 0.0))
        value = np.clip(specific + bias + rng.normal(0.0, sensors.noise_g, n), -span, span)
        cal = sensors.calibration[name]
        raw[:, CHANNELS.index(name)] = np.rint(value * cal.scale - cal.offset)
    depth_below_surface = water_depth_m - drop_height_m + x
    pressure_psi = (water_density * G * depth_below_surface / 1e3 / PSI_KPA
                    + rng.normal(0, sensors.pressure_noise_psi, n))
    cal = sensors.calibration["pore_pressure"]
    raw[:, CHANNELS.index("pore_pressure")] = np.rint(pressure_psi * cal.scale - cal.offset)
    azimuth = math.radians(tilt_azimuth_deg)
    for name, share in (("tilt_x", math.cos(azimuth)), ("tilt_y", math.sin(azimuth))):
        cal = sensors.calibration[name]
        value = np.sin(lean) * share + rng.normal(0.0, sensors.noise_g, n)
        raw[:, CHANNELS.index(name)] = np.rint(value * cal.scale - cal.offset)
    return Drop(raw=raw, release_s=hold_s, impact_s=hold_s + t_impact, impact_speed_m_s=v_impact,
                stop_s=hold_s + t_stop, penetration_m=final, travel_m=x, speed_m_s=speed, bed_force_n=bed_force)


def _bed_force(probe: Probe, bed: Bed, depth_m: np.ndarray, speed_m_s: np.ndarray, water_density: float
               ) -> np.ndarray:
    """The bed's force on the moving probe at each depth in it (> 0) and speed: A_f(z)·q(z, v) and
    (ρ_b − ρ_w)·g·V(z). [N]"""
    out = np.empty(depth_m.size)
    for k, (z, v) in enumerate(zip(depth_m.tolist(), speed_m_s.tolist())):
        out[k] = probe.frontal_area_m2(z) * bed.pressure_pa(z, v)
        if bed.density_kg_m3 > 0.0:
            out[k] += (bed.density_kg_m3 - water_density) * G * probe.volume_below_m3(z)
    return out
