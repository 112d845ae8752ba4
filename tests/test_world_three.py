"""World three (pencli/testing/world_three.py) checked against CONTRACT §2 where it has no effect, and its sensor chain
against what it claims: a truth world that is wrong measures nothing."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pencli.testing import world_three as w3
from pencli.testing.reference import reference_run


def _shot(**over) -> w3.Shot:
    base = dict(width_m=0.15, thickness_m=1.5e-3, tip_rad=math.radians(60.0), depth_m=0.133, sprung_kg=2.943,
                load_cell_kg=0.389, springs=4, stiffness_n_m=1450.0, spring_kg=0.28, free_m=0.5, compressed_m=0.2481,
                standoff_m=0.15, standoff_file_m=0.15, efficiency=0.98, material=dict(w3.TABLE_1["mpacs_c"]),
                strength_pa=6.0e6, rate_hz=30000.0,
                noise=dict(rms_n=1.0, colour="white", colour_share=0.0, band_hz=1000.0, pole_radius=0.95,
                           floor_share=0.05),
                encoder=dict(step_m=1e-4, phase=0.3, edge_error=[0.0] * 4), filter=dict(kind="none", cutoff=0.4),
                pre_s=0.1, post_s=0.12, time_digits=8, effects=[])
    base.update(over)
    return w3.Shot(**base)


def _reference(shot: w3.Shot, material: dict) -> dict:
    p = dict(blade_width_mm=shot.width_m * 1e3, blade_thickness_mm=shot.thickness_m * 1e3,
             tip_angle_deg=math.degrees(shot.tip_rad), penetration_depth_mm=shot.depth_m * 1e3,
             sprung_mass_kg=shot.sprung_kg, load_cell_mass_kg=shot.load_cell_kg)
    m = dict(density_kg_m3=material["density"], microstructure_strength_kpa=shot.strength_pa / 1e3,
             friction_coefficient=material["mu"], gravity_m_s2=w3.G,
             coefficients=dict(strength_factor=material["Cs"], sidewall_pressure_kpa=material["P_kpa"],
                               damping_kpa_s_m=material["C_kpa_s_m"], inertia_coefficient=material["K"]))
    e = dict(spring_count=shot.springs, spring_stiffness_kn_m=shot.stiffness_n_m / 1e3,
             spring_mass_kg=shot.spring_kg, spring_nominal_length_mm=shot.free_m * 1e3,
             spring_compressed_length_mm=shot.compressed_m * 1e3, surface_offset_mm=shot.standoff_m * 1e3,
             propulsion_efficiency_pct=shot.efficiency * 100)
    return reference_run(p, m, e, rtol=1e-11)


@pytest.mark.parametrize("material,springs,thickness", [("mpacs_c", 2, 2e-3), ("mpacs_c", 6, 1e-3),
                                                        ("grill_brick", 4, 3e-3)])
def test_without_effects_the_motion_is_contract_2s(material, springs, thickness):
    mat = dict(w3.TABLE_1[material])
    mat["C_kpa_s_m"] = 0.8  # a damping term too, which Table 1's materials lack
    shot = _shot(material=mat, springs=springs, thickness_m=thickness, strength_pa=mat["strength_kpa"] * 1e3)
    ref = _reference(shot, mat)
    mo = w3.motion(shot)
    assert mo.contact_speed_m_s == pytest.approx(ref["contact_speed_m_s"], rel=1e-7)
    assert mo.stop_s - mo.contact_s == pytest.approx(ref["penetration_time_s"], rel=1e-5)
    assert mo.end == ref["end"]
    depth_mm = (mo.u[-1] - shot.standoff_m) * 1e3
    assert depth_mm == pytest.approx(ref["final_depth_mm"], abs=1e-4)
    inside = (mo.t > mo.contact_s) & (mo.t <= mo.stop_s)
    assert mo.resistance[inside].max() == pytest.approx(ref["peak_resistance_n"], rel=2e-3)


def test_energy_balances_to_the_integrators_accuracy():
    """Spring work + gravity's = kinetic energy + the work done on the block + guide friction's, at the stop."""
    shot = _shot(springs=6, thickness_m=1e-3, material=dict(w3.TABLE_1["mpacs_b"]), strength_pa=2.0e6,
                 effects=[dict(name="propulsion_loss", form="guide_friction", energy_lost=0.15)])
    mo = w3.motion(shot)
    n, k, stroke = shot.springs, shot.stiffness_n_m, shot.free_m - shot.compressed_m
    m_eff = shot.sprung_kg + n * shot.spring_kg / 3
    u = mo.u[mo.t <= mo.stop_s][-1]
    v_end = mo.v[mo.t <= mo.stop_s][-1]
    travel = min(u, stroke)
    spring = shot.efficiency * n * k * (stroke * travel - 0.5 * travel ** 2)
    guide = 0.15 * shot.efficiency * n * 0.5 * k * stroke * travel
    assert mo.end == "full_depth"
    balance = spring + m_eff * w3.G * u - guide - 0.5 * m_eff * v_end ** 2 - mo.work[mo.t <= mo.stop_s][-1]
    assert abs(balance) < 1e-6 * spring


def test_a_propulsion_loss_takes_the_share_of_energy_it_says():
    """Kinetic energy at contact = the spring's work over the stand-off (less the lost share: of η, or the guide
    friction's constant force ℓ·η·n·k·stroke/2 over the stand-off) + gravity's, in closed form."""
    plain = w3.motion(_shot(springs=2))
    for form in ("efficiency", "guide_friction"):
        shot = _shot(springs=2, effects=[dict(name="propulsion_loss", form=form, energy_lost=0.2)])
        lossy = w3.motion(shot)
        n, k, stroke, s0 = shot.springs, shot.stiffness_n_m, shot.free_m - shot.compressed_m, shot.standoff_m
        m_eff = shot.sprung_kg + n * shot.spring_kg / 3
        spring = shot.efficiency * n * k * (stroke * s0 - 0.5 * s0 ** 2)
        lost = 0.2 * spring if form == "efficiency" else 0.2 * shot.efficiency * n * 0.5 * k * stroke * s0
        kinetic = 0.5 * m_eff * lossy.contact_speed_m_s ** 2
        assert kinetic == pytest.approx(spring - lost + m_eff * w3.G * s0, rel=1e-8)
        # gravity's work is the same in both; the spring's and the guide's scale with the loss
        assert lossy.contact_speed_m_s < plain.contact_speed_m_s * 0.95


def test_the_encoder_counts_with_its_edge_errors():
    enc = dict(step_m=2e-4, phase=0.0, edge_error=[0.1, -0.1, 0.0, 0.2])
    disp = np.linspace(0.0, 8e-4, 8001)  # four counts
    counts = w3._encoder_counts(disp, enc)
    edges = disp[1:][np.diff(counts) > 0] / 2e-4
    assert np.allclose(edges, [0 + 0.1, 1 - 0.1, 2 + 0.0, 3 + 0.2], atol=2e-3)
    assert counts[-1] == 4


@pytest.mark.parametrize("form", ["resonant_cell", "creep", "pole_and_delay"])
def test_each_sensor_lag_delays_a_slow_ramp_by_its_lag(form):
    """Under a ramp, a low-pass of mean delay τ falls τ × slope behind (its first moment)."""
    rate = 60000.0
    t = np.arange(0, 0.05, 1 / rate)
    ramp = np.where(t > 0.01, (t - 0.01) * 1e4, 0.0)
    lag = dict(lag_ms=0.4, damping_ratio=0.7, creep_share=0.6, delay_share=0.5, form=form)
    out = w3._lagged(ramp, lag, rate)
    late = t > 0.04
    assert np.mean(ramp[late] - out[late]) / 1e4 == pytest.approx(0.4e-3, rel=0.05)


def test_noise_has_the_rms_it_says():
    rng = np.random.default_rng(0)
    for colour in ("white", "pink", "band"):
        noise = dict(rms_n=3.0, colour=colour, colour_share=0.5, band_hz=900.0, pole_radius=0.95, floor_share=0.05)
        assert np.std(w3._coloured_noise(rng, 60000, noise, 30000.0)) == pytest.approx(3.0, rel=0.03)


@pytest.mark.parametrize("kind", ["bessel", "chebyshev", "none"])
def test_the_anti_alias_filter_passes_a_static_force_unchanged(kind):
    level = np.full(3000, 250.0)
    level[1500:] = 900.0
    out = w3._anti_alias(level, dict(kind=kind, cutoff=0.3), 30000.0)
    assert out[1400] == pytest.approx(250.0, rel=1e-9)
    assert out[-1] == pytest.approx(900.0, rel=1e-9)
