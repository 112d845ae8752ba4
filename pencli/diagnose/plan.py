"""The next runs that would best tell a diagnosis's leading candidates apart (``pen diagnose --suggest N``).

Each candidate is a law effect as the diagnosis fitted it: its best member, its coefficients and the Eq. 9
coefficients of the fit with it in. For every rig design a next run can take (the bundled presets' spring counts
and blade thicknesses and the runs' own, the runs' blade widths, at the highest sampling rate they used), the
dynamic model is run under the first and the resistances the candidates predict along the first candidate's motion
are compared: the separation is the root of the summed squared difference over the samples (its mean taken out,
which the new run's own strength factor would absorb), in units of the campaign's force noise. It is a forecast
before any refit, and not zero on the runs the candidates were fitted to (they fit those alike only as far as the
diagnosis can tell), so it is read against the same figure for the best of those runs, given beside it. A lone
verdict is compared with the baseline (no effect), which says how firmly a new run would confirm it. Measurement
effects (the force chain) and the drive do not change the resistance the model predicts: the plan compares law
effects only and says so.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Mapping, Sequence

import numpy as np

from pencli.errors import ModelError
from pencli.fit.resistance import with_coefficients
from pencli.model.dynamics import simulate
from pencli.model.geometry import BLADE
from pencli.model.resistance import parse_terms

PLAN_RTOL = 1e-8
"""Tolerance of the planning simulations: their differences are read at the noise level, far above it. [–]"""
PLAN_EVALUATIONS = 20_000
"""Evaluations a planning simulation may take (a run takes a few hundred); a design whose motion creeps past it
gets no forecast. [–]"""
NOISE_FLOOR_N = 1e-12
"""A campaign's force noise is kept above this before it divides (a noiseless simulated record). [N]"""


@dataclass(frozen=True)
class Candidate:
    """One law effect as fitted: its extra force on a design, and the Eq. 9 coefficients of its fit."""

    name: str
    values: Mapping[str, float]
    """Eq. 9 coefficients (CONTRACT §1 names, file units) of the fit with the effect in."""
    force: object
    """``force(design) -> f(x [m], v [m/s]) [N]`` or None: the effect's extra resistance (None: the baseline)."""


@dataclass(frozen=True)
class Suggestion:
    """One proposed run and how far apart it would put the candidates."""

    spring_count: int
    blade_thickness_mm: float
    blade_width_mm: float
    sampling_rate_hz: float
    candidates: tuple[str, str]
    separation_sigma: float
    """Root of the summed squared difference of the two candidates' predicted resistance over the samples of
    the run's common penetration, over the campaign's force noise. [noise units]"""

    def to_dict(self) -> dict:
        return {**asdict(self), "candidates": list(self.candidates)}


def _motion(design, candidate: Candidate, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Depth [m] and speed [m/s] from contact to the stop of a run of ``design`` under ``candidate``, sampled at
    ``rate_hz``."""
    extra = candidate.force(design) if candidate.force is not None else None
    result = simulate(with_coefficients(design, candidate.values), rtol=PLAN_RTOL, extra_resistance=extra,
                      output_rate_hz=rate_hz, max_evaluations=PLAN_EVALUATIONS)
    tr, contact = result.trajectory, result.summary.contact_time_s
    inside = (tr.time_s >= contact) & (tr.time_s <= contact + result.summary.penetration_time_s)
    return tr.depth_m[inside], np.maximum(tr.velocity_m_s[inside], 0.0)


def resistance_along(design, candidate: Candidate, depth_m: np.ndarray, speed_m_s: np.ndarray) -> np.ndarray:
    """The resistance ``candidate`` gives a run of ``design`` moving through ``depth_m`` at ``speed_m_s``: its
    Eq. 9 with the coefficients of its fit, plus its effect's force. [N]"""
    law = BLADE.law(with_coefficients(design, candidate.values), parse_terms(None))
    total = np.sum(law.terms_in_contact(depth_m, speed_m_s), axis=0)
    if candidate.force is not None:
        force = candidate.force(design)
        total = total + np.array([force(float(x), float(v)) for x, v in zip(depth_m, speed_m_s)])
    return total


def separation(design, a: Candidate, b: Candidate, rate_hz: float, noise_n: float) -> float:
    """How far apart ``a`` and ``b`` put a run of ``design``, in noise units (see :class:`Suggestion`): both
    read along the motion ``a`` predicts, and the difference's mean taken out (the new run's own strength
    factor, refitted, absorbs a constant)."""
    depth, speed = _motion(design, a, rate_hz)
    if depth.size < 2:
        return 0.0
    diff = resistance_along(design, a, depth, speed) - resistance_along(design, b, depth, speed)
    diff = diff - float(np.mean(diff))
    return float(math.sqrt(float(np.sum(diff * diff))) / max(noise_n, NOISE_FLOOR_N))


RIG_SPRINGS = (2, 4, 6)
"""Spring counts of the rig's bundled launcher presets (``springs_2`` … ``springs_6``)."""
RIG_THICKNESSES_M = (1e-3, 1.5e-3, 2e-3)
"""Blade thicknesses of the rig's bundled blades (``al6061_1mm`` … ``al6061_2mm``). [m]"""


def designs(base, runs_designs: Sequence) -> list:
    """The rig designs a next run can take: the spring counts and blade thicknesses of the rig's bundled presets
    and of the campaign's runs, the blade widths of its runs, on ``base``'s launcher and material."""
    counts = sorted(set(RIG_SPRINGS) | {d.spring_count for d in runs_designs})
    thicknesses = sorted(set(RIG_THICKNESSES_M) | {round(d.blade_thickness_m, 9) for d in runs_designs})
    widths = sorted({round(d.blade_width_m, 9) for d in runs_designs})
    return [replace(base, spring_count=n, blade_thickness_m=t, blade_width_m=w)
            for n in counts for t in thicknesses for w in widths]


def plan(candidates: Sequence[Candidate], runs_designs: Sequence, rate_hz: float, noise_n: float,
         count: int) -> tuple[list[Suggestion], float]:
    """The ``count`` designs (distinct) that put the first candidate furthest from the others, best first,
    each with the pair it separates least (the separation quoted is that pair's); and the best separation a run
    like the campaign's own gives, for comparison. [noise units]"""
    lead, others = candidates[0], candidates[1:]

    def worst(design) -> tuple[float, str] | None:
        """The pair this design separates least, or None where the model cannot finish a candidate's run."""
        try:
            return min((separation(design, lead, other, rate_hz, noise_n), other.name) for other in others)
        except ModelError:
            return None

    forecasts = [(w, d) for d in designs(runs_designs[0], runs_designs) if (w := worst(d)) is not None]
    forecasts.sort(key=lambda item: -item[0][0])
    chosen = [Suggestion(int(d.spring_count), round(d.blade_thickness_m * 1e3, 6), round(d.blade_width_m * 1e3, 6),
                         float(rate_hz), (lead.name, name), round(sep, 2))
              for (sep, name), d in forecasts[:count]]
    own = max((w[0] for w in map(worst, runs_designs) if w is not None), default=0.0)
    return chosen, round(own, 2)
