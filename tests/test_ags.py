"""AGS4 CPT files (read through python-ags4) on the committed Hollandse Kust Zuid tests: every reading against a
plain CSV parse of the file's text written here, pen's qt against the contractor's corrected cone resistance,
units converted from what the file's UNIT row states, broken copies, and the show and plot commands."""

from __future__ import annotations

import csv
import gzip
import hashlib
import io
import json
import re

import numpy as np
import pytest

from pencli import api
from pencli.errors import DataError
from pencli.sensors.cone_tip import qt_kpa
from pencli.io.ags import read_ags
from tests.conftest import REPO, invoke

FIELD = REPO / "examples" / "field" / "ags"
FILES = sorted(FIELD.glob("*.ags.gz"))


def scpt_rows(text: str) -> tuple[list[str], list[str], list[list[str]]]:
    """The SCPT group of an AGS4 text, parsed as the CSV it is: (headings, units, data rows)."""
    headings, units, rows, inside = [], [], [], False
    for row in csv.reader(io.StringIO(text)):
        if not row:
            continue
        if row[0] == "GROUP":
            inside = row[1] == "SCPT"
        elif inside and row[0] == "HEADING":
            headings = row
        elif inside and row[0] == "UNIT":
            units = row
        elif inside and row[0] == "DATA":
            rows.append(row)
    return headings, units, rows


def test_the_committed_files_are_the_originals_listed_with_their_licence():
    listed = dict(re.findall(r"^\| (\S+\.ags) \| ([0-9a-f]{64}) \|$", (FIELD / "README.md").read_text(), re.MULTILINE))
    assert sorted(listed) == sorted(p.name.removesuffix(".gz") for p in FILES) and len(FILES) == 4
    for path in FILES:  # the original's sha256, as published beside the data
        assert hashlib.sha256(gzip.decompress(path.read_bytes())).hexdigest() == listed[path.name.removesuffix(".gz")]
    assert "CC0 1.0 Universal" in (FIELD / "LICENSE").read_text()


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name[22:32])
def test_every_reading_is_the_files_own_in_pens_units(path):
    """Depth [m], qc [MN/m² = MPa], fs and u₂ [kN/m² = kPa] as the text's CSV rows give them, row by row."""
    headings, units, rows = scpt_rows(gzip.decompress(path.read_bytes()).decode())
    assert [units[headings.index(h)] for h in ("SCPT_DPTH", "SCPT_RES", "SCPT_FRES", "SCPT_PWP2")] == [
        "m", "MN/m2", "kN/m2", "kN/m2"]
    (sounding,) = read_ags(path)
    assert sounding.kind == "cptu" and len(rows) == sounding.columns["depth_m"].size > 2400
    for heading, column in (("SCPT_DPTH", "depth_m"), ("SCPT_RES", "qc_mpa"), ("SCPT_FRES", "fs_kpa"),
                            ("SCPT_PWP2", "u2_kpa")):
        expected = np.array([float(r[headings.index(heading)] or "nan") for r in rows])
        np.testing.assert_array_equal(sounding.columns[column], expected, err_msg=heading)
    assert sounding.header_number("push_rate_mm_s") == 20.0 and sounding.header_number("cone_area_cm2") == 15.0


def test_qt_is_the_contractors_corrected_cone_resistance():
    """pen's qt = qc + (1 − a)·u₂ with the file's net area ratio (0.58) against the contractor's SCPT_QT: the
    area ratio the file's own columns imply (least squares of qt − qc on u₂) is 0.58 to 0.001, and the median
    row differs by less than qc's written digit (0.001 MPa), nine rows in ten by less than 0.01 MPa.  (The
    rest, up to 0.3 MPa where u₂ jumps, are rows where the contractor's qt was not made from the 2 cm values
    as written: averaged otherwise, it cannot be recomputed from them.)"""
    for path in FILES:
        (sounding,) = read_ags(path)
        c = sounding.columns
        assert sounding.header_number("MA") == pytest.approx(0.58)
        qt = qt_kpa(c["qc_mpa"], c["u2_kpa"], sounding.header_number("MA")) / 1e3
        both = np.isfinite(qt) & np.isfinite(c["qt_file_mpa"])
        assert both.sum() > 2400
        u2_mpa, excess = c["u2_kpa"][both] / 1e3, c["qt_file_mpa"][both] - c["qc_mpa"][both]
        assert 1.0 - np.sum(u2_mpa * excess) / np.sum(u2_mpa * u2_mpa) == pytest.approx(0.58, abs=0.001)
        difference = np.abs(qt[both] - c["qt_file_mpa"][both])
        assert np.median(difference) <= 0.001 and np.quantile(difference, 0.9) <= 0.01


def test_a_unit_is_converted_from_what_the_file_states(tmp_path):
    """The same file with qc stated in kN/m² (values × 1000) and depth in cm (× 100) reads the same."""
    text = gzip.decompress(FILES[0].read_bytes()).decode()
    headings, units, rows = scpt_rows(text)
    out, inside = [], False
    for line, row in zip(text.splitlines(), csv.reader(io.StringIO(text))):
        if row and row[0] == "GROUP":
            inside = row[1] == "SCPT"
        if inside and row and row[0] in ("UNIT", "DATA"):
            q, d = headings.index("SCPT_RES"), headings.index("SCPT_DPTH")
            if row[0] == "UNIT":
                row[q], row[d] = "kN/m2", "cm"
            else:
                row[q] = f"{float(row[q]) * 1000:.0f}" if row[q] else ""
                row[d] = f"{float(row[d]) * 100:.0f}"
            line = ",".join(f'"{v}"' for v in row)
        out.append(line)
    changed = tmp_path / "kn.ags"
    changed.write_text("\r\n".join(out) + "\r\n")
    (before,), (after,) = read_ags(FILES[0]), read_ags(changed)
    for column in ("qc_mpa", "depth_m"):
        np.testing.assert_allclose(after.columns[column], before.columns[column], rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("case, said", [
    ("missing", "no such file"), ("garbage", "no SCPT group"), ("unit", "'kPa/m'"), ("binary", "AGS4")])
def test_a_broken_ags_file_is_one_line_naming_the_file(tmp_path, case, said):
    path = tmp_path / "broken.ags"
    text = gzip.decompress(FILES[0].read_bytes()).decode()
    if case == "garbage":
        path.write_text('"GROUP","PROJ"\n"HEADING","PROJ_ID"\n"UNIT",""\n"TYPE","ID"\n"DATA","X"\n')
    elif case == "unit":
        path.write_text(text.replace('"UNIT","","","m","MN/m2"', '"UNIT","","","m","kPa/m"', 1))
    elif case == "binary":
        path.write_bytes(b"\x00\xff" * 64)
    with pytest.raises(DataError) as error:
        read_ags(path)
    message = str(error.value)
    assert "\n" not in message and str(path) in message and said in message, message


def test_show_and_plot_read_the_files(tmp_path, runner):
    result = invoke(runner, "soundings", "show", *map(str, FILES), "--json")
    assert result.exit_code == 0, result.output
    shown = json.loads(result.stdout)
    assert [s["name"] for s in shown] == [f"HKZ1-CPT0{i}.000" for i in range(1, 5)]
    assert all(s["kind"] == "cptu" and s["logger_rate_mm_s"] == 20.0 and s["bottom_m"] > 49 for s in shown)
    figure = tmp_path / "cpt.png"
    result = invoke(runner, "soundings", "plot", str(FILES[0]), "--out", str(figure))
    assert result.exit_code == 0 and figure.stat().st_size > 10_000
    assert api.read_soundings([FILES[1]])[0].name == "HKZ1-CPT02.000"
