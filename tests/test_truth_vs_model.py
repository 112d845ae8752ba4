"""The simulated rig's true world (RK4, its own force law) against pen's model (closed form + DOP853).

Two independent implementations of CONTRACT §2 must agree when the world
carries no hidden effect; each effect must move the world the way its
physics says.
"""

from __future__ import annotations

import math

import pytest

from pencli.acquire.rig import rig_from_mapping
from pencli.acquire.sim import world_from
from pencli.acquire.truth import true_motion
from pencli.model.design import design_from_sets
from pencli.model.dynamics import simulate
from pencli.params.load import load_preset


def sets(p, m, e):
    return load_preset(p, "penetrator"), load_preset(m, "material"), load_preset(e, "energizing")


@pytest.mark.parametrize("p,m,e", [("al6061_1mm", "grill_brick", "springs_4"), ("al6061_2mm", "mpacs_c", "springs_2"),
                                   ("al6061_1.5mm", "mpacs_d", "springs_6"), ("appendix_c", "mpacs_b", "appendix_c")])
def test_truth_without_effects_agrees_with_the_model(p, m, e):
    ps, ms, es = sets(p, m, e)
    world = world_from(ps, ms, es, rig_from_mapping({}))
    motion = true_motion(world, 30000.0)
    model = simulate(design_from_sets(ps, ms, es)).summary
    assert motion.contact_speed_m_s == pytest.approx(model.contact_speed_m_s, rel=1e-8)
    assert motion.contact_time_s == pytest.approx(model.contact_time_s, rel=1e-8)
    assert motion.end == model.end
    assert motion.final_depth_m * 1e3 == pytest.approx(model.final_depth_mm, rel=1e-5)
    assert motion.stop_time_s - motion.contact_time_s == pytest.approx(model.penetration_time_s, rel=1e-4)


def _depth(effects, p="al6061_1mm", m="mpacs_c", e="springs_2", **rig):
    ps, ms, es = sets(p, m, e)
    world = world_from(ps, ms, es, rig_from_mapping({"effects": effects, **rig}))
    return true_motion(world, 30000.0)


def test_effects_move_the_world_as_their_physics_says():
    base = _depth([])
    assert base.end == "arrest"
    weaker = _depth([{"name": "strength_layer", "depth_mm": 20, "ratio": 0.5}])
    assert weaker.final_depth_m > base.final_depth_m
    harder = _depth([{"name": "strength_gradient", "change_per_100mm": 1.0}])
    assert harder.final_depth_m < base.final_depth_m
    lossy = _depth([{"name": "propulsion_loss", "loss": 0.2}])
    assert lossy.contact_speed_m_s < base.contact_speed_m_s
    slick = _depth([{"name": "velocity_friction", "drop": 0.5, "speed_m_s": 2.0}])
    assert slick.final_depth_m > base.final_depth_m
    block = _depth([], strength_scale=1.3)
    assert block.final_depth_m < base.final_depth_m
    sensor_only = _depth([{"name": "sensor_lag", "tau_ms": 0.5}])
    assert sensor_only.final_depth_m == base.final_depth_m  # a sensor effect leaves the motion alone


def _resistance(effects, x, v):
    from pencli.acquire.truth import _resistance_function

    ps, ms, es = sets("al6061_1mm", "mpacs_c", "springs_2")
    return _resistance_function(world_from(ps, ms, es, rig_from_mapping({"effects": effects})))(x, v)


@pytest.mark.parametrize("shape,at_50mm", [
    (0, lambda c, e, L: (1 + c) ** 0.5 - 1), (1, lambda c, e, L: c * 0.5 ** e),
    (2, lambda c, e, L: c * (1 - math.exp(-50 / L)) / (1 - math.exp(-100 / L))),
    (3, lambda c, e, L: c * (40 + 0.2 * 10) / (40 + 0.2 * 60)),  # two slopes: the defaults' kink 40 mm, ratio 0.2
    # an S-shaped rise centred at L, the default tanh width 20 mm: s(x) = tanh((x − L)/20)
    (4, lambda c, e, L: c * (math.tanh((50 - L) / 20) + math.tanh(L / 20)) / (math.tanh((100 - L) / 20)
                                                                             + math.tanh(L / 20)))])
def test_each_form_of_a_strength_gradient_changes_the_frontal_strength_as_described(shape, at_50mm):
    """The sim world's random forms: at 100 mm every form has changed the frontal strength force
    (R at the surface, at rest) by change_per_100mm; at 50 mm by its own profile, written out here."""
    change, exponent, length = 1.7, 2.2, 30.0
    effect = [{"name": "strength_gradient", "change_per_100mm": change, "shape": shape, "exponent": exponent,
               "length_mm": length}]
    frontal = _resistance([], 0.0, 0.0)
    assert _resistance(effect, 0.1, 0.0) - _resistance([], 0.1, 0.0) == pytest.approx(change * frontal, rel=1e-12)
    assert _resistance(effect, 0.05, 0.0) - _resistance([], 0.05, 0.0) == pytest.approx(
        at_50mm(change, exponent, length) * frontal, rel=1e-12)


