"""Edge classes of the CONTRACT §2 model found by the outside check, against the independent oracle."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import yaml

from pencli.params.load import load_preset
from tests.conftest import invoke
from pencli.testing.reference import reference_run


def _mappings(p, m, e, **energizing):
    maps = [load_preset(name, kind).to_mapping() for name, kind in
            ((p, "penetrator"), (m, "material"), (e, "energizing"))]
    maps[2].update(energizing)
    return maps


def test_full_depth_just_short_of_the_arrest_point_is_full_depth(runner):
    """A depth limit just short of where the blade would arrest; the tip passed the stops and
    came back within one step, and the run was called an arrest beyond the stops."""
    p, m, e = _mappings("appendix_c", "grill_brick", "appendix_c", spring_stiffness_kn_m=5)
    free = reference_run({**p, "penetration_depth_mm": 1000.0}, m, e)
    assert not free["full_penetration"]
    limit = free["final_depth_mm"] - 1.2e-4  # the outside check's case: 121.83269 against 121.83281 mm
    want = reference_run({**p, "penetration_depth_mm": limit}, m, e)
    assert want["full_penetration"]
    result = invoke(runner, "predict", "-p", "appendix_c", "-m", "grill_brick", "-e", "appendix_c",
                    "--set", "spring_stiffness_kn_m=5", "--set", f"penetration_depth_mm={limit!r}", "--json")
    assert result.exit_code == 0, result.output
    got = json.loads(result.stdout)
    assert got["full_penetration"] is True and got["end"] == "full_depth"
    assert got["final_depth_mm"] == pytest.approx(limit, rel=1e-12)
    assert got["penetration_time_s"] == pytest.approx(want["penetration_time_s"], rel=1e-4)
    assert got["residual_ke_j"] > 0.0
    assert abs(got["energy_balance_error_j"]) < 1e-6


@pytest.mark.parametrize("compressed_mm", [500.0, 620.0])  # free length 500 mm: zero stroke, and beyond it
def test_springs_not_compressed_at_release_are_a_gravity_drop(runner, tmp_path, compressed_mm):
    """CONTRACT §2 puts the spring force at 0 beyond the free length, so springs at zero
    stroke (or longer than free) are a valid design: the body falls under gravity alone."""
    p, m, e = _mappings("appendix_c", "grill_brick", "appendix_c", spring_compressed_length_mm=compressed_mm)
    assert e["spring_nominal_length_mm"] == 500.0
    energizing = tmp_path / "drop.yaml"
    energizing.write_text(yaml.safe_dump(e))
    result = invoke(runner, "predict", "-p", "appendix_c", "-m", "grill_brick", "-e", energizing, "--json")
    assert result.exit_code == 0, result.output
    got = json.loads(result.stdout)
    g = m.get("gravity_m_s2", 9.81)
    assert got["contact_speed_m_s"] == pytest.approx(math.sqrt(2 * g * e["surface_offset_mm"] / 1e3), rel=1e-9)
    assert got["spring_energy_j"] == 0.0
    want = reference_run(p, m, e)
    for key in ("contact_speed_m_s", "penetration_time_s", "final_depth_mm", "peak_resistance_n"):
        assert got[key] == pytest.approx(want[key], rel=1e-4), key
    out = tmp_path / "drop.parquet"
    swept = invoke(runner, "sweep", "-p", "appendix_c", "-m", "grill_brick", "-e", energizing,
                   "--vary", f"surface_offset_mm=100,{e['surface_offset_mm']}", "--out", out, "--json")
    assert swept.exit_code == 0, swept.output
    import pyarrow.parquet as pq

    table = pq.read_table(out).to_pydict()
    row = table["surface_offset_mm"].index(e["surface_offset_mm"])
    assert table["end"][row] != "invalid"
    assert table["final_depth_mm"][row] == pytest.approx(want["final_depth_mm"], rel=1e-4)


@pytest.mark.parametrize("sets,names", [
    (["density_kg_m3=1e300"], "density_kg_m3"),
    (["blade_width_mm=1e300", "blade_thickness_mm=1e299"], "blade_width_mm"),
])
def test_absurd_inputs_end_in_one_line(runner, sets, names):
    """Density 1e300 gave a traceback, width 1e300 hung past 600 s."""
    args = ["predict", "-p", "appendix_c", "-m", "grill_brick", "-e", "appendix_c", "--allow-out-of-range"]
    for s in sets:
        args += ["--set", s]
    result = invoke(runner, *args)
    assert result.exit_code == 1
    assert isinstance(result.exception, SystemExit)  # a handled error, not a traceback
    lines = [ln for ln in result.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:") and names in lines[0], result.output


def test_a_long_fall_is_sampled_within_bounded_memory(runner):
    """A stand-off of 1e9 mm sampled 450 s at 50 kHz (3.3 GB); now at most MAX_SAMPLES."""
    from pencli import api
    from pencli.model.dynamics import MAX_SAMPLES

    pred = api.predict("appendix_c", "grill_brick", "appendix_c", overrides=["surface_offset_mm=1e9"],
                       allow_out_of_range=True)
    assert len(pred.result.trajectory) <= MAX_SAMPLES + 16
    g = pred.design.gravity_m_s2
    # a long drop: the contact speed is the free fall's from the end of the spring stroke
    assert pred.result.summary.contact_speed_m_s == pytest.approx(math.sqrt(2 * g * 1e6), rel=1e-3)
    assert any("sampled at" in w for w in pred.to_dict()["warnings"])


def test_an_energy_balance_beyond_tolerance_is_a_warning(monkeypatch):
    """The balance error was never reported; beyond the tolerance it is a warning."""
    from pencli import api
    import pencli.model.dynamics as dyn

    quiet = api.predict("appendix_c", "grill_brick", "appendix_c")
    assert not any("energy balance" in w for w in quiet.to_dict()["warnings"])
    monkeypatch.setattr(dyn, "ENERGY_TOLERANCE", 1e-30)
    loud = api.predict("appendix_c", "grill_brick", "appendix_c")
    assert any("energy balance" in w for w in loud.to_dict()["warnings"])


def _sweep(runner, tmp_path, name, *args):
    import pyarrow.parquet as pq

    out = tmp_path / f"{name}.parquet"
    result = invoke(runner, "sweep", *args, "--out", out, "--json")
    assert result.exit_code == 0, result.output
    return pq.read_table(out).to_pydict()


@pytest.mark.parametrize("offset", [0.0, None])  # 0: starts at the surface and creeps; None: 11.6 m/s, arrests
def test_large_damping_in_the_batch_matches_the_oracle(runner, tmp_path, offset):
    """At C = 3,000–100,000 kPa·s/m the batch's RK4 left its stability region (final
    depth off by 0.16 % to 96 %), and a creeping run had no defined time (0.896 s, 3.20 s, 0.948 s by
    round-off).  Both simulators now agree with the oracle, which implements the creep rule (docs/guide/sweeps.md) itself."""
    p, m, e = _mappings("appendix_c", "grill_brick", "appendix_c")
    sets = [] if offset is None else ["--set", f"surface_offset_mm={offset}"]
    if offset is not None:
        e["surface_offset_mm"] = offset
    table = _sweep(runner, tmp_path, "damping", "-p", "appendix_c", "-m", "grill_brick", "-e", "appendix_c", *sets,
                   "--vary", "coefficients.damping_kpa_s_m=3000,10000,100000")
    for row, damping in enumerate(table["coefficients.damping_kpa_s_m"]):
        want = reference_run(p, {**m, "coefficients": {**m["coefficients"], "damping_kpa_s_m": damping}}, e)
        assert table["end"][row] == want["end"], damping
        for key in ("penetration_time_s", "final_depth_mm", "peak_resistance_n"):
            assert table[key][row] == pytest.approx(want[key], rel=1e-4), (damping, key)
        if want["end"] == "creep":
            got = json.loads(invoke(runner, "predict", "-p", "appendix_c", "-m", "grill_brick", "-e", "appendix_c",
                                    *sets, "--set", f"coefficients.damping_kpa_s_m={damping}", "--json").stdout)
            assert got["end"] == "creep" and got["full_penetration"] is False
            assert got["penetration_time_s"] == pytest.approx(want["penetration_time_s"], rel=1e-4)
            assert got["final_depth_mm"] == pytest.approx(want["final_depth_mm"], rel=1e-6)


@pytest.mark.parametrize("damping", [0.0, 300.0])  # the closed form, and the damped path
def test_batch_near_the_full_depth_boundary_matches_the_oracle(damping):
    """With the limit within 0.1 % of the arrest depth the batch's time was off by up to 3e-3
    and its residual energy by 0.2–100 %, and 9 of 30 such designs were called arrests."""
    from pencli.model.design import design_from_sets
    from pencli.params.load import resolve
    from pencli.predict.batch import design_arrays, simulate_batch

    p, m, e = _mappings("appendix_c", "grill_brick", "appendix_c", spring_stiffness_kn_m=5)
    m["coefficients"] = {**m["coefficients"], "damping_kpa_s_m": damping}
    free = reference_run({**p, "penetration_depth_mm": 1000.0}, m, e)
    assert free["end"] == "arrest"
    for gap in (1e-5, 1e-4, 1e-3):
        limit = free["final_depth_mm"] * (1 - gap)
        want = reference_run({**p, "penetration_depth_mm": limit}, m, e)
        assert want["full_penetration"] and want["residual_ke_j"] > 0
        design = design_from_sets(resolve("appendix_c", "penetrator").with_values({"penetration_depth_mm": limit}),
                                  resolve("grill_brick", "material").with_values(
                                      {"coefficients.damping_kpa_s_m": damping}),
                                  resolve("appendix_c", "energizing").with_values({"spring_stiffness_kn_m": 5}))
        got = simulate_batch(design_arrays(design))
        assert got.end[0] == "full_depth", gap
        for key in ("penetration_time_s", "residual_ke_j", "peak_resistance_n"):
            assert got.figures[key][0] == pytest.approx(want[key], rel=1e-4), (gap, key)


@pytest.mark.parametrize("damping", [1000.0, 100000.0])
def test_damped_design_without_inertia_term_runs_on_the_linear_flow_from_contact(damping):
    """With K = 0 the damped motion is linear from contact; such designs were never handed to the linear flow
    and ended 'stalled' at depth 0 (found by a random fuzz of the batch, not by the outside check)."""
    from pencli.model.design import design_from_sets
    from pencli.params.load import resolve
    from pencli.predict.batch import design_arrays, simulate_batch

    p, m, e = _mappings("appendix_c", "grill_brick", "appendix_c")
    m["coefficients"] = {**m["coefficients"], "damping_kpa_s_m": damping, "inertia_coefficient": 0.0}
    want = reference_run(p, m, e)
    design = design_from_sets(resolve("appendix_c", "penetrator"), resolve("grill_brick", "material").with_values(
        {"coefficients.damping_kpa_s_m": damping, "coefficients.inertia_coefficient": 0.0}),
        resolve("appendix_c", "energizing"))
    got = simulate_batch(design_arrays(design))
    assert got.end[0] == want["end"]
    for key in ("penetration_time_s", "final_depth_mm", "peak_resistance_n"):
        assert got.figures[key][0] == pytest.approx(want[key], rel=1e-4), key


def _case(pen: dict, mat: dict, ene: dict) -> list[dict]:
    """Appendix C in grill brick with a table's penetrator, material (coefficients by their short key) and
    energizing values replaced: the three mappings, in file units."""
    p, m, e = _mappings("appendix_c", "grill_brick", "appendix_c", **ene)
    p.update(pen)
    coefficients = {k: v for k, v in mat.items() if k in ("sidewall_pressure_kpa", "damping_kpa_s_m",
                                                          "inertia_coefficient")}
    m.update({k: v for k, v in mat.items() if k not in coefficients})
    m["coefficients"] = {**m["coefficients"], **coefficients}
    return [p, m, e]


_STALLED_BEFORE = {  # two of the 24 designs (of a 4,000-design fuzz) that the lock-step numpy batch left 'stalled'
    "slow_drop": ({"blade_width_mm": 14.2682, "blade_thickness_mm": 2.06123, "sprung_mass_kg": 2.58484},
                  {"density_kg_m3": 1388.15, "microstructure_strength_kpa": 404.284, "sidewall_pressure_kpa": 0.255869,
                   "damping_kpa_s_m": 9081.46, "inertia_coefficient": 2.48636},
                  {"spring_stiffness_kn_m": 1.01104, "surface_offset_mm": 3073.53}),
    "heavy_wide": ({"blade_width_mm": 333.292, "blade_thickness_mm": 1.853, "sprung_mass_kg": 50.3533},
                   {"density_kg_m3": 16.8639, "microstructure_strength_kpa": 98.4284, "sidewall_pressure_kpa": 1.03406,
                    "damping_kpa_s_m": 7129.03, "inertia_coefficient": 3.45823},
                   {"spring_stiffness_kn_m": 1.58225, "surface_offset_mm": 7.51168}),
}


@pytest.mark.parametrize("case", sorted(_STALLED_BEFORE))
def test_heavily_damped_designs_end_in_the_batch_as_in_the_oracle(case):
    """Heavy damping with a v² term: thousands of damping-limited RK4 steps before the linear regime.  The
    lock-step batch stopped after 6,400 and called them 'stalled'; each design now runs its own compiled
    loop with a budget of 2·10⁶ steps."""
    from pencli.model.design import design_from_sets
    from pencli.params.validate import validate_mapping
    from pencli.predict.batch import design_arrays, simulate_batch

    p, m, e = _case(*_STALLED_BEFORE[case])
    want = reference_run(p, m, e)
    sets = [validate_mapping(x, case, expected_kind=kind, allow_out_of_range=True)
            for x, kind in ((p, "penetrator"), (m, "material"), (e, "energizing"))]
    got = simulate_batch(design_arrays(design_from_sets(*sets)))
    assert got.end[0] == want["end"]
    for key in ("penetration_time_s", "final_depth_mm", "peak_resistance_n", "residual_ke_j"):
        assert got.figures[key][0] == pytest.approx(want[key], rel=1e-4, abs=1e-9), key


def test_unit_columns_times_file_coefficients_are_the_papers_eq9():
    """The fit's and the diagnosis's columns (one file unit of each coefficient, from the parameter definitions)
    times coefficients in file units give Eq. 9 written out here from the paper, kPa converted by hand."""
    import numpy as np

    from pencli.fit.resistance import with_coefficients
    from pencli.model.design import design_from_sets
    from pencli.model.resistance import eq9_coefficients, unit_terms

    d = design_from_sets(load_preset("appendix_c", "penetrator"), load_preset("grill_brick", "material"),
                         load_preset("appendix_c", "energizing"))
    cs, p_kpa, c_kpa_s_m, k = 0.8, 3.5, 12.0, 21.0
    x, v = np.array([0.01, 0.05, 0.12]), np.array([6.0, 3.0, 0.5])
    w, t, th, mu = d.blade_width_m, d.blade_thickness_m, d.tip_angle_rad, d.friction_coefficient
    paper = w * t * (cs * d.strength_pa * (math.sin(th) + mu * math.cos(th)) + mu * p_kpa * 1e3 * 2 * x / t
                     + c_kpa_s_m * 1e3 * v + k * d.density_kg_m3 * v * v)
    columns = np.column_stack(np.broadcast_arrays(*unit_terms(d, x, v)))
    assert columns @ np.array([cs, p_kpa, c_kpa_s_m, k]) == pytest.approx(paper, rel=1e-12)
    a0, a1, b, dd = eq9_coefficients(with_coefficients(d, {"strength_factor": cs, "sidewall_pressure_kpa": p_kpa,
                                                           "damping_kpa_s_m": c_kpa_s_m, "inertia_coefficient": k}))
    assert a0 + a1 * x + b * v + dd * v * v == pytest.approx(paper, rel=1e-12)


@pytest.mark.parametrize("fields", [{"density_kg_m3": 1e300}, {"blade_width_m": 1e300, "blade_thickness_m": 1e299},
                                    {"damping_pa_s_m": 1e300}])
def test_batch_marks_designs_the_scalar_simulator_refuses_as_overflow(fields):
    """A force beyond float64's reach: `pen predict` refuses the design in one line, and the batch used to
    return figures for it anyway (an 'arrest' at 2e-23 mm after 2e124 s for a density of 1e300)."""
    from dataclasses import replace

    from pencli.model.design import design_from_sets
    from pencli.model.dynamics import simulate
    from pencli.params.load import resolve
    from pencli.predict.batch import design_arrays, simulate_batch

    base = design_from_sets(resolve("appendix_c", "penetrator"), resolve("grill_brick", "material"),
                            resolve("appendix_c", "energizing"))
    design = replace(base, **fields)
    with pytest.raises(Exception, match="cannot be integrated in float64"):
        simulate(design)
    got = simulate_batch(design_arrays(design))
    assert got.end[0] == "overflow"
    assert np.isnan(got.figures["penetration_time_s"][0]) and not got.figures["full_penetration"][0]  # no figure
    ordinary = simulate_batch(design_arrays(base))
    assert ordinary.end[0] in ("arrest", "full_depth")


_STEEP_INERTIA = {  # within every documented range; found by bench/bench_batch_fuzz.py (seed 1)
    "light_wide_blade_c0": ({"blade_width_mm": 945.439, "blade_thickness_mm": 0.551867, "sprung_mass_kg": 0.0879361,
                             "load_cell_mass_kg": 0.0879361},
                            {"density_kg_m3": 2911.81, "microstructure_strength_kpa": 344.691,
                             "sidewall_pressure_kpa": 52.1692, "damping_kpa_s_m": 0.0, "inertia_coefficient": 867.12},
                            {"spring_stiffness_kn_m": 190.382, "surface_offset_mm": 11.6679}),
    "light_thick_blade_damped": ({"blade_width_mm": 101.571, "blade_thickness_mm": 25.4304,
                                  "sprung_mass_kg": 0.286045, "load_cell_mass_kg": 0.286045},
                                 {"density_kg_m3": 1604.15, "microstructure_strength_kpa": 130.817,
                                  "sidewall_pressure_kpa": 0.811162, "damping_kpa_s_m": 5.00656,
                                  "inertia_coefficient": 702.272},
                                 {"spring_stiffness_kn_m": 8.42079, "surface_offset_mm": 41.0301}),
}


@pytest.mark.parametrize("case", sorted(_STEEP_INERTIA))
def test_steep_inertia_in_the_batch_matches_the_oracle(case):
    """λ = 2wTKρ/m of several hundred per depth travelled: v² falls as e^{−λx} and 1/√v² grows as steeply.
    One 8+8-node Gauss rule over the segment was 1.7e-3 off in penetration time (C = 0), and RK4 at half the
    damping time 1.3e-4 (C > 0); the batch now cuts the C = 0 segment where q changes by about e, and the
    damped path steps at a quarter of the damping time."""
    from pencli.model.design import design_from_sets
    from pencli.params.validate import validate_mapping
    from pencli.predict.batch import design_arrays, simulate_batch

    p, m, e = _case(*_STEEP_INERTIA[case])
    want = reference_run(p, m, e)
    sets = [validate_mapping(x, case, expected_kind=kind) for x, kind in
            ((p, "penetrator"), (m, "material"), (e, "energizing"))]  # no range override: documented designs
    got = simulate_batch(design_arrays(design_from_sets(*sets)))
    assert got.end[0] == want["end"]
    for key in ("penetration_time_s", "final_depth_mm", "peak_resistance_n", "residual_ke_j"):
        assert got.figures[key][0] == pytest.approx(want[key], rel=1e-4, abs=1e-9), key


_CREEPS = {  # heavily damped designs of bench/bench_batch_fuzz.py (seed 7); K of the third is above its range
    "creep_while_rk4": ({"blade_width_mm": 420.118, "blade_thickness_mm": 6.46963, "sprung_mass_kg": 0.397962},
                        {"density_kg_m3": 449.415, "microstructure_strength_kpa": 182.211,
                         "sidewall_pressure_kpa": 32.8132, "damping_kpa_s_m": 243.328, "inertia_coefficient": 382.201},
                        {"spring_stiffness_kn_m": 11.3142, "surface_offset_mm": 10.692}),
    "creep_while_rk4_b": ({"blade_width_mm": 677.752, "blade_thickness_mm": 8.68321, "sprung_mass_kg": 0.338822,
                           "load_cell_mass_kg": 0.338822},
                          {"density_kg_m3": 389.928, "microstructure_strength_kpa": 238.631,
                           "sidewall_pressure_kpa": 5.2444, "damping_kpa_s_m": 109.138,
                           "inertia_coefficient": 989.928},
                          {"spring_stiffness_kn_m": 34.3601, "surface_offset_mm": 5.34714}),
    "stiff_creep_50s": ({"blade_width_mm": 273.842, "blade_thickness_mm": 22.1797, "sprung_mass_kg": 0.582058},
                        {"density_kg_m3": 756.728, "microstructure_strength_kpa": 288.277,
                         "sidewall_pressure_kpa": 0.327764, "damping_kpa_s_m": 42473.3, "inertia_coefficient": 1036.24},
                        {"spring_stiffness_kn_m": 57.0217, "surface_offset_mm": 86.6839}),
    "creep_170s": ({"blade_width_mm": 302.616, "blade_thickness_mm": 9.4629, "sprung_mass_kg": 0.31555,
                    "load_cell_mass_kg": 0.31555},
                   {"density_kg_m3": 7.5797, "microstructure_strength_kpa": 127.7, "sidewall_pressure_kpa": 8.98089,
                    "damping_kpa_s_m": 84679.0, "inertia_coefficient": 60.2715},
                   {"spring_stiffness_kn_m": 12.2882, "surface_offset_mm": 31.7807}),
}


@pytest.mark.parametrize("case", sorted(_CREEPS))
def test_creeping_designs_end_alike_in_both_simulators(case):
    """Creep is one rule (model.design.creep_point) in both simulators.  Before: the batch checked it only
    once its exact linear flow had taken over, so a tip that reached x* − δ slowly while RK4 still ran was
    called an arrest seconds later (first two cases); RK4 ran out of steps on a stiff 50-s creep (now the
    exact flow takes over after 20,000 RK4 steps); and pen predict gave up after 60 s of simulated time on
    a 170-s creep (now it integrates until the run ends)."""
    from pencli.model.design import design_from_sets
    from pencli.model.dynamics import simulate
    from pencli.params.validate import validate_mapping
    from pencli.predict.batch import design_arrays, simulate_batch

    p, m, e = _case(*_CREEPS[case])
    sets = [validate_mapping(x, case, expected_kind=kind, allow_out_of_range=True)
            for x, kind in ((p, "penetrator"), (m, "material"), (e, "energizing"))]
    design = design_from_sets(*sets)
    scalar = simulate(design, output_rate_hz=100.0).summary
    got = simulate_batch(design_arrays(design))
    assert scalar.end == got.end[0] == "creep"
    for key in ("penetration_time_s", "final_depth_mm", "peak_resistance_n"):
        assert got.figures[key][0] == pytest.approx(getattr(scalar, key), rel=1e-4), key
    if case != "creep_170s":  # the oracle's own time limit is shorter
        want = reference_run(p, m, e)
        assert want["end"] == "creep"
        assert got.figures["penetration_time_s"][0] == pytest.approx(want["penetration_time_s"], rel=1e-4)


def test_a_blade_that_takes_hours_to_reach_full_depth_gets_there_in_both_simulators():
    """A heavily damped blade (C = 10⁷ kPa·s/m) pushed by its weight alone past a weak block reaches full depth
    after 6,583 s.  pen predict used to stop at 3,600 s of simulated time and call the run ``stalled`` at 114 mm,
    exiting 0, while the batch reached full depth: a stall is not a result, and the two paths agree."""
    from pencli import api
    from pencli.predict.batch import design_arrays, simulate_batch

    overrides = ["tip_angle_deg=90", "penetration_depth_mm=120", "sprung_mass_kg=20",
                 "microstructure_strength_kpa=20", "coefficients.damping_kpa_s_m=10000000"]
    predicted = api.predict("appendix_c", "grill_brick", "appendix_c", overrides=overrides, allow_out_of_range=True,
                            output_rate_hz=1.0)
    scalar = predicted.result.summary
    batch = simulate_batch(design_arrays(predicted.result.design))
    assert scalar.end == batch.end[0] == "full_depth"
    assert scalar.penetration_time_s > 3600.0
    assert batch.figures["penetration_time_s"][0] == pytest.approx(scalar.penetration_time_s, rel=1e-6)
    assert scalar.final_depth_mm == pytest.approx(120.0, abs=1e-9)
    assert abs(scalar.energy_balance_error_j) < 1e-6 * scalar.spring_energy_j


def test_a_creep_states_its_convention_and_the_time_constant_that_moves_it():
    """A creep's penetration time is a convention (to within 1 µm of the rest depth); the result says so and
    gives the slow mode's time constant τ, so that a reader knows what another convention gives: each
    tenfold-closer end adds τ·ln 10.  Checked against the independent Radau oracle run to 10 µm, 1 µm and
    0.1 µm of the rest depth (Appendix C blade, grill brick, C = 10⁴ kPa·s/m, starting at the surface)."""
    from pencli import api

    overrides = ["coefficients.damping_kpa_s_m=10000", "surface_offset_mm=0"]
    predicted = api.predict("appendix_c", "grill_brick", "appendix_c", overrides=overrides, output_rate_hz=100.0)
    summary = predicted.result.summary
    assert summary.end == "creep" and summary.creep_time_constant_s > 0
    assert "within 1 µm of the rest depth" in predicted.result.message
    p, m, e = (load_preset(name, kind).to_mapping() for name, kind in
               (("appendix_c", "penetrator"), ("grill_brick", "material"), ("appendix_c", "energizing")))
    m["coefficients"] = {**m["coefficients"], "damping_kpa_s_m": 10000.0}
    e["surface_offset_mm"] = 0.0
    times = {d: reference_run(p, m, e, creep_distance_m=d)["penetration_time_s"] for d in (1e-5, 1e-6, 1e-7)}
    assert times[1e-6] == pytest.approx(summary.penetration_time_s, rel=1e-6)
    step = summary.creep_time_constant_s * math.log(10.0)
    assert times[1e-7] - times[1e-6] == pytest.approx(step, rel=2e-3)
    assert times[1e-6] - times[1e-5] == pytest.approx(step, rel=2e-3)
    assert predicted.result.summary.to_dict()["creep_time_constant_s"] == summary.creep_time_constant_s


def test_an_arrest_damped_within_a_hair_of_critical_says_its_time_is_round_off():
    """At ζ = 0.999 at the rest depth (Appendix C blade, grill brick, stand-off 10 mm) the tip overshoots the rest
    depth by e⁻⁷⁰ of its approach: pen predict, the batch and the Radau oracle gave 0.62, 0.75 and 0.68 s.  Both
    simulators now say the time is round-off; at ζ = 0.99 (an overshoot of 2.5·10⁻¹⁰, resolved) the three agree
    within the batch's 10⁻⁴ and nothing is said, and at ζ = 1.001 the run creeps in a well-defined time."""
    from pencli import api
    from pencli.model.design import damping_ratio_at_rest
    from pencli.model.resistance import resistance_law
    from pencli.predict.batch import design_arrays, simulate_batch

    def predicted(c_kpa_s_m):
        return api.predict("appendix_c", "grill_brick", "appendix_c", output_rate_hz=100.0,
                           overrides=["surface_offset_mm=10", f"coefficients.damping_kpa_s_m={c_kpa_s_m}"]).result

    design = predicted(1000.0).design
    law = resistance_law(design)
    m = design.effective_mass_kg
    zeta_per_c = float(damping_ratio_at_rest(m, design.drive_stiffness_n_m, design.stroke_m - design.surface_offset_m,
                                             m * design.gravity_m_s2, law.strength_n, law.friction_n_m,
                                             law.damping_n_s_m, design.penetration_depth_m)) / 1000.0
    p, mat, e = (load_preset(name, kind).to_mapping() for name, kind in
                 (("appendix_c", "penetrator"), ("grill_brick", "material"), ("appendix_c", "energizing")))
    e["surface_offset_mm"] = 10.0
    for zeta, flagged, end in ((0.999, True, "arrest"), (0.99, False, "arrest"), (1.001, False, "creep")):
        c = zeta / zeta_per_c
        result = predicted(c)
        batch = simulate_batch(design_arrays(result.design))
        assert result.summary.end == batch.end[0] == end, zeta
        assert result.summary.near_critical is flagged and bool(batch.near_critical[0]) is flagged, zeta
        assert ("round-off" in result.message) is flagged, zeta
        if not flagged:
            mat["coefficients"] = {**mat["coefficients"], "damping_kpa_s_m": c}
            oracle = reference_run(p, mat, e)["penetration_time_s"]
            assert result.summary.penetration_time_s == pytest.approx(oracle, rel=1e-4), zeta
            assert batch.figures["penetration_time_s"][0] == pytest.approx(oracle, rel=1e-4), zeta
