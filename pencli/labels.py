"""Names and units of everything pen draws or prints: one definition, read by figures, reports and the CLI.

Parameter keys take their name, symbol and unit from :data:`pencli.params.definitions.PARAMETERS`; the
figures of a simulated run (CONTRACT §5), the recorded channels and the analysis quantities are listed here.
A figure's axis reads ``blade thickness T [mm]``, never ``blade_thickness_mm``.  Pure data: no I/O.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from pencli.params.definitions import BY_KEY


@dataclass(frozen=True)
class Quantity:
    """How to show one quantity: its name, the unit shown and the factor from the stored value to it."""

    name: str
    unit: str
    scale: float = 1.0
    """Shown value = stored value × scale (``penetration_time_s`` is stored in s and shown in ms: 1e3)."""

    @property
    def label(self) -> str:
        """``name [unit]`` (the name alone for a quantity without unit)."""
        return f"{self.name} [{self.unit}]" if self.unit else self.name


FIGURES: dict[str, Quantity] = {
    "contact_speed_m_s": Quantity("speed at contact", "m/s"),
    "contact_time_s": Quantity("time to contact", "ms", 1e3),
    "penetration_time_s": Quantity("penetration time", "ms", 1e3),
    "final_depth_mm": Quantity("final depth", "mm"),
    "full_penetration": Quantity("full penetration", ""),
    "peak_resistance_n": Quantity("peak resistance", "N"),
    "peak_resistance_depth_mm": Quantity("depth of the peak resistance", "mm"),
    "residual_ke_j": Quantity("residual kinetic energy", "J"),
    "spring_energy_j": Quantity("spring energy delivered", "J"),
    "gravity_work_j": Quantity("work of gravity", "J"),
    "energy_strength_j": Quantity("energy: strength", "J"),
    "energy_friction_j": Quantity("energy: friction", "J"),
    "energy_damping_j": Quantity("energy: damping", "J"),
    "energy_inertia_j": Quantity("energy: inertia", "J"),
    "energy_other_j": Quantity("energy: resistance not by term", "J"),
}
"""The figures of one predicted run (CONTRACT §5 and the energy balance), as shown."""

DRIVE_WORK: dict[str, Quantity] = {
    "springs": FIGURES["spring_energy_j"],
    "free_fall": Quantity("work of buoyancy, drag and tether", "J"),
    "constant_rate": Quantity("work of the push", "J"),
}
"""How ``spring_energy_j`` (the drive's work, CONTRACT §5's name) is shown for each drive."""

CHANNELS: dict[str, Quantity] = {
    "time_s": Quantity("time since release", "ms", 1e3),
    "position_mm": Quantity("position", "mm"),
    "depth_m": Quantity("depth below the surface", "mm", 1e3),
    "fx_n": Quantity("lateral force Fx", "N"),
    "fy_n": Quantity("lateral force Fy", "N"),
    "fz_n": Quantity("axial force Fz", "N"),
    "tx_nm": Quantity("moment Mx", "N·m"),
    "ty_nm": Quantity("moment My", "N·m"),
    "tz_nm": Quantity("moment Mz", "N·m"),
    "force_n": Quantity("load-cell force F", "N"),
    "velocity_m_s": Quantity("speed", "m/s"),
    "acceleration_m_s2": Quantity("acceleration", "m/s²"),
    "resistance_n": Quantity("resistance R", "N"),
}
"""The recorded and conditioned channels of a run (CONTRACT §3 and pen's stages), as shown."""

SPEED_AT_CONTACT = Quantity("speed at contact", "m/s")
"""The sweep variable ``speed_at_contact`` (not a parameter key)."""


def quantity(key: str) -> Quantity:
    """How to show ``key``: a parameter key (``blade_thickness_mm``, ``coefficients.strength_factor`` or the
    coefficient's bare name), a figure, a channel or ``speed_at_contact``; an unknown key is shown as it is."""
    if key in FIGURES:
        return FIGURES[key]
    if key in CHANNELS:
        return CHANNELS[key]
    if key == "speed_at_contact":
        return SPEED_AT_CONTACT
    param = BY_KEY.get(key) or BY_KEY.get(f"coefficients.{key}")
    if param is not None:
        named = param.symbol and re.search(rf"(?<!\w){re.escape(param.symbol)}(?!\w)", param.meaning)
        symbol = f" {param.symbol}" if param.symbol and not named else ""
        return Quantity(f"{_first_clause(param.meaning)}{symbol}", "" if param.unit in ("-", "–", "1") else param.unit)
    return Quantity(key, "")


def label(key: str) -> str:
    """``name [unit]`` of ``key`` (see :func:`quantity`)."""
    return quantity(key).label


def _first_clause(meaning: str) -> str:
    """A parameter's meaning up to its first parenthesis or comma: what fits on an axis."""
    for stop in (" (", ", ", "; "):
        meaning = meaning.split(stop)[0]
    return meaning.strip()
