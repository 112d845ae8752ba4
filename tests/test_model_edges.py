"""Edge classes of the CONTRACT §2 model found by the outside check (issue 12), against the independent oracle."""

from __future__ import annotations

import json

import pytest

from pencli.params.load import load_preset
from tests.conftest import invoke
from tests.reference import reference_run


def _mappings(p, m, e, **energizing):
    maps = [load_preset(name, kind).to_mapping() for name, kind in
            ((p, "penetrator"), (m, "material"), (e, "energizing"))]
    maps[2].update(energizing)
    return maps


def test_full_depth_just_short_of_the_arrest_point_is_full_depth(runner):
    """Issue 12 defect 1: a depth limit just short of where the blade would arrest; the tip passed the stops and
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