@pytest.mark.parametrize("shape,h", [(0, lambda r: r / (1 + r)), (1, lambda r: 1 - math.exp(-r)),
                                     (2, lambda r: min(r, 1.0)), (3, lambda r: min(r, 1.0) ** 0.6)])
def test_each_form_of_plug_growth_widens_every_frontal_term(shape, h):
    growth, length, T = 2.0, 20.0, 1.0  # mm; al6061_1mm
    effect = [{"name": "plug_growth", "growth_mm": growth, "length_mm": length, "shape": shape, "exponent": 0.6}]
    for x_mm, v in ((10.0, 0.0), (35.0, 4.0)):
        x = x_mm * 1e-3
        widened = 1 + growth * h(x_mm / length) / T
        frontal = _resistance([], x, v) - _resistance([], x, 0.0) + _resistance([], 0.0, 0.0)  # friction has no v
        assert _resistance(effect, x, v) - _resistance([], x, v) == pytest.approx((widened - 1) * frontal, rel=1e-9)


@pytest.mark.parametrize("params,g", [
    ({"shape": 3, "drop": 0.4, "exponent": 0.6}, lambda v: -0.4 * (v / 10) ** 0.6),
    ({"shape": 4, "drop": 0.3, "speed_m_s": 1.5, "viscous": 0.5}, lambda v: -0.3 * (1 - math.exp(-v / 1.5)) + 0.05 * v)])
def test_the_power_and_stribeck_friction_forms_follow_their_speed_laws(params, g):
    """The relative change of μ, g(v), moves every friction force by the same factor: the force change at two
    speeds at one depth is in the ratio of g, and at one speed it grows with depth as the sidewall friction."""
    effect = [{"name": "velocity_friction", **params}]

    def change(x, v):
        return _resistance(effect, x, v) - _resistance([], x, v)

    assert change(0.05, 2.0) / change(0.05, 8.0) == pytest.approx(g(2.0) / g(8.0), rel=1e-9)
    sidewall = _resistance([], 0.05, 0.0) - _resistance([], 0.0, 0.0)  # 2 μ w P x at 50 mm
    assert change(0.05, 8.0) == pytest.approx(g(8.0) * sidewall, rel=2e-3)  # and μ cos θ of a blunt tip


def test_an_onset_rate_strength_is_flat_below_its_speed_and_a_power_of_the_excess_above():
    """Sim truth shape 3 of rate_strength (the bench's ``--onset-rates``): nothing changes below speed_m_s; above
    it the frontal strength force is multiplied by 1 + c·(v − speed)^exponent, written out here."""
    c, onset, exponent = 0.12, 2.0, 0.8
    effect = [{"name": "rate_strength", "shape": 3, "coefficient": c, "speed_m_s": onset, "exponent": exponent}]
    frontal = _resistance([], 0.0, 0.0)  # the strength term alone, at the surface at rest
    assert _resistance(effect, 0.0, 1.5) == _resistance([], 0.0, 1.5)
    assert _resistance(effect, 0.0, 5.0) - _resistance([], 0.0, 5.0) == pytest.approx(
        c * 3.0 ** exponent * frontal, rel=1e-12)


def test_saturating_sidewall_pressure_integrates_its_rise():
    rise, scale = 2.0, 25.0
    effect = [{"name": "sidewall_pressure_growth", "shape": 1, "rise": rise, "scale_mm": scale}]
    x = 0.06
    friction = _resistance([], x, 0.0) - _resistance([], 0.0, 0.0)  # 2 μ w P x
    integral = rise * (x - scale * 1e-3 * (1 - math.exp(-x / (scale * 1e-3))))  # ∫ rise (1 − e^(−z/a)) dz
    assert _resistance(effect, x, 0.0) - _resistance([], x, 0.0) == pytest.approx(friction * integral / x, rel=1e-9)


def test_an_effect_form_outside_its_shapes_is_refused_in_one_line():
    from pencli.errors import ParameterError

    with pytest.raises(ParameterError, match=r"effects\[0\] \(sensor_lag\): shape = 4; expected one of 0, 1, 2, 3"):
        _resistance([{"name": "sensor_lag", "shape": 4}], 0.0, 0.0)
    # a two-slope gradient that cannot be stated against its change at 100 mm (it divided by zero)
    with pytest.raises(ParameterError, match=r"effects\[0\] \(strength_gradient\): kink_mm = 0, slope_ratio = 0; "
                                             r"expected both ≥ 0, not both 0"):
        _resistance([{"name": "strength_gradient", "shape": 3, "kink_mm": 0, "slope_ratio": 0}], 0.0, 0.0)
    # an S-shaped rise of no width is a step the sim does not draw (it divided by zero)
    with pytest.raises(ParameterError, match=r"effects\[0\] \(strength_gradient\): width_mm = 0; expected > 0"):
        _resistance([{"name": "strength_gradient", "shape": 4, "width_mm": 0}], 0.0, 0.0)
    # a capped power plug of exponent ≤ 0 is infinite at the surface (0 ** −1 raised ZeroDivisionError)
    with pytest.raises(ParameterError, match=r"effects\[0\] \(plug_growth\): exponent = -1; expected > 0"):
        _resistance([{"name": "plug_growth", "shape": 3, "exponent": -1}], 0.0, 0.0)


