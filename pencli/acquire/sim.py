"""The simulated rig: a digital twin with sensor models.

It integrates the true world (:mod:`pencli.acquire.truth`, with any hidden
effects of the rig file), then measures it the way the real rig does: the
string encoder quantised to its counts (0.16 mm), the six-axis load cell
seeing the resistance, the blade-mount inertia and its static weight, with
offsets and noise, optionally lagging, ringing or drifting; then it
returns encoder counts and gauge volts through the inverse of the force
calibration, so the acquisition path calibrates them exactly as it would
real readings.
"""

from __future__ import annotations

import math
from typing import Iterator

import numpy as np

from pencli.acquire.calibration import ForceCalibration, PositionCalibration
from pencli.acquire.drivers import RawBlock, ShotSetup
from pencli.acquire.rig import RigConfig
from pencli.acquire.truth import TrueMotion, TrueWorld, true_motion
from pencli.errors import RigError
from pencli.params.load import resolve
from pencli.params.validate import ParameterSet

LEVER_ARM_M = 0.05
"""Lever of side forces about the sensor's origin, for the torque channels. [m]"""


def _registered_shape(penetrator: ParameterSet, material: ParameterSet, energizing: ParameterSet):
    """The areas at depth of a geometry registered with pen that the rig does not know by name (its author's
    :meth:`~pencli.model.geometry.Shape.areas`, at the true material's friction coefficient)."""
    from pencli.model.design import design_from_sets
    from pencli.model.geometry import geometry_of

    geometry = geometry_of(penetrator)
    if not hasattr(geometry, "areas"):
        raise RigError(f"{penetrator.source}: the simulated rig fires a blade, a tapered blade, a cone or a shape "
                       f"given by its areas, not a {penetrator.geometry.replace('_', ' ')}")
    design = design_from_sets(penetrator, material, energizing)
    return lambda x: geometry.areas(design, x)


def world_from(penetrator: ParameterSet, material: ParameterSet, energizing: ParameterSet, rig: RigConfig
               ) -> TrueWorld:
    """The true world of a shot: the run's blade and launcher, the rig's true material and effects."""
    truth_material = material
    if rig["true_material"] is not None:
        truth_material = resolve(rig["true_material"], "material")
    mv = truth_material.values
    missing = [k for k in ("coefficients.strength_factor", "coefficients.sidewall_pressure_kpa",
                           "coefficients.damping_kpa_s_m", "coefficients.inertia_coefficient") if k not in mv]
    if missing:
        raise RigError(f"the simulated rig needs a true material with coefficients; {truth_material.source} lacks "
                       f"{missing[0]} (set true_material in the rig file)")
    pv, ev = penetrator.values, energizing.values
    cone = taper = shape = None
    if penetrator.geometry == "cone":
        cone = (math.radians(pv["cone_half_angle_deg"]), pv["shaft_diameter_mm"] / 2e3,
                pv.get("tip_flat_diameter_mm", 0.0) / 2e3, penetrator.choice("cone_area"))
    elif penetrator.geometry == "tapered_blade":
        if any(name == "plug_growth" for name, _ in rig.effects):
            raise RigError(f"{penetrator.source}: the simulated rig's plug growth widens a plain blade; this one "
                           f"tapers")
        taper = (pv["tip_thickness_mm"] / 1e3, pv["taper_length_mm"] / 1e3)
    elif penetrator.geometry != "blade":
        shape = _registered_shape(penetrator, truth_material, energizing)
    return TrueWorld(
        blade_width_m=pv.get("blade_width_mm", math.nan) * 1e-3,
        blade_thickness_m=pv.get("blade_thickness_mm", math.nan) * 1e-3,
        tip_angle_rad=math.radians(pv.get("tip_angle_deg", math.nan)),
        penetration_depth_m=pv["penetration_depth_mm"] * 1e-3, cone=cone, taper=taper, shape=shape,
        sprung_mass_kg=pv["sprung_mass_kg"], load_cell_mass_kg=pv["load_cell_mass_kg"],
        density_kg_m3=mv["density_kg_m3"],
        strength_pa=mv["microstructure_strength_kpa"] * 1e3 * float(rig["strength_scale"]),
        friction_coefficient=mv["friction_coefficient"], gravity_m_s2=mv.get("gravity_m_s2", 9.81),
        strength_factor=mv["coefficients.strength_factor"],
        sidewall_pressure_pa=mv["coefficients.sidewall_pressure_kpa"] * 1e3,
        damping_pa_s_m=mv["coefficients.damping_kpa_s_m"] * 1e3,
        inertia_coefficient=mv["coefficients.inertia_coefficient"],
        spring_count=int(ev["spring_count"]), spring_stiffness_n_m=ev["spring_stiffness_kn_m"] * 1e3,
        spring_mass_kg=ev["spring_mass_kg"], nominal_length_m=ev["spring_nominal_length_mm"] * 1e-3,
        compressed_length_m=ev["spring_compressed_length_mm"] * 1e-3, surface_offset_m=(ev["surface_offset_mm"] + float(rig["surface_offset_error_mm"])) * 1e-3,
        efficiency=ev["propulsion_efficiency_pct"] / 100.0, effects=rig.effects)


