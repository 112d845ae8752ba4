"""The hold-out truth world: a second rig simulator, written apart from pen and from its `sim` driver.

It is used to *measure* the diagnosis, never to develop or tune it: the
figures it gives are reported as hold-out figures (docs/guide/diagnosis.md, bench/
bench_diagnose_holdout.py).  Nothing here is imported by pen.

What differs from the `sim` driver's world (pencli/acquire/truth.py, sim.py):

- dynamics integrated by scipy's LSODA with event location (the sim driver:
  fixed-step RK4 on the sampling grid);
- every effect has other forms, drawn at random within its meaning (edge
  widths, exponents, frequencies, onset depths, laws);
- sensor chain: force noise white or coloured (AR(1)), 0.5–6 N; a two-pole
  Butterworth anti-alias filter on the force channel (cut-off 0.15–0.4 of
  the sample rate); an incremental encoder of 0.08–0.32 mm with a random
  grating phase; 30 or 60 kHz (or mixed within a campaign); time exported
  to six significant digits;
- nuisances always on: block-to-block strength scatter 3–6 %, stand-off
  scatter (σ 0.3–1.5 mm around the file's value), blades of several widths
  and thicknesses, 4–8 runs, sometimes a material no table holds.

Runs are written as CONTRACT §3 folders (data.csv + the three parameter
files + run.yaml) and go through `pen ingest`, `tare`, `subtract-inertia`
and `diagnose` exactly as a lab's runs would.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pencli.testing.labfolders import Campaign, write_lab_folder

G = 9.81
CATALOGUE = ("strength_layer", "strength_gradient", "plug_growth", "sidewall_pressure_growth", "velocity_friction",
             "rate_strength", "load_cell_mass_error", "sensor_lag", "rig_ringing", "force_drift", "propulsion_loss")
OUTSIDE = "periodic_crushing"
"""An effect outside the catalogue: strength oscillating sinusoidally with depth (crushing cycles)."""
OUTSIDE_KINDS = (OUTSIDE, "fragment_impacts", "strength_relaxation", "gauge_nonlinearity", "blade_wander")
"""Effects outside the catalogue, one of each kind of misfit the catalogue has no term for: periodic in depth
(crushing cycles); intermittent, one-sided and different in every run (fragments struck at random depths);
following the time in the material (the crushed zone weakens as it ages); following the measured force itself
(a load cell whose gain rises with load); and differing from run to run (the blade enters at a random tilt, so
each run's sidewall pressure is its own)."""
PAIRS = (("strength_layer", "load_cell_mass_error"), ("rig_ringing", "sidewall_pressure_growth"),
         ("propulsion_loss", "strength_gradient"), ("force_drift", "velocity_friction"))
"""The hold-out bench's two-effect campaigns."""
DRAWS, OUTSIDE_DRAWS = 2, 2
"""Campaigns per catalogue effect, and outside the catalogue, in one draw of the hold-out bench."""
TITLE = "HOLD-OUT WORLD (never tuned on)"

MATERIALS = {  # measured properties and true Eq. 9 coefficients (file units)
    "mpacs_c": dict(density_kg_m3=400.0, microstructure_strength_kpa=6000.0, friction_coefficient=0.4,
                    strength_factor=0.6, sidewall_pressure_kpa=31.6, damping_kpa_s_m=0.0, inertia_coefficient=34.4),
    "grill_brick": dict(density_kg_m3=110.0, microstructure_strength_kpa=1630.0, friction_coefficient=0.75,
                        strength_factor=1.08, sidewall_pressure_kpa=7.93, damping_kpa_s_m=0.0,
                        inertia_coefficient=46.5),
}


def unknown_material(rng: np.random.Generator) -> dict:
    """A simulant no table holds."""
    return dict(density_kg_m3=float(rng.uniform(150, 500)), microstructure_strength_kpa=float(rng.uniform(1200, 5000)),
                friction_coefficient=float(rng.uniform(0.3, 0.7)), strength_factor=float(rng.uniform(0.5, 1.2)),
                sidewall_pressure_kpa=float(rng.uniform(6, 35)),
                damping_kpa_s_m=float(rng.choice([0.0, rng.uniform(0.3, 2.0)])),
                inertia_coefficient=float(rng.uniform(25, 50)))


# ----------------------------------------------------------------------------- effects, drawn at random
def draw_effect(name: str, rng: np.random.Generator, intensity: float = 1.0) -> dict:
    """Random form and size of an effect; ``intensity`` scales its size (1 = clearly present)."""
    s = intensity
    if name == "strength_layer":
        ratio = float(rng.choice([rng.uniform(0.45, 0.7), rng.uniform(1.4, 1.9)]))
        return dict(name=name, depth_mm=float(rng.uniform(25, 95)), ratio=1 + (ratio - 1) * s,
                    ramp_mm=float(rng.uniform(0, 10)), thickness_mm=float(rng.choice([1e9, rng.uniform(25, 60)])))
    if name == "strength_gradient":
        return dict(name=name, form=str(rng.choice(["power", "tanh"])), change=float(rng.uniform(0.8, 2.0)) * s,
                    exponent=float(rng.uniform(0.7, 2.5)), length_mm=float(rng.uniform(30, 90)))
    if name == "plug_growth":
        return dict(name=name, growth_mm=float(rng.uniform(1.5, 3.5)) * s, length_mm=float(rng.uniform(10, 50)),
                    form=str(rng.choice(["ramp", "sqrt"])))
    if name == "sidewall_pressure_growth":
        return dict(name=name, form=str(rng.choice(["exponential", "quadratic"])),
                    length_mm=float(rng.uniform(40, 100)), scale=s)
    if name == "velocity_friction":
        sign = float(rng.choice([-1.0, 1.0]))
        return dict(name=name, change=sign * float(rng.uniform(0.35, 0.6)) * s, exponent=float(rng.uniform(0.5, 1.5)))
    if name == "rate_strength":
        return dict(name=name, form=str(rng.choice(["log", "saturating"])), change=float(rng.uniform(0.25, 0.5)) * s,
                    speed_m_s=float(rng.uniform(0.5, 3.0)))
    if name == "load_cell_mass_error":
        ratio = float(rng.choice([rng.uniform(0.55, 0.75), rng.uniform(1.3, 1.6)]))
        return dict(name=name, ratio=1 + (ratio - 1) * s)
    if name == "sensor_lag":
        return dict(name=name, form=str(rng.choice(["first_order", "delay", "bessel"])),
                    time_ms=float(rng.uniform(0.15, 0.6)) * s)
    if name == "rig_ringing":
        n = int(rng.integers(1, 4))
        return dict(name=name, frequencies_hz=sorted(float(f) for f in rng.uniform(300, 3000, n)),
                    damping_ratio=float(rng.uniform(0.01, 0.06)), share=float(rng.uniform(0.08, 0.2)) * s)
    if name == "force_drift":
        return dict(name=name, form=str(rng.choice(["linear", "thermal", "quadratic"])),
                    amount_n=float(rng.uniform(30, 80)) * s * float(rng.choice([-1.0, 1.0])),
                    time_constant_s=float(rng.uniform(0.03, 0.2)))
    if name == "propulsion_loss":  # a share of the springs' energy, or a friction on the carriage over a span
        if rng.uniform() < 0.5:
            return dict(name=name, form="efficiency", loss=float(rng.uniform(0.1, 0.25)) * s)
        return dict(name=name, form="guide_friction", friction_n=float(np.exp(rng.uniform(np.log(25), np.log(100))))
                    * s, span=str(rng.choice(["stroke", "flight", "whole"])))
    if name == OUTSIDE:
        return dict(name=name, period_mm=float(rng.uniform(8, 20)), amplitude=0.35 * s)
    if name == "fragment_impacts":  # the depths are each run's own (_per_run)
        return dict(name=name, per_100mm=float(rng.uniform(3, 8)), width_mm=float(rng.uniform(1, 4)),
                    amplitude=float(rng.uniform(0.5, 1.0)) * s)
    if name == "strength_relaxation":
        return dict(name=name, drop=float(rng.uniform(0.3, 0.5)) * s, time_constant_ms=float(rng.uniform(5, 40)))
    if name == "gauge_nonlinearity":  # measured = F·(1 + gain·F/1 kN), either sign
        return dict(name=name, gain_per_kn=float(rng.choice([-1.0, 1.0])) * float(rng.uniform(0.08, 0.2)) * s)
    if name == "blade_wander":  # the tilts are each run's own (_per_run)
        return dict(name=name, spread=float(rng.uniform(0.3, 0.6)) * s)
    raise ValueError(name)


def _per_run(effect: dict, rng: np.random.Generator, depth_m: float) -> dict:
    """One run's draw of an effect whose form differs from run to run (the others pass unchanged)."""
    if effect["name"] == "fragment_impacts":
        count = int(rng.poisson(effect["per_100mm"] * depth_m / 0.1))
        return {**effect, "depths_mm": sorted(float(d) for d in rng.uniform(0, depth_m * 1e3, count))}
    if effect["name"] == "blade_wander":
        return {**effect, "pressure_factor": 1.0 + effect["spread"] * float(rng.uniform(-1.0, 1.0))}
    return effect


@dataclass
class Shot:
    """One run's truth: blade, launcher, material and the sensor chain."""

    width_m: float
    thickness_m: float
    tip_rad: float
    depth_m: float
    sprung_kg: float
    load_cell_kg: float
    springs: int
    stiffness_n_m: float
    spring_kg: float
    free_m: float
    compressed_m: float
    standoff_m: float
    """True stand-off (the file says the nominal). [m]"""
    standoff_file_m: float
    efficiency: float
    material: dict
    strength_pa: float
    """This block's true strength (the file says the table's). [Pa]"""
    rate_hz: float
    noise_n: float
    noise_colour: float
    encoder_m: float
    cutoff_hz: float
    effects: list = field(default_factory=list)

    def effect(self, name):
        return next((e for e in self.effects if e["name"] == name), None)


def _resistance(shot: Shot):
    m = shot.material
    w, T, th = shot.width_m, shot.thickness_m, shot.tip_rad
    S, mu0, rho = shot.strength_pa, m["friction_coefficient"], m["density_kg_m3"]
    Cs, P, C, K = m["strength_factor"], m["sidewall_pressure_kpa"] * 1e3, m["damping_kpa_s_m"] * 1e3, \
        m["inertia_coefficient"]
    layer, grad, plug = shot.effect("strength_layer"), shot.effect("strength_gradient"), shot.effect("plug_growth")
    press, vf, rate = shot.effect("sidewall_pressure_growth"), shot.effect("velocity_friction"), \
        shot.effect("rate_strength")
    crush = shot.effect(OUTSIDE)
    fragments, relax = shot.effect("fragment_impacts"), shot.effect("strength_relaxation")
    wander = shot.effect("blade_wander")
    if wander:
        P *= wander["pressure_factor"]

    def strength(x, v, t_in):
        f = 1.0
        if layer:
            top, ramp = layer["depth_mm"] * 1e-3, max(layer["ramp_mm"], 1e-3) * 1e-3
            into = min(max((x - top) / ramp, 0.0), 1.0)
            out = min(max((x - top - layer["thickness_mm"] * 1e-3) / ramp, 0.0), 1.0)
            f *= 1.0 + (layer["ratio"] - 1.0) * (into - out)
        if grad:
            if grad["form"] == "power":
                f *= 1.0 + grad["change"] * (x / 0.1) ** grad["exponent"]
            else:
                f *= 1.0 + grad["change"] * math.tanh(x / (grad["length_mm"] * 1e-3)) / math.tanh(
                    0.1 / (grad["length_mm"] * 1e-3))
        if rate:
            u = v / rate["speed_m_s"]
            f *= 1.0 + rate["change"] * (math.log1p(u) / math.log1p(5 / rate["speed_m_s"]) if rate["form"] == "log"
                                         else (1 - math.exp(-u)) / (1 - math.exp(-5 / rate["speed_m_s"])))
        if crush:
            f *= 1.0 + crush["amplitude"] * math.sin(2 * math.pi * x / (crush["period_mm"] * 1e-3))
        if fragments:
            width = fragments["width_mm"] * 1e-3
            f *= 1.0 + fragments["amplitude"] * sum(math.exp(-0.5 * ((x - d * 1e-3) / width) ** 2)
                                                    for d in fragments["depths_mm"])
        if relax:
            f *= 1.0 - relax["drop"] * -math.expm1(-t_in / (relax["time_constant_ms"] * 1e-3))
        return S * f

    def mu(v):
        if vf:
            return max(mu0 * (1.0 + vf["change"] * (v / 5.0) ** vf["exponent"]), 0.02)
        return mu0

    def sidewall(x):  # ∫0^x P(z) dz
        if not press:
            return P * x
        L = press["length_mm"] * 1e-3
        if press["form"] == "exponential":
            return P * (x + press["scale"] * (L * math.expm1(x / L) - x))
        return P * (x + press["scale"] * x ** 3 / (3 * L * L))

    def thickness(x):
        if not plug:
            return T
        L, g = plug["length_mm"] * 1e-3, plug["growth_mm"] * 1e-3
        return T + g * (min(x / L, 1.0) if plug["form"] == "ramp" else math.sqrt(x / (x + L)))

    def resistance(x, v, t_in=0.0):
        """Resistance at depth x [m], speed v [m/s] and t_in [s] after contact. [N]"""
        x, v = max(x, 0.0), max(v, 0.0)
        mv = mu(v)
        return (w * thickness(x) * (Cs * strength(x, v, max(t_in, 0.0)) * (math.sin(th) + mv * math.cos(th)) + C * v + K * rho * v * v)
                + 2 * mv * w * sidewall(x))

    return resistance


def motion(shot: Shot):
    """(time grid from the release [s], displacement [m], velocity, acceleration, resistance, contact time, end)."""
    from scipy.integrate import solve_ivp

    n, k = shot.springs, shot.stiffness_n_m
    loss = shot.effect("propulsion_loss")
    eta = shot.efficiency * (1 - (loss.get("loss", 0.0) if loss else 0.0))
    m_eff = shot.sprung_kg + n * shot.spring_kg / 3
    stroke = shot.free_m - shot.compressed_m
    R = _resistance(shot)
    s0 = shot.standoff_m
    friction = loss.get("friction_n", 0.0) if loss else 0.0  # on the carriage while it moves, over its span
    span = {"stroke": stroke, "flight": s0, "whole": math.inf}[loss.get("span", "whole")] if friction else 0.0

    def accel(u, v, inside, t=0.0):
        spring = eta * n * k * (stroke - u) if u < stroke else 0.0
        guide = friction if (u < span and v > 0) else 0.0
        return (spring + m_eff * G - guide - (R(u - s0, v, t - t_c) if inside else 0.0)) / m_eff

    def flight(t, y):
        return [y[1], accel(y[0], y[1], False)]

    def surface(t, y):
        return y[0] - s0
    surface.terminal, surface.direction = True, 1

    first = solve_ivp(flight, (0, 2.0), [0.0, 0.0], method="LSODA", events=surface, dense_output=True, rtol=1e-10,
                      atol=1e-12, max_step=2e-4)
    t_c = float(first.t_events[0][0])
    v_c = float(first.y_events[0][0][1])

    def pen(t, y):
        return [y[1], accel(y[0], y[1], True, t)]

    def arrest(t, y):
        return y[1]
    arrest.terminal, arrest.direction = True, -1

    def stops(t, y):
        return y[0] - s0 - shot.depth_m
    stops.terminal, stops.direction = True, 1

    second = solve_ivp(pen, (t_c, t_c + 2.0), [s0, v_c], method="LSODA", events=[arrest, stops], dense_output=True,
                       rtol=1e-10, atol=1e-12, max_step=5e-5)
    end = "arrest" if second.t_events[0].size else "full_depth"
    t_s = float(second.t[-1])
    dt = 1.0 / shot.rate_hz
    t = np.arange(0.0, t_s + 0.15, dt)
    u = np.empty_like(t)
    v = np.empty_like(t)
    a = np.zeros_like(t)
    res = np.zeros_like(t)
    for i, ti in enumerate(t):
        if ti < t_c:
            u[i], v[i] = first.sol(ti)
            a[i] = accel(u[i], v[i], False)
        elif ti <= t_s:
            u[i], v[i] = second.sol(ti)
            v[i] = max(v[i], 0.0)
            a[i] = accel(u[i], v[i], True, ti)
            res[i] = R(u[i] - s0, v[i], ti - t_c)
        else:
            u[i], v[i] = second.y[0, -1], 0.0
            if end == "arrest":  # the material holds the springs (CONTRACT §2)
                spring = eta * n * k * (stroke - u[i]) if u[i] < stroke else 0.0
                res[i] = spring + m_eff * G
    return t, u, v, a, res, t_c, v_c, end


def measure(shot: Shot, rng: np.random.Generator, pre_s: float = 0.15) -> dict[str, np.ndarray]:
    """The CONTRACT §3 columns as the rig records them (calibrated, untared)."""
    from scipy.signal import butter, lfilter

    t, u, v, a, res, t_c, v_c, end = motion(shot)
    n_pre = int(pre_s * shot.rate_hz)
    time = np.concatenate([(np.arange(-n_pre, 0)) / shot.rate_hz, t])
    disp = np.concatenate([np.zeros(n_pre), u])
    acc = np.concatenate([np.zeros(n_pre), a])
    resist = np.concatenate([np.zeros(n_pre), res])
    mass = shot.effect("load_cell_mass_error")
    m_lc = shot.load_cell_kg * (mass["ratio"] if mass else 1.0)
    force = resist + m_lc * (acc - G)
    gauge = shot.effect("gauge_nonlinearity")
    if gauge:  # the load cell's gain rises (or falls) with the force it carries
        force = force * (1.0 + gauge["gain_per_kn"] * force / 1e3)
    ring = shot.effect("rig_ringing")
    if ring:
        tc = time - t_c
        after = tc > 0
        step = float(res[np.searchsorted(t, t_c)]) if np.searchsorted(t, t_c) < res.size else 0.0
        for i, f in enumerate(ring["frequencies_hz"]):
            w0 = 2 * math.pi * f
            zeta = ring["damping_ratio"]
            amp = ring["share"] * step / (i + 1)
            force += np.where(after, amp * np.exp(-zeta * w0 * np.maximum(tc, 0)) * np.sin(w0 * np.maximum(tc, 0)),
                              0.0)
    lag = shot.effect("sensor_lag")
    if lag:
        tau = lag["time_ms"] * 1e-3
        if lag["form"] == "first_order":
            alpha = math.exp(-1 / (tau * shot.rate_hz))
            force = lfilter([1 - alpha], [1, -alpha], force - force[0]) + force[0]
        elif lag["form"] == "delay":
            k = tau * shot.rate_hz
            force = np.interp(np.arange(force.size) - k, np.arange(force.size), force)
        else:  # second-order Bessel low-pass with group delay ≈ tau
            from scipy.signal import bessel

            corner = 1.0 / (2 * math.pi * tau) / (shot.rate_hz / 2)
            if corner < 1.0:  # past the Nyquist frequency it passes all the record holds: nothing to filter
                b, aa = bessel(2, corner, norm="delay")
                force = lfilter(b, aa, force - force[0]) + force[0]
    drift = shot.effect("force_drift")
    if drift:
        tp = np.maximum(time, 0.0)
        shape = {"linear": tp / 0.1, "quadratic": (tp / 0.1) ** 2,
                 "thermal": -np.expm1(-tp / drift["time_constant_s"])}[drift["form"]]
        force = force + drift["amount_n"] * shape
    # gauge noise (white or coloured), then the anti-alias filter, then the converter's own small noise
    white = rng.normal(0.0, 1.0, time.size)
    phi = shot.noise_colour
    coloured = lfilter([math.sqrt(1 - phi * phi)], [1, -phi], white)
    b, aa = butter(2, shot.cutoff_hz / (shot.rate_hz / 2))
    offset = float(rng.uniform(-30, 30))
    fz = lfilter(b, aa, force + shot.noise_n * coloured - force[0], zi=None) + force[0] + offset
    fz += rng.normal(0, 0.05 * shot.noise_n, time.size)
    counts = np.floor(disp / shot.encoder_m + rng.uniform(0, 1))
    counts -= counts[0]
    cols = {"time_s": time, "position_mm": counts * shot.encoder_m * 1e3, "fz_n": fz}
    for name, scale in (("fx_n", 1.0), ("fy_n", 1.0), ("tx_nm", 0.01), ("ty_nm", 0.01), ("tz_nm", 0.01)):
        cols[name] = rng.normal(float(rng.uniform(-5, 5)) * scale, shot.noise_n * scale, time.size)
    return cols


def write_run(folder: Path, shot: Shot, columns: dict, run_id: str, material_name: str) -> Path:
    """A CONTRACT §3 run folder; the files carry nominal values (the truth differs by the nuisances)."""
    m = shot.material
    files = {
        "penetrator": {"kind": "penetrator", "name": f"blade_{shot.thickness_m * 1e3:g}mm",
                       "blade_width_mm": shot.width_m * 1e3, "blade_thickness_mm": shot.thickness_m * 1e3,
                       "tip_angle_deg": math.degrees(shot.tip_rad), "penetration_depth_mm": shot.depth_m * 1e3,
                       "sprung_mass_kg": shot.sprung_kg, "load_cell_mass_kg": shot.load_cell_kg},
        "material": {"kind": "material", "name": material_name, "density_kg_m3": m["density_kg_m3"],
                     "microstructure_strength_kpa": m["microstructure_strength_kpa"],
                     "friction_coefficient": m["friction_coefficient"], "gravity_m_s2": G},
        "energizing": {"kind": "energizing", "name": f"springs_{shot.springs}", "spring_count": shot.springs,
                       "spring_stiffness_kn_m": shot.stiffness_n_m / 1e3, "spring_mass_kg": shot.spring_kg,
                       "spring_nominal_length_mm": shot.free_m * 1e3,
                       "spring_compressed_length_mm": shot.compressed_m * 1e3,
                       "surface_offset_mm": shot.standoff_file_m * 1e3,
                       "propulsion_efficiency_pct": shot.efficiency * 100},
        "run": {"id": run_id, "operator": "holdout world", "notes": "hold-out truth world"},
    }
    return write_lab_folder(folder, columns, files)



def make_campaign(folder: Path, seed: int, effects=(), *, intensity: float = 1.0, runs: int | None = None
                  ) -> Campaign:
    """A campaign of 4–8 runs (``runs`` when given) with random nuisances and the named effects in random forms.

    Nuisances come from ``seed`` alone and the effects' forms from a second stream, so a campaign with and
    without its effects shares every nuisance and noise draw.  ``runs`` changes none of the campaign's own draws,
    and the runs it shares with the campaign of the drawn size are the same runs.
    """
    rng = np.random.default_rng(seed)
    effect_rng = np.random.default_rng([seed, 7])
    material_name = str(rng.choice(["mpacs_c", "grill_brick", "unknown"]))
    material = unknown_material(rng) if material_name == "unknown" else dict(MATERIALS[material_name])
    if material_name == "unknown":
        material_name = f"simulant_{seed}"
    n_runs = int(rng.integers(4, 9))
    n_runs = n_runs if runs is None else int(runs)
    rate = rng.choice([30000.0, 60000.0, 0.0])  # 0: mixed rates
    scatter = float(rng.uniform(0.03, 0.06))
    standoff_sigma = float(rng.uniform(0.3e-3, 1.5e-3))
    noise = float(rng.uniform(0.5, 6.0))
    colour = float(rng.choice([0.0, rng.uniform(0.3, 0.9)]))
    encoder = float(rng.choice([0.08e-3, 0.1e-3, 0.16e-3, 0.2e-3, 0.25e-3, 0.32e-3]))
    width = float(rng.choice([0.184, 0.12, 0.092]))
    drawn = [draw_effect(name, effect_rng, intensity) for name in effects]
    folders = []
    thicknesses = [1e-3, 1.5e-3, 2e-3, 2.5e-3]
    for i in range(n_runs):
        run_rate = float(rate) if rate else float(rng.choice([30000.0, 60000.0]))
        springs = int((2, 4, 6)[i % 3]) if i < 3 else int(rng.choice([2, 4, 6]))
        shot = Shot(width_m=width, thickness_m=thicknesses[i % 4] if i < 4 else float(rng.choice(thicknesses)),
                    tip_rad=math.radians(89.9), depth_m=0.133, sprung_kg=2.443, load_cell_kg=0.389, springs=springs,
                    stiffness_n_m=1450.0, spring_kg=0.28, free_m=0.5, compressed_m=0.2481,
                    standoff_m=0.148 + float(rng.normal(0, standoff_sigma)), standoff_file_m=0.148, efficiency=0.98,
                    material=material,
                    strength_pa=material["microstructure_strength_kpa"] * 1e3 * (1 + float(rng.normal(0, scatter))),
                    rate_hz=run_rate, noise_n=noise, noise_colour=colour, encoder_m=encoder,
                    cutoff_hz=float(rng.uniform(0.15, 0.4)) * run_rate,
                    effects=[_per_run(e, np.random.default_rng([seed, 11, i]), 0.133) for e in drawn])
        columns = measure(shot, np.random.default_rng([seed, i]))
        folders.append(write_run(folder / f"h{seed}-{i}", shot, columns, f"h{seed}-{i}", material_name))
    nuisances = dict(material=material_name, runs=n_runs, rate_hz=float(rate) or "mixed", block_scatter=scatter,
                     standoff_sigma_mm=standoff_sigma * 1e3, noise_n=noise, noise_ar1=colour, encoder_mm=encoder * 1e3,
                     width_mm=width * 1e3)
    return Campaign(folders, drawn, nuisances)
