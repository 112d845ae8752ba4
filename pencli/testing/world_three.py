"""World three: a third rig simulator, written after the diagnosis was frozen, to measure it once.

The development world (pencli/acquire/truth.py, sim.py) and the hold-out
world (pencli/testing/holdout_world.py) were both written by the sessions that
developed the diagnosis, and the hold-out world has been drawn more than
sixty times with its misses read after each draw.  This world was written
by a developer who had not worked on the method, to stand in for the outside check's independent simulator: other code,
another sensor chain, other effect forms.  It is not innocent of the
method: its author had read the README's description of the families and
the other two worlds' effect lists, and chose forms by their physical
meaning, neither to match nor to dodge a family.  Its one sanity check
through pen before the draw was `pen fit` on null campaigns (which found
a DC gain error of its Chebyshev filter, see `_anti_alias`); no diagnosis was run on it before
its first measurement (bench/bench_diagnose_holdout.py --world three),
which is the one reported as blind.  Anything drawn from it after a change
made while looking at its results is not.

Nothing here is imported by pen.  What it does differently:

- dynamics: scipy's DOP853 with event location, from the release at rest;
  the launcher's push rod may carry a guide friction;
- a lab's campaign plan: 2–3 blade thicknesses of 1, 1.5, 2, 3 mm, sometimes
  two widths, three sprung masses (the rig's variable accelerated mass),
  spring counts 2/4/6, stand-offs of 120–200 mm, tip angles 89.9° or 60°;
  Table 1's own coefficients (Grill Brick Cs 1.6, MPACS B, MPACS C) or a
  simulant no table holds;
- sensor chain: gauge noise white plus pink (1/f) or a narrow-band
  resonance; a four-pole Bessel or Chebyshev anti-alias filter, or none;
  a converter floor; a quadrature encoder (×4 decoding, 0.08–0.32 mm a count)
  whose four edges per grating line sit off their nominal places by a few
  per cent of a count (duty-cycle error); time exported to 6 or 8
  significant digits; pre-trigger 0.1–0.25 s, 0.12–0.3 s kept after the stop;
- effects in forms of their own (see :func:`draw_effect`): crusts, lenses
  and substrates with erf edges; linear, square-root, logistic and
  exponential-approach gradients of either sign; capped power, tanh and
  unbounded plug growth; Janssen, onset and power sidewall pressure;
  rate-and-state and tanh speed laws of friction; power, threshold and
  log10 rate strength; a load cell with a mechanical resonance, a gauge
  that creeps, or a pole with a delay; modes struck by the impact and by
  the force step, one to three, weighted at random; drifts that settle, ramp, or follow
  the heat of the work done; a launcher that loses energy to efficiency or
  to guide friction.  Outside the catalogue: weak seams between the lifts
  the block was cast in, repeating every 12–25 mm.

Units: SI inside; effect parameters carry their unit in their name.
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
OUTSIDE = "cast_lift_seams"
"""Outside the catalogue: narrow weak seams between casting lifts, every 12–25 mm of depth."""

PAIRS = tuple(tuple(sorted(p)) for p in (
    ("plug_growth", "velocity_friction"), ("sensor_lag", "strength_gradient"), ("rate_strength", "rig_ringing"),
    ("force_drift", "strength_layer"), ("load_cell_mass_error", "sidewall_pressure_growth"),
    ("propulsion_loss", "strength_layer")))
"""Two-effect campaigns: every catalogue effect in at least one pair, written down before any was run."""
DRAWS, OUTSIDE_DRAWS = 3, 3
"""Campaigns per catalogue effect, and outside the catalogue, in one draw of the hold-out bench."""
TITLE = "WORLD THREE (drawn blind once, --base 950000)"

TABLE_1 = {  # paper Table 1 (6061 Al blades): measured properties and the fitted Eq. 9 coefficients
    "grill_brick": dict(density=110.0, strength_kpa=1630.0, mu=0.75, Cs=1.6, P_kpa=7.07, C_kpa_s_m=0.0, K=46.0),
    "mpacs_b": dict(density=290.0, strength_kpa=2000.0, mu=0.4, Cs=0.6, P_kpa=12.5, C_kpa_s_m=0.0, K=10.0),
    "mpacs_c": dict(density=400.0, strength_kpa=6000.0, mu=0.4, Cs=0.6, P_kpa=31.6, C_kpa_s_m=0.0, K=34.4),
}


def foam_simulant(rng: np.random.Generator) -> dict:
    """A simulant no table holds (a foam glass or a sintered snow)."""
    return dict(density=float(rng.uniform(120, 450)), strength_kpa=float(rng.uniform(1000, 5000)),
                mu=float(rng.uniform(0.3, 0.75)), Cs=float(rng.uniform(0.5, 1.6)), P_kpa=float(rng.uniform(5, 35)),
                C_kpa_s_m=float(rng.choice([0.0, rng.uniform(0.2, 1.5)])), K=float(rng.uniform(10, 50)))


def _ratio(rng, low=(0.45, 0.72), high=(1.4, 2.0)) -> float:
    return float(rng.uniform(*low)) if rng.random() < 0.5 else float(rng.uniform(*high))


# ----------------------------------------------------------------------------- effects, drawn at random
def draw_effect(name: str, rng: np.random.Generator, intensity: float = 1.0) -> dict:
    """A random form and size of ``name``; ``intensity`` scales its departure from the reference model."""
    s = intensity
    if name == "strength_layer":
        form = str(rng.choice(["crust", "lens", "substrate"]))
        r = 1 + (_ratio(rng) - 1) * s
        if form == "crust":  # the top of the block, to depth_mm, is r × S
            return dict(name=name, form=form, ratio=r, depth_mm=float(rng.uniform(15, 45)),
                        edge_mm=float(rng.uniform(0.5, 8)))
        if form == "lens":
            return dict(name=name, form=form, ratio=r, depth_mm=float(rng.uniform(20, 80)),
                        thickness_mm=float(rng.uniform(15, 60)), edge_mm=float(rng.uniform(0.5, 8)))
        return dict(name=name, form=form, ratio=r, depth_mm=float(rng.uniform(25, 100)),
                    edge_mm=float(rng.uniform(0.5, 12)))
    if name == "strength_gradient":
        form = str(rng.choice(["linear", "sqrt", "logistic", "approach"]))
        change = (float(rng.uniform(0.6, 1.5)) if rng.random() < 0.7 else -float(rng.uniform(0.3, 0.5))) * s
        return dict(name=name, form=form, change_at_100mm=change, centre_mm=float(rng.uniform(30, 80)),
                    width_mm=float(rng.uniform(12, 30)), length_mm=float(rng.uniform(15, 80)))
    if name == "plug_growth":
        form = str(rng.choice(["capped_power", "tanh", "unbounded"]))
        return dict(name=name, form=form, growth_mm=float(rng.uniform(1.0, 3.0)) * s,
                    length_mm=float(rng.uniform(15, 80)), exponent=float(rng.uniform(0.4, 1.2)))
    if name == "sidewall_pressure_growth":
        form = str(rng.choice(["janssen", "onset", "power"]))
        return dict(name=name, form=form, rise_at_100mm=float(rng.uniform(1.5, 4.0)) * s,
                    length_mm=float(rng.uniform(20, 150)), onset_mm=float(rng.uniform(10, 50)),
                    exponent=float(rng.uniform(1.3, 3.0)))
    if name == "velocity_friction":
        form = str(rng.choice(["rate_state", "tanh"]))
        sign = 1.0 if rng.random() < 0.5 else -1.0
        return dict(name=name, form=form, change=sign * float(rng.uniform(0.3, 0.6)) * s,
                    speed_m_s=float(rng.uniform(0.2, 3.0) if form == "rate_state" else rng.uniform(1.0, 6.0)))
    if name == "rate_strength":
        form = str(rng.choice(["power", "threshold", "log10"]))
        return dict(name=name, form=form, change_at_10m_s=float(rng.uniform(0.3, 0.7)) * s,
                    exponent=float(rng.uniform(0.3, 1.2)), threshold_m_s=float(rng.uniform(1.0, 4.0)),
                    speed_m_s=float(rng.uniform(0.1, 1.0)))
    if name == "load_cell_mass_error":
        return dict(name=name, ratio=1 + (_ratio(rng, (0.5, 0.75), (1.3, 1.7)) - 1) * s)
    if name == "sensor_lag":
        form = str(rng.choice(["resonant_cell", "creep", "pole_and_delay"]))
        lag_ms = float(rng.uniform(0.12, 0.6)) * s
        return dict(name=name, form=form, lag_ms=lag_ms, damping_ratio=float(rng.uniform(0.55, 0.9)),
                    creep_share=float(rng.uniform(0.4, 0.8)), delay_share=float(rng.uniform(0.2, 0.8)))
    if name == "rig_ringing":
        n = int(rng.integers(1, 4))
        return dict(name=name, frequencies_hz=sorted(float(f) for f in rng.uniform(400, 4000, n)),
                    damping_ratios=[float(z) for z in rng.uniform(0.01, 0.08, n)],
                    weights=[float(p) for p in rng.uniform(0.3, 1.0, n)],
                    n_per_m_s=float(rng.uniform(4, 14)) * s, step_share=float(rng.uniform(0.0, 0.15)) * s)
    if name == "force_drift":
        form = str(rng.choice(["settle", "ramp", "heating"]))
        return dict(name=name, form=form, amount_n=float(rng.uniform(20, 70)) * s * (1 if rng.random() < 0.5 else -1),
                    time_constant_s=float(rng.uniform(0.02, 0.4)), relax_s=float(rng.uniform(0.2, 1.0)))
    if name == "propulsion_loss":
        return dict(name=name, form=str(rng.choice(["efficiency", "guide_friction"])),
                    energy_lost=float(rng.uniform(0.08, 0.25)) * s)
    if name == OUTSIDE:
        return dict(name=name, spacing_mm=float(rng.uniform(12, 25)), first_mm=float(rng.uniform(4, 12)),
                    seam_mm=float(rng.uniform(1.5, 4.0)), ratio=1 - float(rng.uniform(0.4, 0.7)) * s)
    raise ValueError(f"world three has no effect {name!r}")


@dataclass
class Shot:
    """One run's truth: blade, launcher, block and sensor chain.

    Its first fields are those of the hold-out world's ``Shot`` (a rig has these quantities), written again on
    purpose: the truth worlds share no code with each other or with pen, so that no change to one moves another.
    """

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
    """True stand-off; the file says ``standoff_file_m``. [m]"""
    standoff_file_m: float
    efficiency: float
    material: dict
    strength_pa: float
    """This block's true microstructure strength (the file says the table's). [Pa]"""
    rate_hz: float
    noise: dict
    encoder: dict
    filter: dict
    pre_s: float
    post_s: float
    time_digits: int
    effects: list = field(default_factory=list)

    def effect(self, name):
        return next((e for e in self.effects if e["name"] == name), None)


def _edge(x: float, at: float, width: float) -> float:
    """0 above ``at``, 1 below it, an erf ramp of about ``width`` between. [m]"""
    return 0.5 * (1.0 + math.erf((x - at) / max(width / 2.0, 1e-5)))


def resistance_function(shot: Shot):
    """R(x, v) of this shot's block [N] (x [m] below the surface, v [m/s])."""
    m = shot.material
    w, T, th = shot.width_m, shot.thickness_m, shot.tip_rad
    rho, mu0 = m["density"], m["mu"]
    Cs, P, C, K = m["Cs"], m["P_kpa"] * 1e3, m["C_kpa_s_m"] * 1e3, m["K"]
    S = shot.strength_pa
    layer, grad, plug = shot.effect("strength_layer"), shot.effect("strength_gradient"), shot.effect("plug_growth")
    press, fric, rate = shot.effect("sidewall_pressure_growth"), shot.effect("velocity_friction"), \
        shot.effect("rate_strength")
    seams = shot.effect(OUTSIDE)

    def depth_factor(x: float) -> float:
        f = 1.0
        if layer:
            d, e, r = layer["depth_mm"] * 1e-3, layer["edge_mm"] * 1e-3, layer["ratio"]
            if layer["form"] == "crust":
                f *= r + (1.0 - r) * _edge(x, d, e)
            elif layer["form"] == "lens":
                f *= 1.0 + (r - 1.0) * (_edge(x, d, e) - _edge(x, d + layer["thickness_mm"] * 1e-3, e))
            else:
                f *= 1.0 + (r - 1.0) * _edge(x, d, e)
        if grad:
            c, form = grad["change_at_100mm"], grad["form"]
            if form == "linear":
                g = x / 0.1
            elif form == "sqrt":
                g = math.sqrt(max(x, 0.0) / 0.1)
            elif form == "logistic":
                xc, wd = grad["centre_mm"] * 1e-3, grad["width_mm"] * 1e-3
                lo = 1 / (1 + math.exp(xc / wd))
                g = (1 / (1 + math.exp(-(x - xc) / wd)) - lo) / (1 / (1 + math.exp(-(0.1 - xc) / wd)) - lo)
            else:
                L = grad["length_mm"] * 1e-3
                g = -math.expm1(-x / L) / -math.expm1(-0.1 / L)
            f *= max(1.0 + c * g, 0.2)
        if seams:
            sp, first, wd = seams["spacing_mm"] * 1e-3, seams["first_mm"] * 1e-3, seams["seam_mm"] * 1e-3
            k = round((x - first) / sp)
            nearest = first + max(k, 0) * sp
            f *= 1.0 - (1.0 - seams["ratio"]) * math.exp(-0.5 * ((x - nearest) / (wd / 2.355)) ** 2)
        return f

    def rate_factor(v: float) -> float:
        if not rate:
            return 1.0
        c, form = rate["change_at_10m_s"], rate["form"]
        if form == "power":
            return 1.0 + c * (v / 10.0) ** rate["exponent"]
        if form == "threshold":
            vt = rate["threshold_m_s"]
            return 1.0 + c * max(v - vt, 0.0) / (10.0 - vt)
        v0 = rate["speed_m_s"]
        return 1.0 + c * math.log10(1 + v / v0) / math.log10(1 + 10.0 / v0)

    def mu(v: float) -> float:
        if not fric:
            return mu0
        c, v0 = fric["change"], fric["speed_m_s"]
        if fric["form"] == "rate_state":
            return max(mu0 * (1.0 + c * math.log1p(v / v0) / math.log1p(10.0 / v0)), 0.05)
        return max(mu0 * (1.0 + c * math.tanh(v / v0)), 0.05)

    def pressure_integral(x: float) -> float:
        """∫₀ˣ P(z) dz [N/m]."""
        if not press:
            return P * x
        a, form = press["rise_at_100mm"], press["form"]
        if form == "janssen":  # rises and saturates with depth, as the silo pressure of a granular column
            L = press["length_mm"] * 1e-3
            return P * (x + a * (x - L * -math.expm1(-x / L)) / -math.expm1(-0.1 / L))
        if form == "onset":  # compaction starts at onset_mm
            x0 = press["onset_mm"] * 1e-3
            return P * (x + a * 0.5 * max(x - x0, 0.0) ** 2 / (0.1 - x0))
        n = press["exponent"]
        return P * (x + a * x ** (n + 1) / ((n + 1) * 0.1 ** n))

    def thickness(x: float) -> float:
        if not plug:
            return T
        g, L, form = plug["growth_mm"] * 1e-3, plug["length_mm"] * 1e-3, plug["form"]
        if form == "capped_power":
            h = min((x / L) ** plug["exponent"], 1.0)
        elif form == "tanh":
            h = math.tanh(x / L)
        else:
            h = x / 0.1
        return T + g * h

    def resistance(x: float, v: float) -> float:
        if x <= 0.0:
            return 0.0
        v = max(v, 0.0)
        mv = mu(v)
        frontal = w * thickness(x) * (Cs * S * depth_factor(x) * rate_factor(v) * (math.sin(th) + mv * math.cos(th))
                                      + C * v + K * rho * v * v)
        return frontal + 2.0 * mv * w * pressure_integral(x)

    return resistance


