"""A geometry pen does not ship, added as a user adds one (:mod:`tests.toy_pyramid`: one module, one registration
line), goes through validation, predict, the sweep, the store, the simulated rig, fit and diagnose, and leaves
nothing behind once taken out again."""

from __future__ import annotations

import html
import json
import math

import pytest
import yaml
from tests import toy_pyramid
from tests.conftest import REPO, invoke
from tests.test_geometry_files import LAUNCHER, arrest_on_two_springs

PYRAMID = {"kind": "penetrator", "name": "pyramid", "geometry": "square_pyramid", "pyramid_half_angle_deg": 30.0,
           "shaft_side_mm": 30.0, "penetration_depth_mm": 133.0, "sprung_mass_kg": 2.443, "load_cell_mass_kg": 0.389}


@pytest.fixture
def pyramid():
    with toy_pyramid.register():
        yield


def write(folder, name, mapping):
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(mapping, sort_keys=False))
    return str(path)


def pyramid_resistance(x: float, v: float, material: dict) -> float:
    """The pyramid's resistance from its faces written out here: section side s = min(2x·tan α, a), the strength
    on the section times sin α + μ·cos α, P on the shaft's four faces below the tip's length, the rate terms on
    the section. [N]"""
    if x <= 0.0:
        return 0.0
    alpha, a = math.radians(PYRAMID["pyramid_half_angle_deg"]), PYRAMID["shaft_side_mm"] / 1e3
    c, mu = material["coefficients"], material["friction_coefficient"]
    section = min(2.0 * x * math.tan(alpha), a) ** 2
    shaft = 4.0 * a * max(x - a / (2.0 * math.tan(alpha)), 0.0)
    v = max(v, 0.0)
    return (c["strength_factor"] * material["microstructure_strength_kpa"] * 1e3 * section
            * (math.sin(alpha) + mu * math.cos(alpha))
            + mu * c["sidewall_pressure_kpa"] * 1e3 * shaft
            + section * (c["damping_kpa_s_m"] * 1e3 * v + c["inertia_coefficient"] * material["density_kg_m3"] * v * v))


def test_a_registered_geometry_validates_predicts_and_sweeps_as_its_areas_say(tmp_path, runner, pyramid):
    material = yaml.safe_load((REPO / "pencli" / "params" / "presets" / "material" / "mpacs_c.yaml").read_text())
    files = [write(tmp_path, "pyramid", PYRAMID), write(tmp_path, "two", LAUNCHER)]
    # its keys are the parameter definition's: listed with units, checked, in the schema
    keys = invoke(runner, "params", "keys", "--kind", "penetrator")
    assert "shaft_side_mm" in keys.stdout and "square_pyramid" in keys.stdout
    bad = invoke(runner, "predict", "-p", write(tmp_path, "bad", {**PYRAMID, "shaft_side_mm": -3.0}), "-m",
                 "mpacs_c", "-e", files[1])
    assert bad.exit_code == 1 and "shaft_side_mm" in bad.stderr and "\n" not in bad.stderr.strip()
    from pencli.params.schema import json_schema

    assert "square_pyramid" in json.dumps(json_schema("penetrator"))
    # predict: the motion an integration of the pyramid's resistance written above gives
    result = invoke(runner, "predict", "-p", files[0], "-m", "mpacs_c", "-e", files[1], "--json")
    assert result.exit_code == 0, result.output
    s = json.loads(result.stdout)
    assert s["geometry"] == "square_pyramid" and s["end"] == "arrest"
    depth, time = arrest_on_two_springs(lambda x, v: pyramid_resistance(x, v, material), PYRAMID["sprung_mass_kg"],
                                       s["contact_speed_m_s"])
    assert s["final_depth_mm"] / 1e3 == pytest.approx(depth, rel=1e-8)
    assert s["penetration_time_s"] == pytest.approx(time, rel=1e-8)
    # the sweep varies its keys; each row is predict's for that design
    out = tmp_path / "sweep.parquet"
    swept = invoke(runner, "sweep", "-p", files[0], "-m", "mpacs_c", "-e", files[1], "--vary",
                   "shaft_side_mm=20,40", "--out", str(out))
    assert swept.exit_code == 0, swept.output
    import pyarrow.parquet as pq

    for row in pq.read_table(out).to_pylist():
        alone = json.loads(invoke(runner, "predict", "-p", files[0], "-m", "mpacs_c", "-e", files[1], "--json",
                                  "--set", f"shaft_side_mm={row['shaft_side_mm']}").stdout)
        assert row["final_depth_mm"] == pytest.approx(alone["final_depth_mm"], rel=1e-9)


@pytest.mark.slow
def test_runs_of_a_registered_geometry_are_stored_fitted_and_diagnosed(tmp_path, runner, pyramid):
    """Six pyramids (20, 30, 40 mm shafts; 2 and 6 springs) fired by the simulated rig, whose true world puts its
    own law of the material on the pyramid's areas: stored with their geometry and no blade, the fit finds
    MPACS C's strength factor within 3 %, and a campaign with nothing hidden is diagnosed `none`."""
    from pencli import api
    from pencli.testing.campaigns import make_campaign

    shots = []
    for side in (20.0, 30.0, 40.0):
        name = f"pyramid_{side:g}"
        shots += [(write(tmp_path, name, {**PYRAMID, "name": name, "shaft_side_mm": side}), springs)
                  for springs in (2, 6)]
    db = make_campaign(tmp_path, "mpacs_c", shots=shots, seed=31)
    runs = api.list_runs(db)
    assert len(runs) == 6 and {r["blade_thickness_mm"] for r in runs} == {None}
    assert api.query(db, "SELECT DISTINCT geometry FROM runs")[1] == [("square_pyramid",)]
    api.tare_runs(db, ["all"])
    api.subtract_inertia_runs(db, ["all"])
    fitted = api.fit(db, "mpacs_c", ["all"], record=False).result.coefficients
    truth = yaml.safe_load((REPO / "pencli" / "params" / "presets" / "material" / "mpacs_c.yaml").read_text())
    assert fitted["strength_factor"].value == pytest.approx(truth["coefficients"]["strength_factor"], rel=0.03)
    assert api.diagnose(db, ["all"]).verdict == "none"
    # a run's report names its shape, and lists its keys by their meaning beside the file key
    out = tmp_path / "one.html"
    result = invoke(runner, "report", runs[0]["run_id"], "--db", str(db), "--out", str(out), "--no-pdf")
    assert result.exit_code == 0, result.output
    page = html.unescape(out.read_text())
    assert "square pyramid" in page and "the blade " not in page
    assert "side of a pyramid's square shaft" in page


def test_a_geometry_taken_out_again_leaves_the_definition_as_it_was():
    from pencli.model.geometry import GEOMETRIES
    from pencli.params.definitions import BY_KEY, CHOICE_BY_KEY, PARAMETERS, VARIANTS
    from pencli.params.schema import json_schema

    before = (len(PARAMETERS), dict(VARIANTS), CHOICE_BY_KEY["geometry"], json_schema("penetrator"))
    with toy_pyramid.register():
        assert "square_pyramid" in GEOMETRIES and "shaft_side_mm" in BY_KEY
        with pytest.raises(ValueError, match="already registered"):
            toy_pyramid.register()
    assert "square_pyramid" not in GEOMETRIES and "shaft_side_mm" not in BY_KEY
    assert (len(PARAMETERS), dict(VARIANTS), CHOICE_BY_KEY["geometry"], json_schema("penetrator")) == before
