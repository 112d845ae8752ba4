"""A sweep of a penetrator whose resistance is not Eq. 9's form (a cone, a tapered blade), or of a drive other
than the spring launcher (a free fall through a fluid).

The batch simulator's closed forms and compiled kernels hold for Eq. 9's law on CONTRACT §2's springs, whose
four coefficients are the same at every depth; a cone's frontal area grows with depth, and a fall through
water is dragged and buoyed.  Each of their designs is integrated by the
scalar simulator (:func:`pencli.model.dynamics.simulate`, the one ``pen predict`` uses, about 12 ms a design on
this project's two-core machine), with the same figures and end codes as the batch's rows.  Pure: no I/O.
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from pencli.errors import ModelError, ParameterError
from pencli.model.design import Design
from pencli.model.drive import build_drive
from pencli.model.dynamics import SimulationLimit, simulate
from pencli.model.geometry import GEOMETRIES
from pencli.params.definitions import BY_KEY, RULES, choices_of, params_of
from pencli.predict.batch import ENDS, FIGURES
from pencli.predict.sweep import si_designs

MAX_DESIGNS = 100_000
"""The most designs a sweep integrates one by one (about 20 minutes at 12 ms a design). [–]"""

CHUNK = 250
"""Designs per chunk: the progress bar moves every few seconds."""

_RATE_HZ = 1000.0
"""The trajectory's output rate: the figures come from the integrator's own steps, not from this grid. [Hz]"""


def run_chunk_shaped(base: Mapping[str, float], columns: Mapping[str, np.ndarray], geometry: str,
                     choices: Mapping[str, str], drive: str = "springs") -> dict:
    """One chunk (varied columns, file units) of a ``geometry`` penetrator on a ``drive``, design by design: the batch's
    figures and ``energy_other_j`` (what the resistance dissipated outside Eq. 9's terms: all of a cone's),
    ``end`` codes into :data:`~pencli.predict.batch.ENDS` and ``near_critical``.  A design a parameter rule or
    the geometry refuses is ``invalid``, one whose forces overflow float64 ``overflow``; their figures are NaN.
    ``choices``: the penetrator's named choices (``cone_area``).  Top level, so dask can ship it."""
    designs, speed = si_designs(base, columns)
    n = len(next(iter(columns.values())))
    every = {name: np.broadcast_to(np.asarray(value, dtype=float).reshape(-1) if np.ndim(value) else value, (n,))
             for name, value in designs.items()}
    file_values = {key: np.broadcast_to(np.asarray(columns[key] if key in columns else base.get(key, math.nan),
                                                   dtype=float), (n,)) for key in BY_KEY}
    shape_params = [p for p in params_of("penetrator", geometry) if p.builds == "geometry"]
    named = {c.si_name: choices.get(c.key, c.default) for c in choices_of("penetrator", geometry) if c.si_name}
    out = {name: np.full(n, np.nan) for name in (*FIGURES, "energy_other_j") if name != "full_penetration"}
    full, near = np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)
    code = np.zeros(n, dtype=np.int8)
    for i in range(n):
        values = {key: float(column[i]) for key, column in file_values.items()}
        if not all(rule.holds({k: v for k, v in values.items() if not math.isnan(v)}) for rule in RULES):
            code[i] = ENDS.index("invalid")
            continue
        fields = {name: float(column[i]) for name, column in every.items()}
        fields["spring_count"] = int(fields["spring_count"])
        try:
            shape = GEOMETRIES[geometry](**{p.si_name: values[p.key] * p.si_scale for p in shape_params
                                            if not math.isnan(values[p.key])}, **named)
            design = Design(**fields)
            summary = simulate(design, geometry=shape, drive=build_drive(drive, values, design, shape),
                               output_rate_hz=_RATE_HZ,
                               speed_at_contact_m_s=None if speed is None else float(speed[i])).summary
        except SimulationLimit:
            code[i] = ENDS.index("overflow")
            continue
        except (ModelError, ParameterError):
            code[i] = ENDS.index("invalid")
            continue
        code[i] = ENDS.index(summary.end)
        if code[i] >= ENDS.index("no_contact"):
            continue
        for name in out:
            out[name][i] = float(getattr(summary, name))
        full[i], near[i] = bool(summary.full_penetration), bool(summary.near_critical)
    return {**out, "full_penetration": full, "end": code, "near_critical": near}


__all__ = ["CHUNK", "MAX_DESIGNS", "run_chunk_shaped"]
