"""Launcher files of ``drive: free_fall``: `pen predict` of a cone dropped through air and water against an
integration written here from release (weight, buoyancy, drag until the surface, added mass, the cone's areas),
the flight against its closed form in a vacuum, the energy booked, and the keys each drive holds."""

from __future__ import annotations

import json
import math

import pytest
from scipy.integrate import solve_ivp

from pencli.model.drive import DRIVES
from pencli.params.definitions import DRIVE_NAMES
from tests.conftest import REPO, invoke
from tests.test_geometry_files import CONE, MATERIAL, cone_resistance, write

HEAVY_CONE = {**CONE, "name": "heavy_cone", "sprung_mass_kg": 7.7, "load_cell_mass_kg": 0.0}
DROPS = {
    "water": {"kind": "energizing", "name": "water", "drive": "free_fall", "surface_offset_mm": 1200.0,
              "fluid_density_kg_m3": 1025.0, "drag_coefficient": 0.9, "added_mass_coefficient": 0.5,
              "displaced_volume_l": 1.6},
    "air": {"kind": "energizing", "name": "air", "drive": "free_fall", "surface_offset_mm": 1800.0,
            "fluid_density_kg_m3": 1.2, "drag_coefficient": 1.1, "displaced_volume_l": 1.6},
}
DROPS["tethered"] = {**DROPS["water"], "name": "tethered", "tether_force_n": 12.0}
DROPS["buoyed"] = {**DROPS["water"], "name": "buoyed", "bed_density_kg_m3": 1900.0}
G = 9.81


def predict(tmp_path, runner, drop, *extra):
    files = [write(tmp_path, n, m) for n, m in (("cone", HEAVY_CONE), ("soft", MATERIAL), ("drop", drop))]
    result = invoke(runner, "predict", "-p", files[0], "-m", files[1], "-e", files[2], "--json", *extra)
    assert result.exit_code == 0, result.output + result.stderr
    return json.loads(result.stdout)


def embedded_volume(x: float) -> float:
    """The blunt cone's volume below the surface with its tip ``x`` deep, from its radius r(s) = r_t + s·tan α up
    to the shaft's: π·(r³ − r_t³)/(3·tan α), then the shaft's cylinder. [m³]"""
    alpha = math.radians(HEAVY_CONE["cone_half_angle_deg"])
    rs, rt = HEAVY_CONE["shaft_diameter_mm"] / 2e3, HEAVY_CONE["tip_flat_diameter_mm"] / 2e3
    shoulder = (rs - rt) / math.tan(alpha)
    r = rt + min(max(x, 0.0), shoulder) * math.tan(alpha)
    return math.pi * (r ** 3 - rt ** 3) / (3 * math.tan(alpha)) + math.pi * rs * rs * max(x - shoulder, 0.0)


def independent_drop(drop: dict):
    """From release at rest, s0 above the bed: (contact time, contact speed, final depth, time at rest, the
    drag's work, the bed's buoyancy's work), integrated here from the forces as the physics states them."""
    m = HEAVY_CONE["sprung_mass_kg"]
    rho, volume = drop["fluid_density_kg_m3"], drop["displaced_volume_l"] / 1e3
    added = drop.get("added_mass_coefficient", 0.0) * rho * volume
    area = math.pi * (HEAVY_CONE["shaft_diameter_mm"] / 2e3) ** 2  # the body's largest frontal area
    drag = 0.5 * rho * drop["drag_coefficient"] * area
    s0 = drop["surface_offset_mm"] / 1e3
    bed_density = drop.get("bed_density_kg_m3", 0.0)

    def rhs(_t, y):
        x, v = y[0], y[1]
        fluid = drag * v * abs(v) if x < 0.0 else 0.0
        soil = (bed_density - rho) * G * embedded_volume(x) if bed_density and x > 0.0 else 0.0
        force = m * G - rho * volume * G - drop.get("tether_force_n", 0.0) - fluid - soil - cone_resistance(x, v)
        return [v, force / (m + added), fluid * v, soil * v]

    contact = lambda _t, y: y[0]  # noqa: E731
    contact.terminal, contact.direction = True, 1
    fall = solve_ivp(rhs, (0.0, 10.0), [-s0, 0.0, 0.0, 0.0], method="DOP853", rtol=1e-13, atol=1e-15,
                     events=contact)
    assert fall.status == 1
    t_c, (_, v_c, w_drag, _) = fall.t_events[0][0], fall.y_events[0][0]
    arrest = lambda _t, y: y[1]  # noqa: E731
    arrest.terminal, arrest.direction = True, -1
    bed = solve_ivp(rhs, (t_c, t_c + 5.0), [0.0, v_c, w_drag, 0.0], method="DOP853", rtol=1e-12, atol=1e-14,
                    events=arrest, max_step=1e-4)
    assert bed.status == 1
    return t_c, v_c, bed.y_events[0][0][0], bed.t_events[0][0], w_drag, bed.y_events[0][0][3]


