"""The SGF reader on real piezocone soundings (the NTNU rate study's, committed with their licence) and on broken
copies of them; the push rate read from depth and time against the logger's own rate column."""

from __future__ import annotations

import gzip
import hashlib
import re
from pathlib import Path

import numpy as np
import pytest

from pencli.errors import DataError
from pencli.filter.rate import push_rate_mm_s
from pencli.io.sgf import read_sgf
from tests.conftest import REPO

FIELD = REPO / "examples" / "field" / "ntnu-cptu-rate"
PREDRILL_M = {"TILC": 4.0, "OYSC": 8.0, "HALS": 3.0}
"""Predrilled depths the data set's authors give per site (the README beside the files). [m]"""


def listed() -> dict[str, tuple[float, str]]:
    """sounding → (nominal rate [mm/s], sha256 of the uncompressed file), from the table of the attribution README."""
    rows = re.findall(r"^\| `(\w+)\.cpt` \| [^|]+ \| ([0-9.]+)[^|]* \| `([0-9a-f]{64})` \|$",
                      (FIELD / "README.md").read_text(), re.MULTILINE)
    return {name: (float(rate), digest) for name, rate, digest in rows}


def path_of(name: str) -> Path:
    return FIELD / "soundings" / f"{name}.cpt.gz"


def test_the_committed_soundings_are_the_ones_listed_with_their_licence():
    files = listed()
    assert len(files) == 64 and sorted(f"{n}.cpt.gz" for n in files) == sorted(p.name for p in (FIELD / "soundings").iterdir())
    for name, (_, digest) in files.items():  # the sha256 content digest of each file as published, as listed
        assert hashlib.sha256(gzip.decompress(path_of(name).read_bytes())).hexdigest() == digest, name
    assert "MIT License" in (FIELD / "LICENSE").read_text() and "10.5281/zenodo.14838136" in (FIELD / "README.md").read_text()


@pytest.mark.parametrize("name", sorted(listed()))
def test_a_real_sounding_reads_whole(name):
    """Each file: one piezocone sounding named by its number (some Øysand names begin with an ø in cp1252), rows from
    the predrilled depth on in 2 cm steps, every row with qc, fs and u₂, the net area ratio from the header (a
    decimal comma in the Halsen files), and a clock."""
    (sounding,) = read_sgf(path_of(name))
    stem = name
    assert sounding.kind == "cptu"
    number = re.match(r"\d+", stem[4:]).group(0).lstrip("0")
    assert re.search(r"\d+", sounding.name).group(0).lstrip("0") == number  # '57', 'ø19', '#1', '64.a'
    assert sounding.name.startswith(("Ø", "ø")) or not stem.startswith("OYS") or sounding.name[0].isdigit()
    depth = sounding.columns["depth_m"]
    # from the predrilled depth: the header's HO, and the site's (one Øysand sounding resumes at 15 m)
    assert depth[0] == pytest.approx(sounding.header_number("HO"), abs=0.011)
    assert depth[0] == pytest.approx(PREDRILL_M[stem[:4]]) or stem == "OYSC64_2"
    assert 12.0 < depth[-1] < 24.0 and np.all(np.diff(depth) >= 0)
    assert np.median(np.diff(depth)) == pytest.approx(0.02 if stem[:4] != "HALS" else 0.01, abs=1e-9)
    for column in ("qc_mpa", "fs_kpa", "u2_kpa", "rate_mm_s"):
        assert np.isfinite(sounding.columns[column]).mean() > 0.99, column
    assert 0.0 < np.nanmedian(sounding.columns["qc_mpa"]) < 30.0  # MPa, not kPa
    assert 0.8 < sounding.header_number("MA") < 0.9
    # the clock as written: a logger glitch sets it back on a row to three in some files (Øysand's 54 at 18.14 m,
    # with a negative qc on the next row); the reader keeps rows as they are
    assert sounding.time_s is not None and np.sum(np.diff(sounding.time_s) < 0) <= 3
    assert sounding.row_events  # rows that carry event codes