@dataclass
class Motion:
    t: np.ndarray
    """Sample times from the release. [s]"""
    u: np.ndarray
    """Displacement from the release position. [m]"""
    v: np.ndarray
    """Speed. [m/s]"""
    a: np.ndarray
    """Acceleration. [m/s²]"""
    resistance: np.ndarray
    """R at each sample; after an arrest the material's hold on the springs. [N]"""
    work: np.ndarray
    """Work done on the block so far. [J]"""
    contact_s: float
    contact_speed_m_s: float
    stop_s: float
    end: str


def motion(shot: Shot) -> Motion:
    """The moving body from its release at rest to the stop, by DOP853 with event location."""
    from scipy.integrate import solve_ivp

    n, k = shot.springs, shot.stiffness_n_m
    loss = shot.effect("propulsion_loss")
    stroke = shot.free_m - shot.compressed_m
    eta, guide_n = shot.efficiency, 0.0
    if loss and loss["form"] == "efficiency":
        eta *= 1.0 - loss["energy_lost"]
    elif loss:  # a friction on the push rod over the spring's stroke takes that share of the spring's work
        guide_n = loss["energy_lost"] * eta * n * 0.5 * k * stroke ** 2 / stroke
    m_eff = shot.sprung_kg + n * shot.spring_kg / 3.0
    R = resistance_function(shot)
    s0 = shot.standoff_m

    def spring(u: float) -> float:
        return eta * n * k * (stroke - u) if u < stroke else 0.0

    def accel(u: float, v: float) -> float:
        push = spring(u) - (guide_n if (u < stroke and v > 0) else 0.0)
        return (push + m_eff * G - R(u - s0, v)) / m_eff

    def rhs(t, y):
        return [y[1], accel(y[0], y[1]), R(y[0] - s0, y[1]) * y[1]]

    def surface(t, y):
        return y[0] - s0
    surface.terminal, surface.direction = True, 1

    def arrest(t, y):
        return y[1] - 1e-9
    arrest.terminal, arrest.direction = True, -1

    def stops(t, y):
        return y[0] - s0 - shot.depth_m
    stops.terminal, stops.direction = True, 1

    fly = solve_ivp(rhs, (0.0, 3.0), [0.0, 0.0, 0.0], method="DOP853", events=surface, dense_output=True,
                    rtol=1e-10, atol=1e-13, max_step=1e-3)
    t_c = float(fly.t_events[0][0])
    y_c = fly.y_events[0][0]
    into = solve_ivp(rhs, (t_c, t_c + 3.0), [s0, float(y_c[1]), 0.0], method="DOP853", events=[arrest, stops],
                     dense_output=True, rtol=1e-10, atol=1e-13, max_step=1e-5)
    end = "arrest" if into.t_events[0].size else "full_depth"
    t_s = float(into.t[-1])
    dt = 1.0 / shot.rate_hz
    t = np.arange(0.0, t_s + shot.post_s, dt)
    u = np.empty_like(t)
    v = np.zeros_like(t)
    a = np.zeros_like(t)
    res = np.zeros_like(t)
    work = np.zeros_like(t)
    for i, ti in enumerate(t):
        if ti < t_c:
            ui, vi = fly.sol(ti)[:2]
            u[i], v[i], a[i] = ui, vi, accel(ui, vi)
        elif ti <= t_s:
            ui, vi, wi = into.sol(ti)
            vi = max(vi, 0.0)
            u[i], v[i], a[i], res[i], work[i] = ui, vi, accel(ui, vi), R(ui - s0, vi), wi
        else:
            u[i], work[i] = into.y[0, -1], into.y[2, -1]
            if end == "arrest":  # the material holds the springs (CONTRACT §2)
                res[i] = spring(u[i]) + m_eff * G
    return Motion(t, u, v, a, res, work, t_c, float(y_c[1]), t_s, end)


