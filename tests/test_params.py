"""Parameter files: presets, the contract's examples, and every bad case."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from pencli.params.definitions import KINDS, PARAMETERS, params_of
from pencli.params.load import all_presets, load_file
from pencli.params.schema import json_schema
from pencli.errors import ParameterError
from pencli.params.validate import validate_mapping
from tests.conftest import REPO, SPEC, invoke

GOOD = {
    "penetrator": ("kind: penetrator\nname: t\nblade_width_mm: 184\nblade_thickness_mm: 1.0\ntip_angle_deg: 89.9\n"
                   "penetration_depth_mm: 133\nsprung_mass_kg: 2.443\nload_cell_mass_kg: 0.389\n"),
    "material": ("kind: material\nname: t\ndensity_kg_m3: 400\nmicrostructure_strength_kpa: 6000\n"
                 "friction_coefficient: 0.4\ncoefficients:\n  strength_factor: 0.6\n  sidewall_pressure_kpa: 31.6\n"
                 "  damping_kpa_s_m: 0.0\n  inertia_coefficient: 34.4\n"),
    "energizing": ("kind: energizing\nname: t\nspring_count: 4\nspring_stiffness_kn_m: 1.45\nspring_mass_kg: 0.28\n"
                   "spring_nominal_length_mm: 500\nspring_compressed_length_mm: 340\nsurface_offset_mm: 148\n"
                   "propulsion_efficiency_pct: 98\n"),
}

# (name, kind, text transformation, words the one-line error must contain)
BAD = [
    ("unknown_key", "penetrator", lambda t: t + "blade_widht_mm: 3\n", ["unknown key 'blade_widht_mm'"]),
    ("unknown_coefficient", "material", lambda t: t + "  inertia_coeff: 3\n", ["unknown key 'coefficients.inertia_coeff'"]),
    ("key_of_other_kind", "penetrator", lambda t: t + "density_kg_m3: 3\n", ["density_kg_m3", "material file"]),
    ("missing_key", "penetrator", lambda t: t.replace("sprung_mass_kg: 2.443\n", ""), ["missing key 'sprung_mass_kg'"]),
    ("wrong_type", "penetrator", lambda t: t.replace("184", "wide"), ["blade_width_mm", "'wide'", "number"]),
    ("bool_is_not_a_number", "material", lambda t: t.replace("0.4\n", "yes\n", 1), ["friction_coefficient", "True"]),
    ("negative_width", "penetrator", lambda t: t.replace("184", "-184"), ["blade_width_mm", "-184", "> 0"]),
    ("efficiency_above_100", "energizing", lambda t: t.replace("98", "101"), ["propulsion_efficiency_pct", "101", "<= 100"]),
    ("thickness_above_width", "penetrator", lambda t: t.replace("blade_thickness_mm: 1.0", "blade_thickness_mm: 30").replace("184", "20"),
     ["blade_thickness_mm", "blade_width_mm"]),
    ("load_cell_heavier_than_body", "penetrator", lambda t: t.replace("0.389", "3.0"), ["load_cell_mass_kg", "sprung_mass_kg"]),
    ("fractional_spring_count", "energizing", lambda t: t.replace("spring_count: 4", "spring_count: 2.5"),
     ["spring_count", "whole number"]),
    ("out_of_documented_range", "material", lambda t: t.replace("friction_coefficient: 0.4", "friction_coefficient: 3"),
     ["friction_coefficient", "documented range", "--allow-out-of-range"]),
    ("nan_value", "material", lambda t: t.replace("density_kg_m3: 400", "density_kg_m3: .nan"), ["density_kg_m3", "nan"]),
    ("duplicate_key", "penetrator", lambda t: t + "blade_width_mm: 150\n", ["duplicate key 'blade_width_mm'"]),
    ("bad_yaml", "penetrator", lambda t: t + "oops: [unclosed\n", ["not valid YAML", "line"]),
    ("wrong_kind", "penetrator", lambda t: t.replace("kind: penetrator", "kind: blade"), ["'kind'", "'blade'"]),
    ("not_a_mapping", "penetrator", lambda t: "- just\n- a list\n", ["expected a mapping"]),
    ("empty_file", "penetrator", lambda t: "", ["expected a mapping"]),
]


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("kind", KINDS)
def test_good_files_validate(tmp_path, runner, kind):
    path = write(tmp_path, kind, GOOD[kind])
    assert load_file(path).kind == kind
    result = invoke(runner, "params", "validate", path)
    assert result.exit_code == 0, result.output


@pytest.mark.parametrize("name,kind,change,words", BAD, ids=[b[0] for b in BAD])
def test_bad_file_gives_one_line_naming_file_key_and_value(tmp_path, runner, name, kind, change, words):
    path = write(tmp_path, name, change(GOOD[kind]))
    result = invoke(runner, "params", "validate", path)
    assert result.exit_code == 1
    assert "Traceback" not in result.output
    fail_lines = [line for line in result.output.splitlines() if line.startswith("FAIL")]
    assert len(fail_lines) == 1
    assert str(path) in fail_lines[0]
    for word in words:
        assert word in fail_lines[0], (word, fail_lines[0])


@pytest.mark.parametrize("name,kind,change,words", BAD[:12], ids=[b[0] for b in BAD[:12]])
def test_bad_file_in_predict_is_one_red_line_exit_1(tmp_path, runner, name, kind, change, words):
    path = write(tmp_path, name, change(GOOD[kind]))
    refs = {"penetrator": "al6061_1mm", "material": "mpacs_c", "energizing": "springs_4", kind: str(path)}
    result = invoke(runner, "predict", "-p", refs["penetrator"], "-m", refs["material"], "-e", refs["energizing"])
    assert result.exit_code == 1
    assert "Traceback" not in result.output and result.exception is None or isinstance(result.exception, SystemExit)
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:") and str(path) in lines[0]


def test_out_of_range_accepted_when_allowed(tmp_path, runner):
    path = write(tmp_path, "mu3", GOOD["material"].replace("friction_coefficient: 0.4", "friction_coefficient: 3"))
    assert invoke(runner, "params", "validate", path).exit_code == 1
    assert invoke(runner, "params", "validate", "--allow-out-of-range", path).exit_code == 0


def test_validate_reports_every_file_and_fails_if_any_bad(tmp_path, runner):
    good = write(tmp_path, "good", GOOD["energizing"])
    bad = write(tmp_path, "bad", GOOD["energizing"].replace("98", "101"))
    result = invoke(runner, "params", "validate", good, bad)
    assert result.exit_code == 1
    assert "ok" in result.output and "FAIL" in result.output


def test_contract_examples_validate(runner):
    files = sorted((SPEC / "examples").glob("*.yaml")) + sorted((SPEC / "examples").glob("run_*/*.yaml"))
    files = [f for f in files if f.name != "run.yaml"]
    assert len(files) >= 7
    result = invoke(runner, "params", "validate", *files)
    assert result.exit_code == 0, result.output


def test_presets_cover_the_issue_and_agree_with_the_paper():
    by = {(p.kind, p.name): p for p in all_presets()}
    table1 = {  # paper Table 1: density g/cc, S kPa, mu, Cs, P kPa, C, K
        "grill_brick": (0.11, 1630, 0.75, 1.6, 7.07, 0, 46),
        "mpacs_b": (0.29, 2000, 0.4, 0.6, 12.5, 0, 10),
        "mpacs_c": (0.40, 6000, 0.4, 0.6, 31.6, 0, 34.4),
        "mpacs_d": (0.68, 40000, 0.4, 0.25, 530, 0, 70),
    }
    for name, (rho, S, mu, Cs, P, C, K) in table1.items():
        v = by[("material", name)].values
        assert v["density_kg_m3"] == pytest.approx(rho * 1000)
        assert (v["microstructure_strength_kpa"], v["friction_coefficient"]) == (S, mu)
        assert (v["coefficients.strength_factor"], v["coefficients.sidewall_pressure_kpa"],
                v["coefficients.damping_kpa_s_m"], v["coefficients.inertia_coefficient"]) == (Cs, P, C, K)
    assert "single experiment" in by[("material", "mpacs_d")].notes
    for n, joules in ((2, 92), (4, 184), (6, 276)):  # paper section 3, at full stroke
        v = by[("energizing", f"springs_{n}")].values
        stored = 0.5 * n * v["spring_stiffness_kn_m"] * 1e3 * (
            (v["spring_nominal_length_mm"] - v["spring_compressed_length_mm"]) / 1e3) ** 2
        assert stored == pytest.approx(joules, rel=1e-3)
    for t in ("1", "1.5", "2"):
        assert by[("penetrator", f"al6061_{t}mm")].values["blade_thickness_mm"] == float(t)
    pc = by[("penetrator", "appendix_c")].values
    assert (pc["blade_width_mm"], pc["blade_thickness_mm"], pc["tip_angle_deg"], pc["penetration_depth_mm"]) == (
        150, 1.5, 45, 130)
    ec = by[("energizing", "appendix_c")].values
    assert ec["spring_count"] * ec["spring_stiffness_kn_m"] == 10 and ec["spring_count"] * ec["spring_mass_kg"] == 1
    assert (ec["spring_nominal_length_mm"], ec["spring_compressed_length_mm"], ec["surface_offset_mm"]) == (500, 300, 150)
    assert "Figure 10" in by[("penetrator", "appendix_c")].notes


@pytest.mark.parametrize("kind", KINDS)
def test_committed_json_schema_matches_definitions(kind):
    committed = json.loads((REPO / "schema" / f"{kind}.schema.json").read_text())
    assert committed == json.loads(json.dumps(json_schema(kind))), "run: pen params schema --out schema/"


def test_schema_accepts_presets_and_rejects_unknown_keys():
    """A tiny checker of the schema's own rules, to show the schema says what validation does."""
    for preset in all_presets():
        schema = json_schema(preset.kind)
        mapping = preset.to_mapping()
        assert set(schema["required"]) <= set(mapping)
        assert set(mapping) <= set(schema["properties"])
        for key, value in mapping.items():
            prop = schema["properties"][key]
            if prop.get("type") in ("number", "integer"):
                assert value > prop.get("exclusiveMinimum", -float("inf"))
                assert value >= prop.get("minimum", -float("inf"))