def _lag(signal: np.ndarray, tau_s: float, rate_hz: float, shape: int) -> np.ndarray:
    """The force channel's lag, starting settled: shape 0 two cascaded first-order low-passes (exact
    discretisation), 1 one of them, 2 a pure delay of ``tau_s`` (linear interpolation between samples), 3 a
    fourth-order Bessel low-pass whose group delay is ``tau_s`` (bilinear; a delay with a rounded step, as a
    conditioning amplifier's linear-phase filter gives)."""
    if shape == 2:
        shifted = np.arange(signal.size) - tau_s * rate_hz
        return np.interp(shifted, np.arange(signal.size), signal)
    from scipy.signal import lfilter

    if shape == 3:
        from scipy.signal import bessel, lfilter_zi

        # norm="delay": the group delay at low frequency is 1/(2π Wn) with Wn in the units of fs
        b, a = bessel(4, 1.0 / (2.0 * math.pi * tau_s), norm="delay", fs=rate_hz)
        return lfilter(b, a, signal, zi=lfilter_zi(b, a) * signal[0])[0]

    a = math.exp(-1.0 / (tau_s * rate_hz))
    out = signal
    for _ in range(2 if shape == 0 else 1):
        out = lfilter([1 - a], [1, -a], out, zi=[out[0] * a])[0]
    return out


def anti_alias_sos(rig: RigConfig, rate_hz: float) -> np.ndarray | None:
    """The rig's anti-alias low-pass at ``rate_hz`` as second-order sections, or None when it has none: a
    Butterworth, a Bessel (its -3 dB point at the corner) or a Chebyshev type I (ripple up to the corner, its gain
    at 0 Hz scaled to 1, as a converter calibrated at rest reads it) of the rig's order."""
    corner = float(rig["anti_alias_hz"])
    if corner <= 0:
        return None
    from scipy.signal import bessel, butter, cheby1

    kind, order = rig["anti_alias_kind"], int(rig["anti_alias_order"])
    if kind == "bessel":
        return bessel(order, corner, fs=rate_hz, norm="mag", output="sos")
    if kind == "chebyshev":
        sos = cheby1(order, float(rig["anti_alias_ripple_db"]), corner, fs=rate_hz, output="sos")
        sos[0, :3] /= np.prod(np.sum(sos[:, :3], axis=1) / np.sum(sos[:, 3:], axis=1))
        return sos
    return butter(order, corner, fs=rate_hz, output="sos")