# ----------------------------------------------------------------------------- sensor chain
def _coloured_noise(rng: np.random.Generator, n: int, noise: dict, rate_hz: float) -> np.ndarray:
    """Gauge noise of RMS ``noise['rms_n']``: white plus a pink or narrow-band part of share ``colour_share``."""
    from scipy.signal import lfilter

    white = rng.normal(0.0, 1.0, n)
    share = noise["colour_share"]
    if noise["colour"] == "pink":
        spec = np.fft.rfft(rng.normal(0.0, 1.0, n))
        f = np.fft.rfftfreq(n, 1.0 / rate_hz)
        spec /= np.sqrt(np.maximum(f, 5.0))
        col = np.fft.irfft(spec, n)
    elif noise["colour"] == "band":
        r, w0 = noise["pole_radius"], 2 * math.pi * noise["band_hz"] / rate_hz
        col = lfilter([1.0], [1.0, -2 * r * math.cos(w0), r * r], rng.normal(0.0, 1.0, n))
    else:
        col = np.zeros(n)
        share = 0.0
    col = col / (np.std(col) or 1.0)
    return noise["rms_n"] * (math.sqrt(1 - share) * white + math.sqrt(share) * col)


def _lagged(force: np.ndarray, lag: dict, rate_hz: float) -> np.ndarray:
    """The load cell's or amplifier's lag, starting settled at the first sample."""
    from scipy.signal import bilinear, lfilter

    tau = lag["lag_ms"] * 1e-3
    x = force - force[0]
    if lag["form"] == "resonant_cell":  # the cell and what it carries as a damped oscillator: lag 2ζ/ωn
        z = lag["damping_ratio"]
        wn = 2 * z / tau
        b, a = bilinear([wn * wn], [1.0, 2 * z * wn, wn * wn], rate_hz)
        y = lfilter(b, a, x)
    elif lag["form"] == "creep":  # a share of the strain arrives with a time constant (mean lag = share × tc)
        c = lag["creep_share"]
        tc = tau / c
        alpha = math.exp(-1.0 / (tc * rate_hz))
        y = (1 - c) * x + c * lfilter([1 - alpha], [1, -alpha], x)
    else:  # an amplifier pole and a transport delay sharing the lag
        d = lag["delay_share"] * tau
        tc = tau - d
        alpha = math.exp(-1.0 / (tc * rate_hz))
        y = lfilter([1 - alpha], [1, -alpha], x)
        idx = np.arange(x.size) - d * rate_hz
        y = np.interp(idx, np.arange(x.size), y)
    return y + force[0]


