"""The sensor chains' observation equations, each read back against its closed form (:mod:`pencli.sensors`)."""

from __future__ import annotations

import numpy as np
import pytest

from pencli.sensors import CHAINS, Reading, chain, missing_channels


def test_a_cone_tips_qt_is_qc_plus_the_pore_pressure_on_the_shoulder_it_does_not_see():
    """qt = qc + (1 − a)·u₂: 2.0 MPa and 300 kPa on a cone of a = 0.8 give 2,060 kPa; without a net area ratio no
    qt is read, and qc, fs and u₂ are passed on in kPa."""
    channels = {"depth_m": np.array([1.0, 1.1]), "qc_mpa": np.array([2.0, 3.0]), "fs_kpa": np.array([20.0, 25.0]),
                "u2_kpa": np.array([300.0, 100.0])}
    reading = chain("cone_tip", net_area_ratio=0.8).read("s", None, channels)
    assert reading.pressures_kpa["qt"] == pytest.approx([2000.0 + 0.2 * 300.0, 3000.0 + 0.2 * 100.0], rel=1e-15)
    assert reading.pressures_kpa["qc"] == pytest.approx([2000.0, 3000.0]) and reading.force_n is None
    assert reading.pressures_kpa["fs"].tolist() == [20.0, 25.0] and reading.pressures_kpa["u2"].tolist() == [300, 100]
    assert "qt" not in chain("cone_tip").read("s", None, channels).pressures_kpa
    with pytest.raises(ValueError, match="net area ratio"):
        chain("cone_tip", net_area_ratio=1.5)


def test_a_pushs_speed_is_the_loggers_rate_else_depth_over_the_clock_else_unknown():
    t = np.linspace(0.0, 10.0, 11)
    depth = 1.0 + 0.02 * t  # 20 mm/s
    base = {"depth_m": depth, "qc_mpa": np.ones(11)}
    assert chain("cone_tip").read("s", t, base).speed_m_s == pytest.approx(np.full(11, 0.02), rel=1e-12)
    logged = chain("cone_tip").read("s", t, {**base, "rate_mm_s": np.full(11, 19.0)})
    assert logged.speed_m_s == pytest.approx(np.full(11, 0.019))
    assert np.isnan(chain("cone_tip").read("s", None, base).speed_m_s).all()


def test_force_chains_read_the_force_in_newtons():
    """A total sounding's rod force in kN and a SnowMicroPen's tip force in N, both as the force on the
    penetrator; the SnowMicroPen's travel in metres."""
    rods = chain("rod_force").read("t", None, {"depth_m": np.array([0.5, 0.6]), "push_force_kn": np.array([1.5, 2])})
    assert rods.force_n.tolist() == [1500.0, 2000.0] and not rods.pressures_kpa
    tip = chain("tip_force").read("p", None, {"depth_mm": np.array([10.0, 10.5]), "force_n": np.array([0.1, 0.2])})
    assert tip.travel_m == pytest.approx([0.010, 0.0105]) and tip.force_n.tolist() == [0.1, 0.2]


def test_an_accelerometer_drops_reading_is_its_motion_from_release_with_depth_below_the_bed():
    """The reading's rows and depth are the motion's: contact at the impact row, depth = travel less the travel at
    the time of impact (between two rows)."""
    from pencli.filter.freefall import DropMotion
    from pencli.sensors.accelerometers import reading_of

    t = np.arange(10) * 0.01
    travel = 0.5 * 9.0 * t ** 2
    motion = DropMotion(time_s=t, accel_m_s2=np.full(10, 9.0), speed_m_s=9.0 * t, travel_m=travel, release=1,
                        impact=5, stop=8, impact_s=0.045, impact_speed_m_s=0.405, penetration_m=0.0, bias_g={})
    reading = reading_of("d", motion)
    assert (reading.chain, reading.start, reading.contact, reading.stop) == ("accelerometers", 1, 5, 8)
    assert reading.force_n is None and reading.account is motion
    at_impact = np.interp(0.045, t, travel)
    assert reading.depth_m() == pytest.approx(travel[5:9] - at_impact, abs=1e-15)


def test_the_registry_names_what_it_has_and_refuses_a_name_twice():
    assert {"encoder_load_cell", "accelerometers", "cone_tip", "rod_force", "tip_force"} <= set(CHAINS)
    with pytest.raises(ValueError, match="cone_tip"):
        chain("laser")
    with pytest.raises(ValueError, match="already registered"):
        from pencli.sensors import register_chain

        register_chain(CHAINS["cone_tip"])
    assert missing_channels(chain("rod_force"), {"depth_m": 0}) == ["push_force_kn"]


def test_a_reading_without_a_stop_runs_to_its_last_row():
    r = Reading("x", "cone_tip", np.arange(5.0), np.ones(5), contact=2, surface_m=1.5)
    assert r.depth_m().tolist() == [0.5, 1.5, 2.5]


def test_the_rigs_replicates_are_read_as_the_encoder_and_load_cell_read():
    """The encoder rounds travel to whole counts at its phase (0.3 mm at phase 0 reads 2 counts of 0.16 mm) and is
    zeroed at its first reading; the load cell's resistance is off by the mass times the acceleration's error,
    plus its noise."""
    from pencli.sensors.load_cell import encoder_reading, load_cell_reading

    travel = np.array([[0.0], [0.3e-3], [0.5e-3]])
    read = encoder_reading(travel, 0.16e-3, np.array([0.0, 0.5]), first_m=-0.148)
    assert read[:, 0] + 0.148 == pytest.approx([0.0, 0.32e-3, 0.48e-3], abs=1e-15)
    # at phase 0.5 (0.08 mm): 0.08, 0.38, 0.58 mm are 0.5, 2.375, 3.625 counts, rounded to 0, 2, 4 (half to even)
    assert read[:, 1] + 0.148 == pytest.approx([0.0, 0.32e-3, 0.64e-3], abs=1e-15)
    half = encoder_reading(travel, 0.16e-3, np.array([0.5]), first_m=0.0, position_error_m=np.full((3, 1), 0.05e-3))
    assert half[:, 0] == pytest.approx([0.0, 0.32e-3, 0.48e-3], abs=1e-15)
    noise = np.array([[0.5, -0.5], [0.0, 1.0]])
    out = load_cell_reading(np.array([100.0, 200.0]), 0.4, np.array([[10.0, -10.0], [0.0, 5.0]]), noise)
    assert out.tolist() == [[100.0 - 4.0 + 0.5, 100.0 + 4.0 - 0.5], [200.0, 200.0 - 2.0 + 1.0]]