def test_help_of_every_parameter_has_unit_and_range():
    for p in PARAMETERS:
        assert p.unit in p.help and "range" in p.help
    assert {p.kind for p in PARAMETERS} == set(KINDS)
    assert all(params_of(k) for k in KINDS)


def test_set_override_changes_the_design_and_is_validated(runner):
    base = invoke(runner, "predict", "-p", "al6061_1mm", "-m", "mpacs_d", "-e", "springs_4", "--json")
    wider = invoke(runner, "predict", "-p", "al6061_1mm", "-m", "mpacs_d", "-e", "springs_4", "--json",
                   "--set", "blade_width_mm=150", "--set", "coefficients.inertia_coefficient=40")
    assert base.exit_code == 0 and wider.exit_code == 0, wider.output
    a, b = json.loads(base.stdout), json.loads(wider.stdout)
    assert b["overrides"] == {"blade_width_mm": 150.0, "coefficients.inertia_coefficient": 40.0}
    assert not a["full_penetration"]
    assert b["final_depth_mm"] > a["final_depth_mm"]  # a narrower blade goes deeper
    # a value its key does not allow: input rejected, one line, exit 1
    for bad, words in (("blade_width_mm=-1", "blade_width_mm"),
                       ("blade_thickness_mm=60", "outside the documented range")):
        r = invoke(runner, "predict", "-p", "al6061_1mm", "-m", "mpacs_c", "-e", "springs_4", "--set", bad)
        assert r.exit_code == 1 and words in r.stderr and len(r.stderr.strip().splitlines()) == 1, (bad, r.output)
    # a malformed option: a usage error (CONTRACT §6), exit 2, naming what is wrong
    for bad, words in (("nosuch=1", "unknown key"), ("blade_width_mm=wide", "not a number"),
                       ("blade_width_mm", "KEY=VALUE")):
        r = invoke(runner, "predict", "-p", "al6061_1mm", "-m", "mpacs_c", "-e", "springs_4", "--set", bad)
        flat = " ".join(r.stderr.translate({ord(c): " " for c in "│╭╮╰╯─"}).split())  # typer's box, unwrapped
        assert r.exit_code == 2 and words in flat, (bad, r.output)


