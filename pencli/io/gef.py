"""Reader of GEF CPT files (the Dutch geotechnical exchange format), through pygef.

pygef (MIT) parses the file; pen maps its columns to the names and units
pen's soundings use (:class:`pencli.io.sgf.Sounding`): depth and
penetration length in m, qc in MPa, fs and u₂ in kPa, the elapsed time as
the clock (``clock_ms``), inclinations in degrees; a column pen does not
name is kept as ``gef_<pygef's name>``, and a corrected cone resistance the
file carries as ``qt_file_mpa``.  The cone's net area ratio (GEF
measurement variable 3) is kept under SGF's header key ``MA``, so that
``qt = qc + (1 − a)·u₂`` is computed the same way for both formats.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pencli.errors import DataError
from pencli.io.sgf import Sounding

COLUMNS: dict[str, tuple[str, float]] = {
    "penetrationLength": ("penetration_length_m", 1.0),
    "depth": ("depth_m", 1.0),
    "coneResistance": ("qc_mpa", 1.0),
    "correctedConeResistance": ("qt_file_mpa", 1.0),
    "localFriction": ("fs_kpa", 1e3),
    "porePressureU2": ("u2_kpa", 1e3),
    "porePressureU1": ("u1_kpa", 1e3),
    "porePressureU3": ("u3_kpa", 1e3),
    "elapsedTime": ("clock_ms", 1e3),
    "inclinationResultant": ("tilt_deg", 1.0),
    "inclinationNS": ("tilt_ns_deg", 1.0),
    "inclinationEW": ("tilt_ew_deg", 1.0),
    "frictionRatio": ("friction_ratio_pct", 1.0),
}
"""pygef column → (pen's column, factor from pygef's unit to pen's)."""


def read_gef(path: str | Path) -> Sounding:
    """The CPT of a GEF file (``method`` ``"gef"``; kind ``cptu`` where it has u₂, else ``cpt``).  Raises
    :class:`DataError` naming the file and pygef's reason when the file is not a readable GEF CPT."""
    import pygef

    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: no such file")
    try:
        cpt = pygef.read_cpt(path)
    except Exception as error:  # pygef raises several kinds (ValueError, KeyError, polars errors) for a bad file
        reason = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
        raise DataError(f"{path}: not a readable GEF CPT file ({reason})") from None
    columns: dict[str, np.ndarray] = {}
    for name in cpt.data.columns:
        values = cpt.data[name].cast(float, strict=False).to_numpy().astype(float)
        pen, factor = COLUMNS.get(name, (f"gef_{name}", 1.0))
        columns[pen] = values * factor
    if "depth_m" not in columns:
        if "penetration_length_m" not in columns:
            raise DataError(f"{path}: no penetration length or depth column")
        columns["depth_m"] = columns["penetration_length_m"].copy()
    header = {"test_id": str(cpt.alias or path.stem)}
    if cpt.cone_surface_quotient is not None:
        header["MA"] = str(cpt.cone_surface_quotient)
    if cpt.predrilled_depth is not None:
        header["predrilled_depth_m"] = str(cpt.predrilled_depth)
    return Sounding(name=header["test_id"], method="gef", header=header, columns=columns, source=str(path))
