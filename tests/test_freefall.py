"""Free-fall penetrometer records: the BlueDrop reader, the accelerometers stitched and integrated, the bed fitted
across drops, all checked against simulated drops (:mod:`pencli.acquire.freefall`, which shares no code with the
filters and the fit) written in the BlueDrop format."""

from __future__ import annotations

import csv
from dataclasses import replace

import numpy as np
import pytest

from pencli.acquire.freefall import Bed, Probe, Sensors, simulate_drop
from pencli.errors import DataError
from pencli.filter.freefall import drop_motion, stitch
from pencli.fit.freefall import FreeFallProbe, fit_bed
from pencli.io.bluedrop import ACCELEROMETER_RANGES_G, CHANNELS, bluedrop_bytes, read_bluedrop, read_calibration
from pencli.sensors.accelerometers import reading_of

PROBE = Probe()
HEIGHTS_M = (0.5, 1.0, 3.0, 8.0)
"""Release heights above the bed: impact speeds from 2.3 m/s to near the terminal 4.5 m/s."""


def written(tmp_path, drop, sensors, name="drop.bin"):
    path = tmp_path / name
    path.write_bytes(bluedrop_bytes(drop.raw))
    return read_bluedrop(path, sensors.calibration)


def drops(tmp_path, bed, seed):
    """(truth, motion, sensors) of a drop from each height, each sensor chain with its own random bias."""
    rng = np.random.default_rng(seed)
    out = []
    for k, height in enumerate(HEIGHTS_M):
        sensors = Sensors(bias_g={name: float(rng.uniform(-0.03, 0.03)) for name in ACCELEROMETER_RANGES_G})
        truth = simulate_drop(PROBE, bed, height, sensors=sensors, seed=seed * 10 + k)
        record = written(tmp_path, truth, sensors, f"drop{k}.bin")
        accels = {name: record.channels[name] for name in ACCELEROMETER_RANGES_G}
        out.append((truth, drop_motion(record.time_s, accels, ACCELEROMETER_RANGES_G), sensors))
    return out


@pytest.mark.parametrize("seed", range(3))
def test_impact_speed_and_penetration_within_one_percent_of_the_simulation(tmp_path, seed):
    """Random beds that stop the probe (σ 10–40 kPa, b 0–300 kPa/m, c 0–30 kPa·s/m) and sensor biases up to
    0.03 g: the speed at impact and the penetration integrated from the record within 1 % of the simulation's,
    each sensor's bias taken out within a tenth of the largest."""
    rng = np.random.default_rng(500 + seed)
    bed = Bed(rng.uniform(10, 40), rng.uniform(0, 300), rng.uniform(0, 30))
    for truth, motion, sensors in drops(tmp_path, bed, seed):
        assert motion.impact_speed_m_s == pytest.approx(truth.impact_speed_m_s, rel=0.01)
        assert motion.penetration_m == pytest.approx(truth.penetration_m, rel=0.01)
        assert abs(motion.release / 2000.0 - truth.release_s) <= 1 / 2000.0
        for name, bias in sensors.bias_g.items():
            assert abs(motion.bias_g[name][0] - bias) < 0.003 and abs(motion.bias_g[name][1] - bias) < 0.003


@pytest.mark.parametrize("seed", range(3))
def test_the_bed_is_fitted_across_drops(tmp_path, seed):
    """Random beds, four drops each: σ and c within 10 % of the simulated bed's, b within 10 % or 5 kPa/m, and the
    fit's residual under 2 % of the bed's force.  (The least-squares standard errors are smaller than these
    errors: the residuals of neighbouring samples are correlated, so they are not stated as intervals here.)"""
    rng = np.random.default_rng(700 + seed)
    bed = Bed(rng.uniform(10, 40), rng.uniform(0, 300), rng.uniform(2, 30))
    readings = [reading_of(f"drop{k}", motion) for k, (_, motion, _) in enumerate(drops(tmp_path, bed, 70 + seed))]
    probe = FreeFallProbe(PROBE.mass_kg, PROBE.volume_m3, PROBE.half_angle_rad, PROBE.shaft_radius_m,
                          PROBE.drag_coefficient, PROBE.added_mass_coefficient)
    fit = fit_bed(readings, probe)
    assert fit.strength_kpa == pytest.approx(bed.strength_kpa, rel=0.1)
    assert abs(fit.gradient_kpa_m - bed.gradient_kpa_m) < 0.1 * bed.gradient_kpa_m + 5.0
    assert fit.damping_kpa_s_m == pytest.approx(bed.damping_kpa_s_m, rel=0.1)
    assert fit.relative_rms < 0.02 and fit.drops == 4


