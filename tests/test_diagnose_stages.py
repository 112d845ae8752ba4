"""The diagnosis as named stages: each stage on its own, and the engine's shape (short functions, named
thresholds, no effect named in the engine)."""

from __future__ import annotations

import ast
import inspect
from pathlib import Path

import numpy as np
import pytest

from pencli import api
from pencli.diagnose import engine
from pencli.diagnose.effects import EFFECTS, views
from pencli.errors import FitError
from tests.conftest import REPO

EXAMPLE = REPO / "examples" / "workspace" / "runs.duckdb"
DIAGNOSE = REPO / "pencli" / "diagnose"
ALLOWED_LITERALS = {0, 1, -1, 2}
"""Numbers that are no threshold: zero, one, a sign, a square."""


@pytest.fixture(scope="module")
def runs():
    return views(api.load_campaign(EXAMPLE, ["gb-*"]))


def test_the_request_is_checked_before_any_work(runs):
    with pytest.raises(FitError, match="at least 3 runs"):
        engine.check_request(runs[:2], None, 0.01, 200, 0, 1)
    with pytest.raises(FitError, match="between 0 and 0.5"):
        engine.check_request(runs, None, 0.7, 200, 0, 1)
    with pytest.raises(FitError, match="at least 20"):
        engine.check_request(runs, None, 0.01, 10, 0, 1)
    with pytest.raises(FitError, match="unknown effect 'gremlins'"):
        engine.check_request(runs, ["gremlins"], 0.01, 200, 0, 1)
    with pytest.raises(FitError, match=r"--suggest 4: expected 0 to 3 runs"):
        engine.check_request(runs, None, 0.01, 200, 0, 1, 4)
    request = engine.check_request(runs, None, 0.03, 200, 0, 1)
    assert request.alpha == pytest.approx(0.01)
    assert EFFECTS[request.drive_effect].side == "drive" and EFFECTS[request.rest_effect].rest_evidence
    only = engine.check_request(runs, ["strength_layer"], 0.03, 200, 0, 1)
    assert only.drive_effect is None and only.rest_effect is None


def test_runs_of_two_materials_are_refused_in_one_line_before_any_work(tmp_path, runner):
    """The baseline shares P, C and K among the runs: the example's grill brick and MPACS C runs diagnosed
    together read the other material as an effect ('plug_growth with velocity_friction')."""
    import shutil

    from tests.conftest import invoke

    with pytest.raises(FitError, match=r"2 materials: grill_brick \(6 runs\), mpacs_c \(6 runs\)"):
        engine.check_materials(api.load_campaign(EXAMPLE, ["all"]))
    engine.check_materials(api.load_campaign(EXAMPLE, ["mc-*"]))  # one material: nothing to say
    shutil.copytree(EXAMPLE.parent, tmp_path / "ws")
    r = invoke(runner, "diagnose", "all", "--db", tmp_path / "ws" / "runs.duckdb")
    assert r.exit_code == 1 and "diagnose one material's runs at a time" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.output


def test_the_baseline_stage_recovers_the_materials_coefficients(runs):
    """Grill Brick's runs were made with Table 1's coefficients (Cs 0.6 … per block, P 31.6 kPa… as the preset
    holds them); the baseline fit on the measured data must come back close, one strength factor per run."""
    from pencli.params.load import load_preset

    truth = load_preset("grill_brick", "material").values
    baseline = engine.fit_baseline(runs)
    assert len(baseline.strength_factors) == len(runs)
    assert baseline.values["strength_factor"] == pytest.approx(truth["coefficients.strength_factor"], rel=0.03)
    assert baseline.values["sidewall_pressure_kpa"] == pytest.approx(truth["coefficients.sidewall_pressure_kpa"],
                                                                    rel=0.05)
    assert baseline.values["inertia_coefficient"] == pytest.approx(truth["coefficients.inertia_coefficient"],
                                                                  rel=0.05)
    assert all(u.dtype == bool and u.any() for u in baseline.uses)
    assert baseline.run_values(0)["strength_factor"] == float(baseline.strength_factors[0])


def test_the_drive_stage_reads_no_gap_on_a_launcher_that_matches_its_file(runs):
    request = engine.check_request(runs, None, 0.3, 20, 0, 1)  # a rate 20 replicates can see
    baseline = engine.fit_baseline(runs)
    calibration = engine.calibrate_nulls(baseline, request)
    assert len(calibration.replicates) == len(runs)
    drive = engine.read_drive(baseline, calibration, request)
    assert not drive.gap and drive.t < drive.threshold
    assert np.all(np.abs(drive.ratios) < 0.01)  # contact speeds within 1 % of the launcher's prediction