def test_the_pure_delay_lag_shifts_the_force_by_its_delay():
    import numpy as np

    from pencli.acquire.sim import _lag

    rate = 30000.0
    t = np.arange(300) / rate
    signal = np.sin(2 * np.pi * 200.0 * t)
    delayed = _lag(signal, 0.5e-3, rate, 2)  # 15 samples
    assert np.allclose(delayed[15:], signal[:-15], atol=1e-12)


def test_the_bessel_lag_delays_a_slow_sine_as_the_analogue_fourth_order_prototype_does():
    import numpy as np

    from pencli.acquire.sim import _lag

    rate, tau = 30000.0, 0.5e-3
    t = np.arange(3000) / rate
    w = 2 * np.pi * 150.0
    out = _lag(np.sin(w * t), tau, rate, 3)
    # the unit-delay fourth-order Bessel prototype: 105 / (s⁴ + 10 s³ + 45 s² + 105 s + 105) at s = jωτ
    s = 1j * w * tau
    h = 105.0 / (s ** 4 + 10 * s ** 3 + 45 * s ** 2 + 105 * s + 105)
    settled = t > 0.05
    expected = abs(h) * np.sin(w * t + np.angle(h))
    assert np.max(np.abs(out[settled] - expected[settled])) < 2e-3
    # a step crosses half-way one group delay late and settles at its height (gain 1 at DC)
    step = _lag(np.r_[np.zeros(100), np.ones(900)], tau, rate, 3)
    assert abs((np.argmax(step >= 0.5) - 100) / rate - tau) <= 1.0 / rate
    assert abs(step[-1] - 1.0) < 1e-6 and step.max() < 1.015


def _change(effect, penetrator, x, v):
    """What ``effect`` (default form) adds to the true resistance of ``penetrator`` in MPACS C at (x, v). [N]"""
    from pencli.acquire.truth import _resistance_function

    ps, ms, es = sets(penetrator, "mpacs_c", "springs_2")

    def law(effects):
        return _resistance_function(world_from(ps, ms, es, rig_from_mapping({"effects": effects})))(x, v)

    return law([{"name": effect}]) - law([])


def test_the_advice_that_tells_two_effects_apart_by_blade_thickness_holds_in_the_true_world():
    """``separate_with`` (an ambiguity's advice, schema/diagnosis.md) names runs of another blade thickness
    only for two effects whose true forces scale differently with the thickness T, read from the sim world's
    force law (an implementation of its own, not the diagnosis's columns): a plug adds a fixed width, so its
    force, like sidewall friction's, does not grow with T (so the advice must not say thickness for them).  And where the advice says speed tells a plug from a pressure growth, the plug's force changes
    with speed at one depth and the pressure's does not."""
    from pencli.acquire.truth import TRUE_EFFECTS
    from pencli.diagnose.effects import INDISTINGUISHABLE

    x, v = 0.07, 3.0  # inside the default layer (60–110 mm) and past the default plug length (30 mm)

    def thickness_ratio(name):
        return _change(name, "al6061_2mm", x, v) / _change(name, "al6061_1mm", x, v)

    checked = 0
    for pair, advice in INDISTINGUISHABLE.items():
        a, b = sorted(pair)
        if not (a in TRUE_EFFECTS and b in TRUE_EFFECTS and _change(a, "al6061_1mm", x, v)
                and _change(b, "al6061_1mm", x, v)):
            continue  # a chain effect: no change of the force law to compare
        differ = abs(thickness_ratio(a) / thickness_ratio(b) - 1.0) > 0.05
        said = "another blade thickness" in advice
        assert said == differ, (f"{a} × {b}: thickness ratios {thickness_ratio(a):.3f} and {thickness_ratio(b):.3f}, "
                                f"advice: {advice!r}")
        checked += 1
    assert checked >= 5

    def speed_ratio(name):
        return _change(name, "al6061_1mm", x, 6.0) / _change(name, "al6061_1mm", x, 1.0)

    assert "speeds" in INDISTINGUISHABLE[frozenset({"plug_growth", "sidewall_pressure_growth"})]
    assert speed_ratio("sidewall_pressure_growth") == pytest.approx(1.0, abs=1e-9)
    assert speed_ratio("plug_growth") > 1.02