def test_stitching_takes_the_finest_sensor_within_its_range(tmp_path):
    sensors = Sensors()
    truth = simulate_drop(PROBE, Bed(30.0, 200.0, 10.0), 3.0, sensors=sensors)
    record = written(tmp_path, truth, sensors)
    stitched = stitch(record.channels, ACCELEROMETER_RANGES_G)
    fine = np.abs(record.channels["accel_2g"]) < 0.9 * 1.7
    assert fine.mean() > 0.5 and np.array_equal(stitched[fine], record.channels["accel_2g"][fine])
    impact = ~fine & (np.abs(record.channels["accel_18g"]) < 0.9 * 18)
    assert impact.any() and np.array_equal(stitched[impact], record.channels["accel_18g"][impact])
    assert stitched.max() > 1.7  # the impact is read past the 2 g sensor's range


def test_a_record_written_is_read_back_to_the_count(tmp_path):
    raw = np.array([[0, 1, -1, (1 << 23) - 1, -(1 << 23), 12345, -54321, 7, -7, 100]] * 3)
    path = tmp_path / "r.bin"
    path.write_bytes(bluedrop_bytes(raw))
    cal = Sensors().calibration
    record = read_bluedrop(path, cal)
    assert np.array_equal(record.raw, raw)
    k = CHANNELS.index("accel_50g")
    assert record.channels["accel_50g"][0] == pytest.approx((raw[0, k] + cal["accel_50g"].offset)
                                                             / cal["accel_50g"].scale)


def write_calibration(path, rows):
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["channel", "offset", "scale", "unit"])
        writer.writerows(rows)


@pytest.mark.parametrize("case", ["ragged", "empty", "missing channel", "zero scale", "not a number", "unknown"])
def test_broken_input_is_one_line_naming_the_file(tmp_path, case):
    good = [[name, c.offset, c.scale, c.unit] for name, c in Sensors().calibration.items()]
    cal_path, bin_path = tmp_path / "cal.csv", tmp_path / "d.bin"
    write_calibration(cal_path, good)
    bin_path.write_bytes(bluedrop_bytes(np.zeros((4, 10), dtype=int)))
    if case == "ragged":
        bin_path.write_bytes(bin_path.read_bytes()[:-7])
    elif case == "empty":
        bin_path.write_bytes(b"")
    elif case == "missing channel":
        write_calibration(cal_path, good[1:])
    elif case == "zero scale":
        write_calibration(cal_path, [good[0][:2] + [0, "g"], *good[1:]])
    elif case == "not a number":
        write_calibration(cal_path, [good[0][:1] + ["x", 1, "g"], *good[1:]])
    else:
        write_calibration(cal_path, [["accel_7g", 0, 1, "g"], *good])
    expected = {"ragged": "expected whole rows of 30 bytes", "empty": "0 bytes", "missing channel": "no calibration "
                "for accel_2g", "zero scale": "row 2: scale 0", "not a number": "row 2: offset 'x'",
                "unknown": "row 2: channel 'accel_7g'"}[case]
    with pytest.raises(DataError) as error:
        read_bluedrop(bin_path, read_calibration(cal_path))
    assert expected in str(error.value) and "\n" not in str(error.value)
    assert str(error.value).startswith(str(bin_path if case in ("ragged", "empty") else cal_path))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cal.csv", "d.bin"]


def test_a_bed_that_buoys_the_cone_is_fitted_with_its_density_and_misread_without_it(tmp_path):
    """A saturated sand's bulk density (1,900 kg/m³ under seawater) buoys the cone's volume below the surface: a
    force that grows with depth as the frontal area does, 8.6 kPa/m of q's gradient once the cone is in.  With
    the density, the bed's gradient (50 kPa/m, small, where the buoyancy is a sixth of it) comes back within
    10 % or 5 kPa/m as for any bed; without it, the fit reads the buoyancy as gradient."""
    bed = Bed(20.0, 50.0, 8.0, density_kg_m3=1900.0)
    readings = [reading_of(f"drop{k}", motion) for k, (_, motion, _) in enumerate(drops(tmp_path, bed, 91))]
    known = FreeFallProbe(PROBE.mass_kg, PROBE.volume_m3, PROBE.half_angle_rad, PROBE.shaft_radius_m,
                          PROBE.drag_coefficient, PROBE.added_mass_coefficient, bed_density=1900.0)
    fit = fit_bed(readings, known)
    assert fit.strength_kpa == pytest.approx(bed.strength_kpa, rel=0.1)
    assert abs(fit.gradient_kpa_m - bed.gradient_kpa_m) < 0.1 * bed.gradient_kpa_m + 5.0
    assert fit.damping_kpa_s_m == pytest.approx(bed.damping_kpa_s_m, rel=0.1)
    blind = fit_bed(readings, replace(known, bed_density=0.0))
    assert blind.gradient_kpa_m - fit.gradient_kpa_m > 0.5 * (1900.0 - 1025.0) * 9.80665 / 1e3