def _phase_z(tmp_path, effects, names):
    """The flight split's (z, bar) of each named effect's best member, on the simulated rig's six shots with
    ``effects`` (100 replicates)."""
    from tests.test_diagnose import campaign

    runs = views(api.load_campaign(campaign(tmp_path, effects, 4500), ["all"]))
    request = engine.check_request(runs, None, 0.01, 100, 0, 1)
    baseline = engine.fit_baseline(runs)
    scan = engine.scan_families(baseline, engine.calibrate_nulls(baseline, request), request)
    out = {}
    for name in names:
        z, bar = engine.flight_split_test(scan, baseline, scan.candidates[name][scan.tested[name].family.best].spec,
                                          request.alpha)
        out[name] = None if z is None else (z, bar)
    return out


@pytest.mark.slow
def test_a_wrong_load_cell_mass_is_one_size_in_flight_and_in_the_material(tmp_path):
    """A wrong load-cell mass (× 1.5) reads the launch's acceleration as it reads the penetration's: its own
    member fitted apart in flight takes no more than on the replicates; a load cell whose gain rises with the
    force (0.25 per kN, outside the catalogue) reads the penetration's kilonewtons with a 'mass' the launch's tens
    of newtons do not show.  A drift, whose shape is one of a family, is not split."""
    mass = _phase_z(tmp_path / "mass", [{"name": "load_cell_mass_error", "ratio": 1.5}],
                    ("load_cell_mass_error", "force_drift"))
    assert mass["load_cell_mass_error"][0] < mass["load_cell_mass_error"][1], mass
    assert mass["force_drift"] is None, mass
    gauge = _phase_z(tmp_path / "gauge", [{"name": "gauge_nonlinearity", "gain_per_kn": 0.25}],
                     ("load_cell_mass_error",))
    assert gauge["load_cell_mass_error"][0] > gauge["load_cell_mass_error"][1], gauge


# ---------------------------------------------------------------------------- the engine's shape
def _functions(path: Path):
    tree = ast.parse(path.read_text())
    return [n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))]


def test_diagnose_is_a_short_pipeline_and_no_function_of_the_diagnosis_is_long():
    lines = inspect.getsource(engine.diagnose).count("\n")
    assert lines <= 60, lines
    long = [(p.name, f.name, f.end_lineno - f.lineno + 1) for p in sorted(DIAGNOSE.glob("*.py"))
            for f in _functions(p) if f.end_lineno - f.lineno + 1 > 80]
    assert not long, long


def test_every_threshold_in_a_comparison_is_a_named_constant():
    """A bare number in a comparison is a threshold without a reason; each has a module constant with one."""
    bare = []
    for path in sorted(DIAGNOSE.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Compare):
                for side in (node.left, *node.comparators):
                    for leaf in ast.walk(side):
                        if (isinstance(leaf, ast.Constant) and isinstance(leaf.value, (int, float))
                                and not isinstance(leaf.value, bool) and leaf.value not in ALLOWED_LITERALS):
                            bare.append(f"{path.name}:{node.lineno}: {leaf.value!r}")
    assert not bare, bare


def test_module_constants_carry_a_reason():
    """Every upper-case constant of the engine is followed by its docstring (a reason in physical terms)."""
    tree = ast.parse((DIAGNOSE / "engine.py").read_text())
    body = tree.body
    missing = []
    for k, node in enumerate(body):
        if isinstance(node, ast.Assign) and all(isinstance(t, ast.Name) and t.id.isupper() for t in node.targets):
            following = body[k + 1] if k + 1 < len(body) else None
            documented = (isinstance(following, ast.Expr) and isinstance(following.value, ast.Constant)
                          and isinstance(following.value.value, str))
            name = node.targets[0].id
            if not documented and name not in ("MS_PER_S", "MM_PER_M", "UM_PER_M", "PERCENT"):  # unit factors
                missing.append(name)
    assert not missing, missing


def test_the_engine_names_no_catalogue_effect():
    """What an effect needs (the drive view, the rest's evidence) it declares in its registry entry."""
    strings = {n.value for n in ast.walk(ast.parse((DIAGNOSE / "engine.py").read_text()))
               if isinstance(n, ast.Constant) and isinstance(n.value, str)}
    assert not strings & set(EFFECTS), strings & set(EFFECTS)