def test_unknown_preset_lists_the_bundled_ones(runner):
    r = invoke(runner, "predict", "-p", "al6061_9mm", "-m", "mpacs_c", "-e", "springs_4")
    assert r.exit_code == 1 and "al6061_1mm" in r.stderr


def test_missing_coefficient_names_the_key_and_the_fix(tmp_path, runner):
    text = GOOD["material"].replace("  inertia_coefficient: 34.4\n", "")
    path = write(tmp_path, "noK", text)
    r = invoke(runner, "predict", "-p", "al6061_1mm", "-m", path, "-e", "springs_4")
    assert r.exit_code == 1 and "coefficients.inertia_coefficient" in r.stderr
    ok = invoke(runner, "predict", "-p", "al6061_1mm", "-m", path, "-e", "springs_4",
                "--terms", "strength,friction,damping")
    assert ok.exit_code == 0, ok.output


def test_params_show_round_trips_through_validation(tmp_path, runner):
    r = invoke(runner, "params", "show", "mpacs_d", "--json")
    assert r.exit_code == 0
    (mapping,) = json.loads(r.stdout)
    path = write(tmp_path, "roundtrip", yaml.safe_dump(mapping))
    assert load_file(path).values["coefficients.sidewall_pressure_kpa"] == 530


def test_spring_length_at_contact_is_an_alternative_to_the_compressed_length(tmp_path):
    """CONTRACT §1: BAM's 'spring length at contact' = compressed length + stand-off; one or the other."""
    import yaml

    from pencli.errors import ParameterError
    from pencli.params.validate import validate_mapping

    base = {"kind": "energizing", "name": "e", "spring_count": 4, "spring_stiffness_kn_m": 1.45,
            "spring_mass_kg": 0.28, "spring_nominal_length_mm": 500.0, "surface_offset_mm": 143.289,
            "propulsion_efficiency_pct": 98.0}
    by_contact = validate_mapping({**base, "spring_length_at_contact_mm": 487.989}, "c.yaml")
    by_split = validate_mapping({**base, "spring_compressed_length_mm": 344.7}, "s.yaml")
    assert by_contact.get("spring_compressed_length_mm") == pytest.approx(344.7, abs=1e-9)
    assert by_contact.to_mapping()["spring_length_at_contact_mm"] == 487.989
    assert "spring_compressed_length_mm" not in by_contact.to_mapping()  # written back as given
    from pencli import api

    p = api.predict("figure10", "figure10", _write(tmp_path / "c.yaml", by_contact.to_mapping(), yaml))
    q = api.predict("figure10", "figure10", _write(tmp_path / "s.yaml", by_split.to_mapping(), yaml))
    assert p.result.summary.contact_speed_m_s == q.result.summary.contact_speed_m_s
    assert p.result.summary.contact_speed_m_s == pytest.approx(7.155133, rel=1e-6)  # the paper's Figure 10
    with pytest.raises(ParameterError, match="give one, never both"):
        validate_mapping({**base, "spring_length_at_contact_mm": 487.989, "spring_compressed_length_mm": 344.7},
                         "b.yaml")
    with pytest.raises(ParameterError, match="spring_length_at_contact_mm"):
        validate_mapping(base, "n.yaml")
    swapped = by_contact.with_values({"spring_compressed_length_mm": 340.0})  # --set replaces the alternative
    assert swapped.get("spring_compressed_length_mm") == 340.0 and "spring_length_at_contact_mm" not in swapped.values
    assert load_file(tmp_path / "c.yaml").get("spring_compressed_length_mm") == pytest.approx(344.7)