@pytest.mark.parametrize("fluid", ["water", "air", "tethered", "buoyed"])
def test_a_drop_predicts_what_an_integration_from_release_gives(tmp_path, runner, fluid):
    drop = DROPS[fluid]
    s = predict(tmp_path, runner, drop)
    assert s["model"] == "pen-1dof/cone+free_fall" and s["drive"] == "free_fall" and s["end"] == "arrest"
    t_c, v_c, depth, t_rest, w_drag, w_soil = independent_drop(drop)
    assert s["contact_time_s"] == pytest.approx(t_c, rel=1e-8)
    assert s["contact_speed_m_s"] == pytest.approx(v_c, rel=1e-8)
    assert s["final_depth_mm"] / 1e3 == pytest.approx(depth, rel=1e-8)
    assert s["contact_time_s"] + s["penetration_time_s"] == pytest.approx(t_rest, rel=1e-8)
    # energy: gravity's work on the body alone; the drive's is the buoyancy's and the drag's, and the cone's
    # resistance takes what they leave
    s0 = drop["surface_offset_mm"] / 1e3
    travel = s0 + depth
    buoyancy = drop["fluid_density_kg_m3"] * drop["displaced_volume_l"] / 1e3 * G + drop.get("tether_force_n", 0.0)
    assert s["gravity_work_j"] == pytest.approx(HEAVY_CONE["sprung_mass_kg"] * G * travel, rel=1e-8)
    assert s["spring_energy_j"] == pytest.approx(-buoyancy * travel - w_drag - w_soil, rel=1e-8)
    assert s["energy_other_j"] == pytest.approx(s["gravity_work_j"] + s["spring_energy_j"], rel=1e-8)
    assert abs(s["energy_balance_error_j"]) < 1e-8 * s["gravity_work_j"]


def test_a_drop_in_a_vacuum_meets_the_surface_at_the_closed_form_speed(tmp_path, runner):
    vacuum = {**DROPS["air"], "fluid_density_kg_m3": 0.0}
    s = predict(tmp_path, runner, vacuum)
    s0 = vacuum["surface_offset_mm"] / 1e3
    assert s["contact_speed_m_s"] == pytest.approx(math.sqrt(2 * G * s0), rel=1e-12)
    assert s["contact_time_s"] == pytest.approx(math.sqrt(2 * s0 / G), rel=1e-12)
    assert s["spring_energy_j"] == 0.0


def test_water_slows_the_fall_as_the_closed_form_says(tmp_path, runner):
    """m'·v·dv/dh = (m − ρV)·g − ½ρC_D·A·v² integrates to v² = v_t²·(1 − exp(−2g'h/v_t²)), g' = (m − ρV)·g/m',
    m' = m + C_a·ρ·V: the speed at the surface grows with the height and stays below the terminal speed v_t."""
    drop = DROPS["water"]
    m, rho, volume = HEAVY_CONE["sprung_mass_kg"], drop["fluid_density_kg_m3"], drop["displaced_volume_l"] / 1e3
    area = math.pi * (HEAVY_CONE["shaft_diameter_mm"] / 2e3) ** 2
    inertia = m + drop["added_mass_coefficient"] * rho * volume
    terminal2 = 2 * (m - rho * volume) * G / (rho * drop["drag_coefficient"] * area)
    g_net = (m - rho * volume) * G / inertia
    for height_mm in (250.0, 1000.0, 2000.0):
        speed = predict(tmp_path, runner, {**drop, "surface_offset_mm": height_mm})["contact_speed_m_s"]
        expected = math.sqrt(terminal2 * (1 - math.exp(-2 * g_net * height_mm / 1e3 / terminal2)))
        assert speed == pytest.approx(expected, rel=1e-12) and speed < math.sqrt(terminal2)