def _anti_alias(signal: np.ndarray, spec: dict, rate_hz: float) -> np.ndarray:
    from scipy.signal import bessel, cheby1, lfilter, lfilter_zi

    if spec["kind"] == "none":
        return signal
    wc = spec["cutoff"]
    if spec["kind"] == "bessel":
        b, a = bessel(4, wc * 2, norm="mag")
    else:  # an even-order Chebyshev I sits at −1 dB at DC: the force calibration, made through it, takes that out
        b, a = cheby1(4, 1.0, wc * 2)
        b = b * (np.sum(a) / np.sum(b))
    return lfilter(b, a, signal, zi=lfilter_zi(b, a) * signal[0])[0]


def _encoder_counts(disp: np.ndarray, enc: dict) -> np.ndarray:
    """Counts of a ×4-decoded quadrature encoder whose four edges per line are off by ``edge_error`` counts."""
    y = disp / enc["step_m"] + enc["phase"]
    k = np.floor(y)
    line = k.astype(np.int64)
    dk = np.asarray(enc["edge_error"])
    counts = k - 1 + (y >= k + dk[line % 4]) + (y >= k + 1 + dk[(line + 1) % 4])
    return counts - counts[0]


def measure(shot: Shot, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """The CONTRACT §3 columns as this rig records them (calibrated, untared)."""
    mo = motion(shot)
    n_pre = int(round(shot.pre_s * shot.rate_hz))
    time = np.concatenate([np.arange(-n_pre, 0) / shot.rate_hz, mo.t])
    pad = np.zeros(n_pre)
    disp = np.concatenate([pad, mo.u])
    acc = np.concatenate([pad, mo.a])
    res = np.concatenate([pad, mo.resistance])
    work = np.concatenate([pad, mo.work])
    err = shot.effect("load_cell_mass_error")
    m_lc = shot.load_cell_kg * (err["ratio"] if err else 1.0)
    force = res + m_lc * (acc - G)
    ring = shot.effect("rig_ringing")
    if ring:
        tc = np.maximum(time - mo.contact_s, 0.0)
        on = time > mo.contact_s
        step = float(np.interp(mo.contact_s + 2e-4, mo.t, mo.resistance))
        for f, z, wt in zip(ring["frequencies_hz"], ring["damping_ratios"], ring["weights"]):
            # each mode answers the impact's impulse (a sine, ∝ contact speed) and the force step (the overshoot
            # of a step response, a cosine that starts at −share × the step)
            w0 = 2 * math.pi * f
            decay = np.exp(-z * w0 * tc)
            mode = wt * decay * (ring["n_per_m_s"] * mo.contact_speed_m_s * np.sin(w0 * tc)
                                 - ring["step_share"] * step * np.cos(w0 * tc))
            force = force + np.where(on, mode, 0.0)
    lag = shot.effect("sensor_lag")
    if lag:
        force = _lagged(force, lag, shot.rate_hz)
    drift = shot.effect("force_drift")
    if drift:
        tp = np.maximum(time, 0.0)
        if drift["form"] == "settle":
            shape = -np.expm1(-tp / drift["time_constant_s"])
        elif drift["form"] == "ramp":
            shape = tp / 0.1
        else:  # heat of the work done, leaving the cell after the stop
            after = np.maximum(time - mo.stop_s, 0.0)
            shape = work / max(float(mo.work[-1]), 1e-9) * np.exp(-after / drift["relax_s"])
        force = force + drift["amount_n"] * shape
    gauge = _coloured_noise(rng, time.size, shot.noise, shot.rate_hz)
    offset = float(rng.uniform(-50, 50))
    fz = _anti_alias(force + gauge, shot.filter, shot.rate_hz) + offset
    fz = fz + rng.normal(0.0, shot.noise["floor_share"] * shot.noise["rms_n"], time.size)
    counts = _encoder_counts(disp, shot.encoder)
    cols = {"time_s": time, "position_mm": counts * shot.encoder["step_m"] * 1e3, "fz_n": fz}
    cross = rng.uniform(0.005, 0.03, 2)
    for name, base in (("fx_n", cross[0] * force), ("fy_n", cross[1] * force)):
        cols[name] = base + float(rng.uniform(-8, 8)) + rng.normal(0, shot.noise["rms_n"], time.size)
    for name in ("tx_nm", "ty_nm", "tz_nm"):
        cols[name] = float(rng.uniform(-0.05, 0.05)) + rng.normal(0, 0.01 * shot.noise["rms_n"], time.size)
    return cols


def write_run(folder: Path, shot: Shot, columns: dict, run_id: str, material_name: str) -> Path:
    """A CONTRACT §3 run folder with the values the lab would write (nominal stand-off, table strength)."""
    m = shot.material
    files = {
        "penetrator": {"kind": "penetrator", "name": f"al6061_{shot.thickness_m * 1e3:g}mm_{shot.width_m * 1e3:g}w",
                       "blade_width_mm": round(shot.width_m * 1e3, 3),
                       "blade_thickness_mm": round(shot.thickness_m * 1e3, 3),
                       "tip_angle_deg": round(math.degrees(shot.tip_rad), 3),
                       "penetration_depth_mm": round(shot.depth_m * 1e3, 3),
                       "sprung_mass_kg": shot.sprung_kg, "load_cell_mass_kg": shot.load_cell_kg},
        "material": {"kind": "material", "name": material_name, "density_kg_m3": m["density"],
                     "microstructure_strength_kpa": m["strength_kpa"], "friction_coefficient": m["mu"],
                     "gravity_m_s2": G},
        "energizing": {"kind": "energizing", "name": f"launcher_{shot.springs}", "spring_count": shot.springs,
                       "spring_stiffness_kn_m": shot.stiffness_n_m / 1e3, "spring_mass_kg": shot.spring_kg,
                       "spring_nominal_length_mm": round(shot.free_m * 1e3, 4),
                       "spring_compressed_length_mm": round(shot.compressed_m * 1e3, 4),
                       "surface_offset_mm": round(shot.standoff_file_m * 1e3, 3),
                       "propulsion_efficiency_pct": round(shot.efficiency * 100, 3)},
        "run": {"id": run_id, "operator": "world three", "notes": "third truth world (pencli/testing/world_three.py)"},
    }
    return write_lab_folder(folder, columns, files, shot.time_digits)



def _sensor_chain(rng: np.random.Generator, rate_hz: float, noise_rms: float, colour: str, share: float) -> dict:
    return dict(rms_n=noise_rms, colour=colour, colour_share=share, band_hz=float(rng.uniform(150, 0.3 * rate_hz)),
                pole_radius=float(rng.uniform(0.9, 0.985)), floor_share=float(rng.uniform(0.02, 0.1)))


def make_campaign(folder: Path, seed: int, effects=(), *, intensity: float = 1.0) -> Campaign:
    """A lab's campaign of 4–8 runs with random nuisances and the named effects in random forms.

    Nuisances and noise come from ``seed`` alone, the effects' forms from a second stream, so a campaign
    with and without its effects shares every nuisance and noise draw (its twin).
    """
    rng = np.random.default_rng([seed, 3])
    effect_rng = np.random.default_rng([seed, 33])
    kind = str(rng.choice(["grill_brick", "mpacs_b", "mpacs_c", "foam"]))
    material = foam_simulant(rng) if kind == "foam" else dict(TABLE_1[kind])
    material_name = f"foam_{seed}" if kind == "foam" else kind
    n_runs = int(rng.integers(4, 9))
    rate_plan = str(rng.choice(["30k", "60k", "mixed"]))
    scatter = float(rng.uniform(0.03, 0.06))
    standoff_sigma = float(rng.uniform(0.3e-3, 1.5e-3))
    standoff = float(rng.uniform(0.12, 0.2))
    noise_rms = float(rng.uniform(0.5, 6.0))
    colour = str(rng.choice(["white", "pink", "band"]))
    share = float(rng.uniform(0.2, 0.7))
    step = float(rng.choice([0.08e-3, 0.1e-3, 0.16e-3, 0.2e-3, 0.25e-3, 0.32e-3]))
    edge_error = [float(e) for e in rng.normal(0.0, float(rng.uniform(0.02, 0.12)), 4)]
    edge_error = [max(min(e, 0.3), -0.3) for e in edge_error]
    filt = str(rng.choice(["bessel", "chebyshev", "none"]))
    cutoff = float(rng.uniform(0.25, 0.45))
    widths = [float(rng.choice([0.12, 0.15, 0.184]))]
    if rng.random() < 0.3:
        widths.append(float(rng.choice([wd for wd in (0.12, 0.15, 0.184) if wd != widths[0]])))
    thick = [float(t) for t in rng.choice([1e-3, 1.5e-3, 2e-3, 3e-3], size=int(rng.integers(2, 4)), replace=False)]
    tip = math.radians(float(rng.choice([89.9, 60.0])))
    spring_kg = float(rng.uniform(0.25, 0.3))
    time_digits = int(rng.choice([6, 8]))
    depth = float(rng.choice([0.133, 0.14]))
    drawn = [draw_effect(name, effect_rng, intensity) for name in effects]
    spring_start = int(rng.integers(0, 3))
    folders = []
    for i in range(n_runs):
        rate = {"30k": 30000.0, "60k": 60000.0}.get(rate_plan) or float(rng.choice([30000.0, 60000.0]))
        shot = Shot(width_m=widths[i % len(widths)], thickness_m=thick[i % len(thick)], tip_rad=tip, depth_m=depth,
                    sprung_kg=float((2.443, 2.943, 3.443)[int(rng.integers(0, 3))]), load_cell_kg=0.389,
                    springs=(2, 4, 6)[(spring_start + i) % 3], stiffness_n_m=1450.0, spring_kg=spring_kg,
                    free_m=0.5, compressed_m=0.2481, standoff_m=standoff + float(rng.normal(0, standoff_sigma)),
                    standoff_file_m=standoff, efficiency=0.98, material=material,
                    strength_pa=material["strength_kpa"] * 1e3 * (1 + float(rng.normal(0, scatter))), rate_hz=rate,
                    noise=_sensor_chain(rng, rate, noise_rms, colour, share),
                    encoder=dict(step_m=step, phase=float(rng.uniform(0, 1)), edge_error=edge_error),
                    filter=dict(kind=filt, cutoff=cutoff), pre_s=float(rng.uniform(0.1, 0.25)),
                    post_s=float(rng.uniform(0.12, 0.3)), time_digits=time_digits, effects=drawn)
        columns = measure(shot, np.random.default_rng([seed, 3, i]))
        folders.append(write_run(folder / f"w3-{seed}-{i}", shot, columns, f"w3-{seed}-{i}", material_name))
    nuisances = dict(material=material_name, runs=n_runs, rate_hz=rate_plan, block_scatter=scatter,
                     standoff_sigma_mm=standoff_sigma * 1e3, noise_n=noise_rms, noise_colour=colour,
                     encoder_mm=step * 1e3, filter=filt, widths_mm=[wd * 1e3 for wd in widths],
                     thicknesses_mm=[t * 1e3 for t in thick], tip_deg=round(math.degrees(tip), 1))
    return Campaign(folders, drawn, nuisances)