@pytest.mark.parametrize("name", sorted(listed()))
def test_the_rate_from_depth_and_time_is_the_loggers_and_the_nominal(name):
    """The rate read from the clock and the depths (its own column) against the logger's rate column B and the
    authors' nominal rate: within 6 % (or 1 mm/s, B's resolution) of the median B, within 25 % of the nominal."""
    (sounding,) = read_sgf(path_of(name))
    nominal = listed()[name][0]
    rate = push_rate_mm_s(sounding.columns["depth_m"], sounding.time_s)
    moving = sounding.columns["rate_mm_s"][sounding.columns["rate_mm_s"] > 0]
    assert rate == pytest.approx(float(np.median(moving)), rel=0.06, abs=1.0)
    assert rate == pytest.approx(nominal, rel=0.25)


def test_push_rate_leaves_out_the_pauses_and_reads_through_bursts():
    """A push at 20 mm/s with a 60 s stop every metre, its rows stamped in bursts of 1 to 8 (the time of the burst's
    last row): the stops would pull depth over time to 10.2 mm/s, and the bursts make step rates 0 or 8 × 20."""
    depth = np.arange(0.0, 5.0, 0.02)
    time = depth / 0.020 + 60.0 * np.floor(depth + 1e-9)
    for burst in (1, 3, 4, 8):
        stamped = time[np.minimum((np.arange(depth.size) // burst) * burst + burst - 1, depth.size - 1)]
        assert push_rate_mm_s(depth, stamped) == pytest.approx(20.0, rel=0.01), burst
    assert 1e3 * (depth[-1] - depth[0]) / (time[-1] - time[0]) < 11.0
    assert np.isnan(push_rate_mm_s(depth[:4], time[:4]))  # too few rows for a rate


BROKEN = {
    "not SGF": (lambda text: "time,depth\n0,1\n", "line 1: expected '$'"),
    "empty": (lambda text: "", "empty file"),
    "no rows": (lambda text: text.split("\n#\n")[0] + "\n#\n", "no data rows"),
    "no '#' line": (lambda text: text.split("\n#\n")[0] + "\n", "no '#' line"),
    "a word for qc": (lambda text: text.replace("QC=", "QC=abc", 1), "field QC is 'abc"),
    "a field without '='": (lambda text: text.replace(",FS=", ",FS", 1), "is not KEY=value"),
    "a row without depth": (lambda text: re.sub(r"\nD=[0-9.]+,", "\n", text, count=1), "without a depth"),
    "depth back up": (lambda text: re.sub(r"\nD=([0-9.]+),(QC=[^\n]*)\nD=[0-9.]+,", r"\nD=\1,\2\nD=1.000,", text,
                                          count=1), "go back up"),
    "a bad clock": (lambda text: re.sub(r",%(\d+)", r",%12x4", text, count=1), "field % is '12x4'"),
    "a field twice": (lambda text: text.replace(",FS=", ",QC=1,FS=", 1), "given twice"),
}


@pytest.mark.parametrize("case", sorted(BROKEN))
def test_a_broken_copy_is_one_line_naming_file_and_line(tmp_path, case):
    edit, expected = BROKEN[case]
    text = gzip.decompress(path_of("TILC57").read_bytes()).decode("cp1252").replace("\r\n", "\n")
    broken = edit(text)
    assert broken != text or case == "empty"
    path = tmp_path / "TILC57.cpt"
    path.write_bytes(broken.encode("cp1252"))
    with pytest.raises(DataError) as caught:
        read_sgf(path)
    message = str(caught.value)
    assert message.startswith(str(path)) and expected in message and "\n" not in message, message
    if case not in ("empty", "no rows", "no '#' line"):
        assert re.search(r": line \d+: ", message), message
    assert sorted(p.name for p in tmp_path.iterdir()) == ["TILC57.cpt"]  # nothing written beside it