def test_a_body_lighter_than_the_water_it_displaces_floats(tmp_path, runner):
    s = predict(tmp_path, runner, {**DROPS["water"], "displaced_volume_l": 9.0})
    assert s["end"] == "no_contact" and "floats" in " ".join(s["warnings"])


@pytest.mark.parametrize("file, change, said", [
    ("drop", {"spring_count": 4}, ["spring_count", "not a free_fall's", "drive: springs"]),
    ("drop", {"drag_coefficient": None}, ["missing key 'drag_coefficient'"]),
    ("drop", {"drive": "rocket"}, ["'drive'", "'rocket'", "springs, free_fall"]),
    ("springs", {"fluid_density_kg_m3": 1025.0}, ["fluid_density_kg_m3", "not a springs's", "drive: free_fall"]),
])
def test_a_key_of_another_drive_is_one_line(tmp_path, runner, file, change, said):
    from tests.test_geometry_files import LAUNCHER

    base = DROPS["water"] if file == "drop" else LAUNCHER
    mapping = {k: v for k, v in {**base, **change}.items() if v is not None}
    result = invoke(runner, "predict", "-p", "freefall_cone", "-m", "mpacs_b", "-e", write(tmp_path, "bad", mapping))
    assert result.exit_code == 1
    line = result.stderr.strip()
    assert "\n" not in line and all(w in line for w in said), line


def test_the_schema_holds_each_drive_to_its_own_keys():
    import jsonschema
    import yaml

    schema = json.loads((REPO / "schema" / "energizing.schema.json").read_text())
    presets = REPO / "pencli" / "params" / "presets" / "energizing"
    for path in presets.glob("*.yaml"):
        jsonschema.validate(yaml.safe_load(path.read_text()), schema)
    drop = yaml.safe_load((presets / "drop_water.yaml").read_text())
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({**drop, "spring_count": 4}, schema)
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({k: v for k, v in drop.items() if k != "fluid_density_kg_m3"}, schema)
    assert set(DRIVES) == set(DRIVE_NAMES)


def test_a_sweep_of_drops_gives_each_design_what_predict_gives_it(runner, tmp_path):
    """The drop height, the drag coefficient and the bed's density varied: each row is `pen predict`'s for that
    design (the free fall is integrated design by design); a spring's key is not a drop's to vary."""
    import pyarrow.parquet as pq

    out = tmp_path / "s.parquet"
    result = invoke(runner, "sweep", "-p", "freefall_cone", "-m", "mpacs_b", "-e", "drop_water",
                    "--vary", "surface_offset_mm=500:1500", "--vary", "drag_coefficient=0.5,1.1",
                    "--vary", "bed_density_kg_m3=0,1900", "--resolution", "3", "--out", out)
    assert result.exit_code == 0, result.output
    rows = pq.read_table(out).to_pylist()
    assert len(rows) == 12 and len({round(r["contact_speed_m_s"], 9) for r in rows}) == 6
    assert len({round(r["final_depth_mm"], 9) for r in rows}) == 12  # the bed's buoyancy shows in each
    for row in rows:
        alone = json.loads(invoke(runner, "predict", "-p", "freefall_cone", "-m", "mpacs_b", "-e", "drop_water",
                                  "--json", "--set", f"surface_offset_mm={row['surface_offset_mm']}",
                                  "--set", f"drag_coefficient={row['drag_coefficient']}",
                                  "--set", f"bed_density_kg_m3={row['bed_density_kg_m3']}").stdout)
        for key in ("contact_speed_m_s", "final_depth_mm", "penetration_time_s", "spring_energy_j"):
            assert row[key] == pytest.approx(alone[key], rel=1e-12), key
    refused = invoke(runner, "sweep", "-p", "freefall_cone", "-m", "mpacs_b", "-e", "drop_water",
                     "--vary", "spring_count=2,4", "--out", tmp_path / "t.parquet")
    line = refused.stderr.strip()
    assert refused.exit_code == 1 and "spring_count" in line and "free fall" in line and "\n" not in line
    assert not (tmp_path / "t.parquet").exists()


def test_commands_that_integrate_the_springs_alone_say_so_in_one_line(runner, tmp_path):
    result = invoke(runner, "sweep", "-p", "freefall_cone", "-m", "mpacs_b", "-e", "drop_water",
                    "--solve", "max:surface_offset_mm", "--until", "peak_n<=5000")
    assert result.exit_code == 1 and "spring launcher only" in result.stderr