def _write(path, mapping, yaml):
    path.write_text(yaml.safe_dump(mapping))
    return str(path)


def test_full_depth_prediction_is_not_called_outside_a_fit_that_saw_full_depth(tmp_path):
    """'depth 133 mm is outside 0–133 mm' (runs recorded a hair short of the stops)."""
    from pencli import api

    mapping = load_file(REPO / "pencli" / "params" / "presets" / "material" / "grill_brick.yaml").to_mapping()
    mapping["fitted_ranges"] = {"depth_mm": [0.0, 132.9]}
    path = tmp_path / "fitted.yaml"
    path.write_text(yaml.safe_dump(mapping))
    full = api.predict("appendix_c", str(path), "appendix_c")
    assert full.result.summary.full_penetration and not full.warnings, full.warnings
    mapping["fitted_ranges"] = {"depth_mm": [0.0, 60.0]}
    path.write_text(yaml.safe_dump(mapping))
    assert any("depth" in w for w in api.predict("appendix_c", str(path), "appendix_c").warnings)


COVARIANCE = {"strength_factor": {"strength_factor": 4e-4, "inertia_coefficient": -1e-3},
              "inertia_coefficient": {"strength_factor": -1e-3, "inertia_coefficient": 0.25}}


@pytest.mark.parametrize("covariance, said", [
    ({"strength_factr": {"strength_factr": 1.0}}, "coefficient_covariance.strength_factr': unknown coefficient"),
    ({"strength_factor": {"strength_factor": -1.0}}, "a variance is ≥ 0"),
    ({**COVARIANCE, "strength_factor": {"strength_factor": 4e-4, "inertia_coefficient": 1e-3}}, "symmetric"),
    ({**COVARIANCE, "inertia_coefficient": {"inertia_coefficient": 0.25}}, "expected a value for each of"),
    ({"strength_factor": {"strength_factor": "big"}}, "expected a finite number"),
    ([1, 2], "expected a mapping"),
])
def test_a_bad_coefficient_covariance_is_one_line_naming_the_key(covariance, said):
    mapping = load_file(REPO / "pencli" / "params" / "presets" / "material" / "mpacs_c.yaml").to_mapping()
    mapping["coefficient_covariance"] = covariance
    with pytest.raises(ParameterError, match="coefficient_covariance") as caught:
        validate_mapping(mapping, "fitted.yaml")
    assert said in str(caught.value) and "\n" not in str(caught.value)


def test_a_coefficient_covariance_survives_a_round_trip_and_the_schema(tmp_path):
    import jsonschema

    from pencli.params.schema import json_schema

    mapping = load_file(REPO / "pencli" / "params" / "presets" / "material" / "mpacs_c.yaml").to_mapping()
    mapping["coefficient_covariance"] = COVARIANCE
    checked = validate_mapping(mapping, "fitted.yaml")
    assert checked.coefficient_covariance == COVARIANCE
    again = validate_mapping(yaml.safe_load(yaml.safe_dump(checked.to_mapping())), "again.yaml")
    assert again.coefficient_covariance == COVARIANCE
    jsonschema.validate(checked.to_mapping(), json_schema("material"))
    mapping["coefficient_covariance"] = {"strength_factr": {"strength_factr": 1.0}}
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(mapping, json_schema("material"))