def _resonant_noise(rng: np.random.Generator, n: int, rate_hz: float, level_n: float, frequency_hz: float,
                    damping: float, sos: np.ndarray | None) -> np.ndarray:
    """Three channels of white noise through one damped mode (the impulse-invariant two-pole resonator of
    ``frequency_hz`` and ``damping``), scaled to ``level_n`` standard deviation [N] and passed through the
    anti-alias low-pass ``sos`` (None: none), as the gauges' own noise is; started settled (the first
    half second is run in and dropped)."""
    from scipy.signal import lfilter

    w0 = 2 * math.pi * frequency_hz / rate_hz
    r = math.exp(-damping * w0)
    wd = w0 * math.sqrt(1 - damping * damping)
    lead = int(0.5 * rate_hz)
    out = lfilter([1.0], [1.0, -2 * r * math.cos(wd), r * r], rng.normal(0, 1, (n + lead, 3)), axis=0)[lead:]
    return _scaled_and_filtered(out, level_n, sos)


def _scaled_and_filtered(noise: np.ndarray, level_n: float, sos: np.ndarray | None) -> np.ndarray:
    """Noise channels (columns) scaled to ``level_n`` standard deviation [N], then through the anti-alias
    low-pass ``sos`` (None: none)."""
    from scipy.signal import sosfilt

    noise = noise * (level_n / np.std(noise, axis=0))
    return noise if sos is None else sosfilt(sos, noise, axis=0)


def _pink_noise(rng: np.random.Generator, n: int, level_n: float, sos: np.ndarray | None) -> np.ndarray:
    """Three channels of flicker noise over ``n`` samples: white noise whose power is shaped to fall as 1/f
    (amplitudes over √f in its discrete Fourier transform, flat below the lowest frequency the record holds),
    scaled to ``level_n`` standard deviation [N] and passed through the anti-alias low-pass ``sos`` (None:
    none), as the gauges' own noise is."""
    spectrum = np.fft.rfft(rng.normal(0, 1, (n, 3)), axis=0)
    frequency = np.fft.rfftfreq(n)
    spectrum /= np.sqrt(np.maximum(frequency, 1.0 / n))[:, None]
    spectrum[0] = 0.0
    return _scaled_and_filtered(np.fft.irfft(spectrum, n, axis=0), level_n, sos)


