"""GEF CPT files (read through pygef) on the committed files from pygef's tests: columns in pen's names and units,
pen's qt against the contractor's own corrected cone resistance, the push rate from the elapsed time against the
standard rate, broken copies, and the show and plot commands."""

from __future__ import annotations

import hashlib
import json
import re

import numpy as np
import pytest

from pencli import api
from pencli.errors import DataError
from pencli.filter.rate import push_rate_mm_s
from pencli.sensors.cone_tip import qt_kpa
from pencli.io.gef import read_gef
from tests.conftest import REPO, invoke

FIELD = REPO / "examples" / "field" / "gef"
STANDARD_RATE_MM_S = (15.0, 25.0)
"""The standard CPT push rate, 20 ± 5 mm/s (ISO 22476-1). [mm/s]"""


def test_the_committed_files_are_the_ones_listed_with_their_licence():
    listed = dict(re.findall(r"^\| (\S+\.gef) \| ([0-9a-f]{64}) \|$", (FIELD / "README.md").read_text(), re.MULTILINE))
    assert sorted(listed) == sorted(p.name for p in FIELD.glob("*.gef")) == ["cpt.gef", "cpt2.gef"]
    for name, digest in listed.items():  # sha256 content digests as published
        assert hashlib.sha256((FIELD / name).read_bytes()).hexdigest() == digest
    assert "MIT License" in (FIELD / "LICENSE").read_text()


def test_qt_is_the_contractors_corrected_cone_resistance():
    """cpt.gef carries qc, u₂, the net area ratio and the contractor's corrected cone resistance: pen's
    qt = qc + (1 − a)·u₂ is the file's to its last written digit (0.001 MPa) on every row."""
    sounding = read_gef(FIELD / "cpt.gef")
    assert sounding.kind == "cptu" and sounding.header_number("MA") == pytest.approx(0.8)
    c = sounding.columns
    qt = qt_kpa(c["qc_mpa"], c["u2_kpa"], sounding.header_number("MA")) / 1e3
    assert c["qc_mpa"].size == 999 and np.all(np.isfinite(qt))
    assert np.max(np.abs(qt - c["qt_file_mpa"])) <= 0.0011
    assert np.max(c["u2_kpa"]) > 100  # kPa, not MPa


def test_the_push_rate_from_the_elapsed_time_is_the_standard_rate():
    sounding = read_gef(FIELD / "cpt2.gef")
    assert sounding.kind == "cpt" and sounding.time_s is not None
    rate = push_rate_mm_s(sounding.columns["depth_m"], sounding.time_s)
    assert STANDARD_RATE_MM_S[0] <= rate <= STANDARD_RATE_MM_S[1]


@pytest.mark.parametrize("case", ["missing", "garbage", "cut"])
def test_a_broken_gef_is_one_line_naming_the_file(tmp_path, case):
    path = tmp_path / "broken.gef"
    if case == "garbage":
        path.write_text("this is not a GEF file\n")
    elif case == "cut":
        path.write_bytes((FIELD / "cpt.gef").read_bytes()[:400])
    with pytest.raises(DataError) as error:
        read_gef(path)
    message = str(error.value)
    assert message.startswith(str(path)) and "\n" not in message
    assert sorted(p.name for p in tmp_path.iterdir()) == ([] if case == "missing" else ["broken.gef"])


def test_show_and_plot_a_gef(runner, tmp_path):
    shown = invoke(runner, "soundings", "show", FIELD / "cpt.gef", FIELD / "cpt2.gef", "--json")
    assert shown.exit_code == 0, shown.output
    rows = json.loads(shown.stdout)
    assert [r["kind"] for r in rows] == ["cptu", "cpt"] and rows[0]["rate_mm_s"] is None
    out = tmp_path / "cpt.png"
    drawn = invoke(runner, "soundings", "plot", FIELD / "cpt.gef", "--out", out)
    assert drawn.exit_code == 0, drawn.output
    assert out.stat().st_size > 10_000 and "peaks at 19.0 MPa" in " ".join(drawn.stdout.split())
    assert api.read_soundings([FIELD / "cpt2.gef"])[0].name == "N04-25"
