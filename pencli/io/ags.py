"""Reader of AGS4 CPT files (the Association of Geotechnical and Geoenvironmental Specialists' format), through
python-ags4.

python-ags4 (LGPL, a dependency) parses the file's groups; pen takes one sounding per test of its ``SCPT``
group (cone penetration readings, keyed by ``LOCA_ID`` and ``SCPG_TESN``) with the test's ``SCPG`` row
(the cone: its area, net area ratio ``SCPG_CAR``, nominal push rate).  Columns are given pen's names and
units (:class:`pencli.io.sgf.Sounding`): depth in m, qc in MPa, fs and u in kPa, converted from the unit the
file's ``UNIT`` row states; the corrected cone resistance the file carries as ``qt_file_mpa``; any other
numeric column as ``ags_<heading in lower case>``.  The net area ratio is kept under SGF's header key ``MA``,
so ``qt = qc + (1 − a)·u₂`` is computed as for SGF and GEF.  AGS4 CPT data carry no clock: the push rate is
the test's nominal one (``push_rate_mm_s`` in the header).  Plain or gzipped (``.ags.gz``).
"""

from __future__ import annotations

import gzip
import io
from pathlib import Path

import numpy as np

from pencli.errors import DataError
from pencli.io.sgf import Sounding

COLUMNS: dict[str, tuple[str, str]] = {
    "SCPT_DPTH": ("depth_m", "m"),
    "SCPT_RES": ("qc_mpa", "MPa"),
    "SCPT_FRES": ("fs_kpa", "kPa"),
    "SCPT_PWP1": ("u1_kpa", "kPa"),
    "SCPT_PWP2": ("u2_kpa", "kPa"),
    "SCPT_PWP3": ("u3_kpa", "kPa"),
    "SCPT_QT": ("qt_file_mpa", "MPa"),
    "SCPT_FRR": ("friction_ratio_pct", "%"),
}
"""AGS4 heading → (pen's column, pen's unit)."""

UNITS: dict[str, dict[str, float]] = {
    "m": {"m": 1.0, "mm": 1e-3, "cm": 1e-2},
    "MPa": {"MPa": 1.0, "MN/m2": 1.0, "kPa": 1e-3, "kN/m2": 1e-3},
    "kPa": {"kPa": 1.0, "kN/m2": 1.0, "MPa": 1e3, "MN/m2": 1e3},
    "%": {"%": 1.0},
}
"""pen's unit → {a unit an AGS4 file may state: the factor to pen's}."""

KEYS = ("LOCA_ID", "SCPG_TESN")
"""The headings that say which test a reading belongs to."""


def read_ags(path: str | Path) -> list[Sounding]:
    """The CPTs of an AGS4 file, one per test (``method`` ``"ags"``; kind ``cptu`` where it has u₂, else
    ``cpt``), in the file's order.  Raises :class:`DataError` naming the file and what is wrong (not AGS4, no
    CPT readings, a unit pen does not convert)."""
    from python_ags4 import AGS4

    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: no such file")
    try:
        raw = path.read_bytes()
        text = (gzip.decompress(raw) if raw[:2] == b"\x1f\x8b" else raw).decode("utf-8-sig")
        tables, _ = AGS4.AGS4_to_dataframe(io.StringIO(text))
    except (OSError, UnicodeDecodeError, EOFError) as error:
        raise DataError(f"{path}: cannot be read as AGS4 text ({error})") from None
    except Exception as error:  # python-ags4 raises several kinds for a file it cannot parse
        reason = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
        raise DataError(f"{path}: not a readable AGS4 file ({reason})") from None
    if "SCPT" not in tables:
        raise DataError(f"{path}: no SCPT group (cone penetration readings); groups: {', '.join(tables) or 'none'}")
    readings = tables["SCPT"]
    units = dict(zip(readings.columns, readings[readings["HEADING"] == "UNIT"].iloc[0])) if (
        readings["HEADING"] == "UNIT").any() else {}
    data = readings[readings["HEADING"] == "DATA"]
    tests = tables.get("SCPG")
    tests = tests[tests["HEADING"] == "DATA"] if tests is not None else None
    if data.empty:
        raise DataError(f"{path}: its SCPT group has no DATA rows")
    keys = [k for k in KEYS if k in data.columns]
    if KEYS[0] not in keys:
        raise DataError(f"{path}: its SCPT group has no {KEYS[0]} heading (which location each reading is of)")
    groups = [((key if isinstance(key, tuple) else (key,)), rows) for key, rows in data.groupby(keys, sort=False)]
    locations = [key[0] for key, _ in groups]
    out = []
    for key, rows in groups:
        test = None
        if tests is not None and all(k in tests.columns for k in KEYS):
            match = tests[(tests["LOCA_ID"] == key[0]) & (tests["SCPG_TESN"] == key[-1])]
            test = match.iloc[0] if not match.empty else None
        name = str(key[0]) if locations.count(key[0]) == 1 else f"{key[0]}#{key[-1]}"  # tests of a location
        out.append(_sounding(path, name, str(key[0]), rows, units, test))
    return out


def _sounding(path: Path, name: str, location: str, rows, units: dict, test) -> Sounding:
    columns: dict[str, np.ndarray] = {}
    for heading in rows.columns:
        if heading in ("HEADING", *KEYS):
            continue
        values = _numbers(rows[heading])
        if values is None or np.isnan(values).all():
            continue  # text (a file set's name), or blank throughout: not a reading
        stated = str(units.get(heading, "")).strip()
        if heading in COLUMNS:
            column, unit = COLUMNS[heading]
            factor = UNITS[unit].get(stated)
            if factor is None:
                raise DataError(f"{path}: SCPT column {heading} is in {stated or 'no unit'!r}; pen reads it in "
                                f"{', '.join(UNITS[unit])}")
            columns[column] = values * factor
        else:
            columns[f"ags_{heading.lower()}"] = values
    if "depth_m" not in columns:
        raise DataError(f"{path}: its SCPT group has no depth (SCPT_DPTH)")
    header = {"test_id": name, "loca_id": location}
    if test is not None:
        for heading, field in (("SCPG_CAR", "MA"), ("SCPG_RATE", "push_rate_mm_s"), ("SCPG_CSA", "cone_area_cm2"),
                               ("SCPG_TYPE", "cone_type"), ("SCPG_REF", "cone_reference"), ("SCPG_METH", "standard")):
            value = str(test.get(heading, "") or "").strip()
            if value:
                header[field] = value
    return Sounding(name=name, method="ags", header=header, columns=columns, source=str(path))


def _numbers(column) -> np.ndarray | None:
    """A column's values as floats (blank: NaN), or None when a value is neither blank nor a number."""
    out = np.full(len(column), np.nan)
    for i, value in enumerate(column):
        text = str(value).strip()
        if not text:
            continue
        try:
            out[i] = float(text)
        except ValueError:
            return None
    return out


__all__ = ["COLUMNS", "read_ags"]