def measure(motion: TrueMotion, world: TrueWorld, rig: RigConfig, setup: ShotSetup,
            position_cal: PositionCalibration, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Encoder counts and the six calibrated channels (untared) over the whole recording."""
    rate = setup.sampling_rate_hz
    n_total, n_pre = setup.total_samples, setup.pre_trigger_samples
    n_motion = motion.time_s.size
    if n_pre + n_motion > n_total:
        n_motion = n_total - n_pre  # the recording ends before the motion does
    idx = np.arange(n_total) - n_pre  # sample index relative to the release
    t = idx / rate
    k = np.clip(idx, 0, motion.time_s.size - 1)
    moving = idx >= 0
    u = np.where(moving, motion.displacement_m[k], 0.0)
    acc = np.where(moving & (idx < motion.time_s.size), motion.acceleration_m_s2[k], 0.0)
    resistance = np.where(moving, motion.resistance_n[k], 0.0)
    m_lc = world.true_load_cell_mass_kg
    axial = resistance + m_lc * (acc - world.gravity_m_s2)  # untared: the blade's weight hangs on the cell

    ringing = world.effect("rig_ringing")
    if ringing and math.isfinite(motion.contact_time_s):
        tc = t - motion.contact_time_s
        w0 = 2 * math.pi * ringing["frequency_hz"]
        zeta = ringing["damping_ratio"]
        wd = w0 * math.sqrt(max(1 - zeta ** 2, 1e-9))
        amp = ringing["amplitude_n_per_m_s"] * motion.contact_speed_m_s
        second, ratio = ringing["second_amplitude"], ringing["second_ratio"]
        modes = (amp * np.exp(-zeta * w0 * np.maximum(tc, 0)) * np.sin(wd * tc)
                 + second * amp * np.exp(-2 * zeta * w0 * np.maximum(tc, 0)) * np.sin(ratio * wd * tc))
        axial = axial + np.where(tc > 0, modes, 0.0)
    gauge = world.effect("gauge_nonlinearity")
    if gauge:  # the cell's own response, before its electronics' filter and drift
        axial = axial * (1.0 + gauge["gain_per_kn"] * axial / 1e3)
    lag = world.effect("sensor_lag")
    if lag:
        axial = _lag(axial, lag["tau_ms"] * 1e-3, rate, int(lag["shape"]))
    drift = world.effect("force_drift")
    if drift:
        tp = np.maximum(t, 0.0)
        ratio = tp / drift["time_constant_s"]
        profile = -np.expm1(-ratio) if drift["shape"] == 0 else ratio if drift["shape"] == 1 else np.log1p(ratio)
        axial = axial + drift["amplitude_n"] * profile

    noise_f = float(rig["force_noise_n"])
    noise_t = float(rig["torque_noise_nm"])
    side = float(rig["lateral_fraction"]) * resistance
    fo, to = rig["force_offsets_n"], rig["torque_offsets_nm"]
    forces = np.empty((n_total, 6))
    forces[:, 0] = fo[0] + 0.8 * side + rng.normal(0, noise_f, n_total)
    forces[:, 1] = fo[1] + 0.6 * side + rng.normal(0, noise_f, n_total)
    forces[:, 2] = fo[2] + axial + rng.normal(0, noise_f, n_total)
    corr = float(rig["correlated_noise_n"])
    if corr > 0:
        from scipy.signal import lfilter

        a = math.exp(-1.0 / (float(rig["correlated_noise_ms"]) * 1e-3 * rate))
        drive = rng.normal(0, corr * math.sqrt(1 - a * a), (n_total, 3))
        forces[:, :3] += lfilter([1.0], [1.0, -a], drive, axis=0)
    forces[:, 3] = to[0] - LEVER_ARM_M * 0.6 * side + rng.normal(0, noise_t, n_total)
    forces[:, 4] = to[1] + LEVER_ARM_M * 0.8 * side + rng.normal(0, noise_t, n_total)
    forces[:, 5] = to[2] + rng.normal(0, noise_t, n_total)
    sos = anti_alias_sos(rig, rate)
    if sos is not None:  # the acquisition's anti-alias filter: signal and noise alike, settled at the rest level
        from scipy.signal import sosfilt, sosfilt_zi

        forces = sosfilt(sos, forces, axis=0, zi=sosfilt_zi(sos)[:, :, None] * forces[0][None, None, :])[0]
    jitter = float(rig["position_noise_um"]) * 1e-6
    if jitter > 0:  # drawn last, so a seed's other draws are what they were without it
        from scipy.signal import lfilter

        memory = float(rig["position_noise_ms"]) * 1e-3 * rate
        a = math.exp(-1.0 / memory) if memory > 0 else 0.0
        u = u + lfilter([1.0], [1.0, -a], rng.normal(0, jitter * math.sqrt(1 - a * a), n_total))
    floor = float(rig["converter_noise_n"])
    if floor > 0:  # after the filter, and drawn after everything else for the same reason
        forces[:, :3] += rng.normal(0, floor, (n_total, 3))
    resonant = float(rig["resonant_noise_n"])
    if resonant > 0:  # the gauges' narrow-band pick-up: drawn last for the same reason, filtered as the rest was
        forces[:, :3] += _resonant_noise(rng, n_total, rate, resonant, float(rig["resonant_noise_hz"]),
                                         float(rig["resonant_noise_damping"]), sos)
    pink = float(rig["pink_noise_n"])
    if pink > 0:  # the gauges' flicker noise: drawn last for the same reason, filtered as the rest was
        forces[:, :3] += _pink_noise(rng, n_total, pink, sos)
    phase = float(rig["encoder_phase"])  # the counter is zeroed at rest, wherever the count edges lie
    edges = [float(e) for e in rig["encoder_edge_errors"]]
    if not any(edges):
        counts = (np.round(u * 1e3 * position_cal.counts_per_mm + phase) - round(phase)).astype(np.int64)
    else:
        position = u * 1e3 * position_cal.counts_per_mm + phase
        counts = quadrature_counts(position, edges) - quadrature_counts(np.array([phase]), edges)[0]
    return counts, forces


def quadrature_counts(position: np.ndarray, edge_errors: list[float]) -> np.ndarray:
    """The count a quadrature encoder reads at ``position`` [counts]: the number of edges at or below it, less
    one, where edge k lies at k + 1/2 + ``edge_errors[k mod 4]`` (each within ±1/2, so that the edge next to a
    position is one of three); with no errors, the position rounded."""
    d = np.asarray(edge_errors, dtype=float)
    m = np.floor(position - 0.5).astype(np.int64)
    edge = lambda k: k + 0.5 + d[np.mod(k, 4)]  # noqa: E731
    return np.where(edge(m + 1) <= position, m + 1, np.where(edge(m) <= position, m, m - 1)) + 1


class SimRig:
    """The ``sim`` driver."""

    name = "sim"

    def __init__(self, rig: RigConfig, position_cal: PositionCalibration, force_cal: ForceCalibration):
        self.rig = rig
        self.position_cal = position_cal
        self.force_cal = force_cal
        self._inverse = np.linalg.inv(force_cal.matrix)
        self._setup: ShotSetup | None = None
        self._recording: tuple[np.ndarray, np.ndarray] | None = None
        self.truth: dict | None = None
        self.motion: TrueMotion | None = None
        self.world: TrueWorld | None = None

    def arm(self, setup: ShotSetup) -> None:
        self._setup = setup
        self.world = world_from(setup.penetrator, setup.material, setup.energizing, self.rig)
        seed = self.rig["seed"]
        self._rng = np.random.default_rng(seed)

    def _volts(self, forces: np.ndarray) -> np.ndarray:
        return forces @ self._inverse.T

    def read_idle(self, n_samples: int) -> RawBlock:
        if self._setup is None or self.world is None:
            raise RigError("arm the rig before reading it")
        fo, to = self.rig["force_offsets_n"], self.rig["torque_offsets_nm"]
        level = np.array([fo[0], fo[1], fo[2] - self.world.true_load_cell_mass_kg * self.world.gravity_m_s2,
                          to[0], to[1], to[2]])
        noise = np.concatenate([self._rng.normal(0, float(self.rig["force_noise_n"]), (n_samples, 3)),
                                self._rng.normal(0, float(self.rig["torque_noise_nm"]), (n_samples, 3))], axis=1)
        return RawBlock(np.zeros(n_samples, dtype=np.int64), self._volts(level + noise))

    def fire(self) -> None:
        if self._setup is None or self.world is None:
            raise RigError("arm the rig before firing")
        self.motion = true_motion(self.world, self._setup.sampling_rate_hz)
        counts, forces = measure(self.motion, self.world, self.rig, self._setup, self.position_cal, self._rng)
        self._recording = (counts, self._volts(forces))
        m = self.motion
        self.truth = {
            "contact_time_s": m.contact_time_s, "contact_speed_m_s": m.contact_speed_m_s,
            "stop_time_s": m.stop_time_s, "final_depth_mm": m.final_depth_m * 1e3, "end": m.end,
            "strength_pa": self.world.strength_pa, "load_cell_mass_kg": self.world.true_load_cell_mass_kg,
            "effects": [{"name": n, **p} for n, p in self.world.effects],
        }

    def stream(self) -> Iterator[RawBlock]:
        if self._recording is None:
            raise RigError("fire before streaming")
        counts, volts = self._recording
        block = max(1, int(self._setup.sampling_rate_hz // 10))
        for start in range(0, counts.size, block):
            yield RawBlock(counts[start:start + block], volts[start:start + block])

    def disarm(self) -> None:
        self._recording = None
