"""Model against data, as data: what ``report`` and ``diagnose`` draw and test on.

For each run, over its record from 2 ms before contact to 5 ms after the
stop: measured depth and resistance; the resistance Eq. 9 gives with the
measured kinematics (resistance mode); and the fully predicted depth and
resistance from the launch (dynamic mode).
"""

from __future__ import annotations

from dataclasses import replace

from typing import Mapping, Sequence

import numpy as np

from pencli.fit.dynamic import predicted_on
from pencli.fit.resistance import basis, windows
from pencli.fit.result import COEFFICIENTS, TERM_OF
from pencli.run import Run

COLUMNS = ("time_s", "depth_m", "resistance_n", "resistance_model_n", "depth_dynamic_m", "resistance_dynamic_n",
           "in_window")


def model_vs_data(runs: Sequence[Run], values: Mapping[str, float], terms: Sequence[str],
                  *, before_s: float = 2e-3, after_s: float = 5e-3) -> dict[str, np.ndarray]:
    """Columns (``run_id`` plus :data:`COLUMNS`) over every run, concatenated."""
    parts: dict[str, list] = {name: [] for name in ("run_id", *COLUMNS)}
    coeffs = np.array([values[name] if TERM_OF[name] in terms else 0.0 for name in COEFFICIENTS])
    for s in windows(runs):
        rec = s.record or {"time_s": s.time_s, "depth_m": s.depth_m, "velocity_m_s": s.velocity_m_s,
                           "resistance_n": s.resistance_n}
        t = rec["time_s"]
        keep = (t >= s.contact_s - before_s) & (t <= s.stop_s + after_s)
        view = replace(s, time_s=t[keep], depth_m=rec["depth_m"][keep], velocity_m_s=rec["velocity_m_s"][keep],
                       resistance_n=rec["resistance_n"][keep], record=None)
        in_material = (view.depth_m >= 0) & (view.time_s >= s.contact_s) & (view.time_s <= s.stop_s)
        eq9 = np.where(in_material, basis(view) @ coeffs, 0.0)
        x_dyn, r_dyn, _ = predicted_on(view, values, terms, view.time_s)
        parts["run_id"].append(np.full(view.time_s.size, s.run_id, dtype=object))
        parts["time_s"].append(view.time_s)
        parts["depth_m"].append(view.depth_m)
        parts["resistance_n"].append(view.resistance_n)
        parts["resistance_model_n"].append(eq9)
        parts["depth_dynamic_m"].append(x_dyn)
        parts["resistance_dynamic_n"].append(r_dyn)
        parts["in_window"].append((view.time_s >= s.time_s[0]) & (view.time_s <= s.time_s[-1]))
    return {name: np.concatenate(chunks) for name, chunks in parts.items()}
