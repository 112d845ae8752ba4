"""Where a measured run's energy went: the launcher, each Eq. 9 term with the fit's coefficients, what was left.

From contact to the stop the blade carries the kinetic energy it reached the surface with (measured speed),
and the springs (still extending) and gravity add work along the measured depth; each Eq. 9 term dissipates
its force integrated over the measured depth at the measured speed, with the fitted coefficient; what is
left is the kinetic energy at the stop, and the difference is what the fit does not account for.  The
launcher's side compares the kinetic energy at contact with what the file's launcher (η·n·k over the
stand-off, and gravity) would have delivered.  Pure functions, SI inside, joules out.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from pencli.fit.result import COEFFICIENT_OF
from pencli.model.resistance import TERMS
from pencli.run import Run


@dataclass(frozen=True)
class EnergyBalance:
    """A measured run's energy from release to the stop. [J]"""

    launcher_j: float
    """What the file's launcher delivers over the stand-off, with gravity there (the model's kinetic energy at
    contact)."""
    contact_ke_j: float
    """½·m_eff·v² at contact, v measured."""
    drive_in_material_j: float
    """Work of the springs (while they still extend) and of gravity over the measured depth."""
    terms_j: Mapping[str, float]
    """Each Eq. 9 term's force (fitted coefficients) integrated over the measured depth at the measured speed."""
    terms_interval_j: Mapping[str, tuple[float, float] | None]
    """The same with each coefficient at its 95 % interval's ends, held at 0 (None where the fit gave none)."""
    left_ke_j: float
    """½·m_eff·v² at the stop, v measured (0 after an arrest)."""

    @property
    def supplied_j(self) -> float:
        """Kinetic energy at contact plus the drive's work in the material."""
        return self.contact_ke_j + self.drive_in_material_j

    @property
    def unaccounted_j(self) -> float:
        """Supplied − dissipated by the terms − left: what the fitted model does not account for."""
        return self.supplied_j - sum(self.terms_j.values()) - self.left_ke_j

    @property
    def launcher_shortfall_j(self) -> float:
        """What the launcher delivered less than its file says (negative: more)."""
        return self.launcher_j - self.contact_ke_j


def measured_energy(run: Run, values: Mapping[str, float],
                    intervals: Mapping[str, tuple[float, float] | None] | None = None) -> EnergyBalance:
    """The energy balance of a conditioned run (inertia stage) with Eq. 9's coefficients ``values`` (file units,
    by coefficient name) and, optionally, their 95 % intervals."""
    events = run.require_events()
    t, depth, speed = run.column("time_s"), run.column("depth_m"), run.column("velocity_m_s")
    inside = (t >= events.contact_s) & (t <= events.stop_s) & (depth >= 0.0)
    x, v = depth[inside], np.maximum(speed[inside], 0.0)
    d = run.design
    m, g = d.effective_mass_kg, d.gravity_m_s2
    columns = np.broadcast_arrays(*run.geometry.unit_terms(d, np.maximum(x, 1e-12), v))
    per_unit = {term: float(np.trapezoid(column, x)) if x.size > 1 else 0.0 for term, column in zip(TERMS, columns)}
    terms = {term: values[COEFFICIENT_OF[term]] * per_unit[term] for term in TERMS}
    ranges = {}
    for term in TERMS:
        span = (intervals or {}).get(COEFFICIENT_OF[term])
        ranges[term] = None if not span else (max(span[0], 0.0) * per_unit[term], max(span[1], 0.0) * per_unit[term])
    x_end = float(x[-1]) if x.size else 0.0
    stroke_left = max(float(d.stroke_m) - d.surface_offset_m, 0.0)  # spring travel left at contact
    spring_flight = 0.5 * d.drive_stiffness_n_m * (float(d.stroke_m) ** 2 - stroke_left ** 2)
    spring_material = 0.5 * d.drive_stiffness_n_m * (stroke_left ** 2 - max(stroke_left - x_end, 0.0) ** 2)
    return EnergyBalance(
        launcher_j=spring_flight + m * g * d.surface_offset_m,
        contact_ke_j=0.5 * m * events.contact_speed_m_s ** 2,
        drive_in_material_j=spring_material + m * g * x_end,
        terms_j=terms, terms_interval_j=ranges,
        left_ke_j=0.5 * m * float(v[-1]) ** 2 if events.end == "full_depth" and v.size else 0.0,
    )
