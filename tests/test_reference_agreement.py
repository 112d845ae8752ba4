"""`pen predict --json` against an independent tight integration ."""

from __future__ import annotations

import json

import pytest
import yaml

from pencli.params.load import load_preset
from tests.conftest import invoke
from pencli.testing.reference import reference_run

CASES = [
    # (penetrator, material, energizing, speed at contact)
    ("appendix_c", "grill_brick", "appendix_c", None),
    ("appendix_c", "mpacs_c", "appendix_c", None),
    ("figure10", "figure10", "figure10", 7.155133),
    ("figure10", "figure10", "figure10", None),
    ("al6061_2mm", "mpacs_d", "springs_6", None),
    ("al6061_1mm", "mpacs_b", "springs_2", None),
]


@pytest.mark.parametrize("p,m,e,speed", CASES)
def test_predict_matches_reference(runner, p, m, e, speed):
    args = ["predict", "-p", p, "-m", m, "-e", e, "--json"]
    if speed is not None:
        args += ["--speed-at-contact", str(speed)]
    result = invoke(runner, *args)
    assert result.exit_code == 0, result.output
    got = json.loads(result.stdout)
    mappings = [load_preset(name, kind).to_mapping() for name, kind in
                ((p, "penetrator"), (m, "material"), (e, "energizing"))]
    want = reference_run(*mappings, speed_at_contact=speed)
    assert got["full_penetration"] == want["full_penetration"]
    for key in ("contact_speed_m_s", "penetration_time_s", "final_depth_mm", "peak_resistance_n"):
        assert got[key] == pytest.approx(want[key], rel=1e-4), key


def test_figure10_preset_reproduces_the_papers_speed_at_contact(runner):
    """The bundled figure10 launcher gives BAM's 7.155133 m/s (REFERENCE.md) to 1e-6."""
    result = invoke(runner, "predict", "-p", "figure10", "-m", "figure10", "-e", "figure10", "--json")
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["contact_speed_m_s"] == pytest.approx(7.155133, rel=1e-6)


def test_reference_reads_the_contract_example_files(runner):
    """The contract's own example files run through pen and the oracle alike."""
    from tests.conftest import SPEC

    ex = SPEC / "examples"
    result = invoke(runner, "predict", "-p", ex / "blade_1mm.yaml", "-m", ex / "mpacs_c.yaml",
                    "-e", ex / "springs_4.yaml", "--json")
    assert result.exit_code == 0, result.output
    got = json.loads(result.stdout)
    files = [yaml.safe_load((ex / f).read_text()) for f in ("blade_1mm.yaml", "mpacs_c.yaml", "springs_4.yaml")]
    want = reference_run(*files)
    for key in ("contact_speed_m_s", "penetration_time_s", "final_depth_mm", "peak_resistance_n"):
        assert got[key] == pytest.approx(want[key], rel=1e-4), key
