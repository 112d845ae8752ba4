"""The simulated rig's true world (RK4, its own force law) against pen's model (closed form + DOP853).

Two independent implementations of CONTRACT §2 must agree when the world
carries no hidden effect; each effect must move the world the way its
physics says.
"""

from __future__ import annotations

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
