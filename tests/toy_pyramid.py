"""A geometry added the way a user adds one: this module, and the one registration line in :func:`register`.

A square pyramid tip on a square shaft, axis along the motion: each face leans α from the axis, so at depth x
the section's side is s(x) = min(2·x·tan α, a) for a shaft of side a, reached at L = a / (2·tan α).  The
strength presses the section in Eq. 1's projected convention, the sidewall pressure acts on the shaft's four
faces in the material, the rate terms on the section.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from pencli.model.geometry import Shape, register_geometry
from pencli.params.definitions import Param


@dataclass(frozen=True)
class SquarePyramid(Shape):
    half_angle_rad: float
    shaft_side_m: float
    name: str = "square_pyramid"

    def areas(self, design, x: float) -> tuple[float, float, float]:
        a, slope = self.shaft_side_m, math.tan(self.half_angle_rad)
        side = min(2.0 * x * slope, a)
        frontal = side * side
        tip = math.sin(self.half_angle_rad) + design.friction_coefficient * math.cos(self.half_angle_rad)
        return frontal, frontal * tip, 4.0 * a * max(x - a / (2.0 * slope), 0.0)


KEYS = (
    Param("pyramid_half_angle_deg", "penetrator", "α", "angle between a pyramid's face and its axis", "deg",
          "half_angle_rad", math.pi / 180, hard_min=0, hard_max=90, hard_min_exclusive=True,
          hard_max_exclusive=True, range_min=5, range_max=85, builds="geometry"),
    Param("shaft_side_mm", "penetrator", "a", "side of a pyramid's square shaft", "mm", "shaft_side_m", 1e-3,
          hard_min=0, hard_min_exclusive=True, range_min=1, range_max=1000, builds="geometry"),
)


def register():
    return register_geometry(SquarePyramid, "a square pyramid tip on a square shaft", params=KEYS)