def test_a_scan_that_fails_while_the_replicates_are_made_leaves_no_process_behind(runs, monkeypatch):
    """The replicates are made by a pool of processes while the main process builds the columns; a failure there
    must shut the pool down (no worker left running) and reach the caller as it was raised."""
    import multiprocessing

    def broken(*args, **kwargs):
        raise RuntimeError("a failure while the replicates are made")

    monkeypatch.setattr(engine, "_fold_reach", broken)
    before = set(multiprocessing.active_children())
    with pytest.raises(RuntimeError, match="while the replicates are made"):
        engine.diagnose(api.load_campaign(EXAMPLE, ["gb-*"]), bootstrap=60, workers=2)
    assert set(multiprocessing.active_children()) <= before


def test_one_process_or_two_give_the_same_report_to_the_last_digit():
    """``workers`` (``--workers``, ``PEN_WORKERS``) changes where the replicates are made and how many threads the
    compiled solves use, never a number of the report."""
    campaign = api.load_campaign(EXAMPLE, ["gb-*"])[:3]
    one, two = (engine.diagnose(campaign, effects=["strength_layer", "velocity_friction"], bootstrap=60,
                                workers=w).to_dict() for w in (1, 2))
    for report in (one, two):
        report["decision"].pop("seconds")  # the time it took
    assert one == two


def test_an_effect_is_described_by_its_best_member_whose_description_is_physically_possible():
    """A layer whose fitted strength is negative is no layer: the family is described by the best-fitting member
    whose layer the material can hold, the best of all only when no member is admissible."""
    layer = EFFECTS["strength_layer"]
    weaker = next(m for m in layer.members if m.params.get("band") == "weaker")
    stronger = next(m for m in layer.members if m.params.get("band") == "stronger")
    context = {"cs_mean": 2.0}
    # a weaker band whose top edge takes 3 of the mean strength factor 2: strength at 1 − 3/2 < 0
    assert not layer.admissible(layer.describe(weaker, np.array([3.0, 3.0]), context))
    assert layer.admissible(layer.describe(weaker, np.array([1.0, 1.0]), context))
    assert layer.admissible(layer.describe(stronger, np.array([3.0, 3.0]), context))
    members = [weaker, stronger, weaker]
    fits = {0: np.array([3.0, 3.0]), 1: np.array([3.0, 3.0]), 2: np.array([1.0, 1.0])}

    def admissible(i, fit):
        return layer.admissible(layer.describe(members[i], fit["coefficients"], context))

    total = np.array([1.0, 3.0, 2.0])  # member 0 fits best but is impossible; member 2 next
    coefficients = {i: fits[i] for i in fits}
    strength = {i: np.ones(6) for i in fits}
    assert engine._best_admissible(total, coefficients, strength, admissible) == 2
    assert engine._best_admissible(total, coefficients, strength, None) == 0
    assert engine._best_admissible(total, coefficients, strength, lambda i, fit: False) == 0


def test_a_plateau_names_the_edge_across_which_the_strength_changes_most():
    """A weaker band that barely differs from the material above and a large rise at its bottom is a step at the
    bottom edge: the description says so (the ratio across it: the strength below over the band's); a band
    whose top edge changes most names its top, and so does one whose larger bottom change is the less certain."""
    layer = EFFECTS["strength_layer"]
    weaker = next(m for m in layer.members if m.params.get("band") == "weaker")
    stronger = next(m for m in layer.members if m.params.get("band") == "stronger")
    context = {"cs_mean": 2.0}
    step_below = layer.describe(weaker, np.array([0.02, 1.8]), context)  # band ×0.99, then +0.9 of Cs below it
    assert step_below["main_edge_mm"] == weaker.params["bottom_mm"]
    assert step_below["main_edge_ratio"] == pytest.approx((1 - 0.01 + 0.9) / (1 - 0.01))
    band = layer.describe(stronger, np.array([1.0, 0.2]), context)  # ×1.5 band, most of it kept below
    assert band["main_edge_mm"] == stronger.params["depth_mm"]
    assert band["main_edge_ratio"] == pytest.approx(1.5)
    # a larger change at the bottom that the null replicates scatter widely (the runs' last millimetres see it)
    # is less certain than the top's: the top is the main edge
    uncertain = layer.describe(weaker, np.array([0.8, 2.0]), {**context, "coefficient_spread": np.array([0.1, 3.0])})
    assert uncertain["main_edge_mm"] == weaker.params["depth_mm"]
    assert uncertain["main_edge_ratio"] == pytest.approx(0.6)
    step = layer.describe(next(m for m in layer.members if m.params["shape"] != "plateau"), np.array([1.0]), context)
    assert "main_edge_mm" not in step
