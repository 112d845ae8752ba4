"""Diagnosis across constant-rate soundings of one site: does the push rate change the resistance, and which way?

The reference model gives each soil unit one value whatever the rate; the
rate effect (:mod:`pencli.fit.rate_effect`) adds q_u·K·log10(v/v_ref).
Each is fitted without one sounding and scored on it (the relative error of
its unit means), and the improvement summed over soundings is the
statistic.  Its null is made from the campaign itself: the soundings' rates
are shuffled among them (each sounding keeps its units together), which
keeps the units, their spatial scatter and the rates' spread but breaks any
link between rate and resistance.  A site of up to six soundings (720
orderings) is tested on every ordering of its rates, exactly; a larger one
on random shuffles.  The verdict is ``rate_effect`` when the
data's improvement is beyond the null's at the stated false-alarm rate,
and ``none`` otherwise, with the fitted K and its error beside it either
way.  Effects this test does not model (a trend with the date, a unit
misplaced in one sounding) are not named: a misfit left far above the
spatial scatter is noted, not explained.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from pencli.diagnose import SOUNDING_FALSE_ALARM as FALSE_ALARM
from pencli.diagnose import SOUNDING_SHUFFLES as SHUFFLES
from pencli.errors import FitError
from pencli.fit.rate_effect import MIN_RATE_SPAN, RateEffect, UnitMean, fit_rate_effect, solve_rate_law

MIN_SOUNDINGS = 4
"""Soundings a diagnosis needs: one left out, and three at two rates or more to fit the rest."""


@dataclass(frozen=True)
class SoundingDiagnosis:
    """The verdict on a site's soundings and what it rests on."""

    verdict: str
    """``rate_effect`` or ``none``."""
    effect: RateEffect
    """The rate effect fitted on every sounding (K per decade and its error)."""
    improvement: float
    """Σ over soundings of the reference model's held-out squared relative error less the rate effect's."""
    p_value: float
    """The share of shuffled campaigns (and the data) whose improvement is at least the data's (of all orderings
    of the rates when there are no more than the shuffles asked for)."""
    false_alarm: float
    heldout_rms_reference: float
    """RMS of the reference model's held-out relative errors (one value per unit per rate) [–]."""
    heldout_rms_effect: float
    """The same with the rate effect [–]."""
    soundings: int
    null_orderings: int = 0
    """How many orderings of the rates made the null (besides the data's own)."""
    exact: bool = False
    """The null is every ordering of the rates (a site of few soundings), not a random draw of them."""
    notes: tuple[str, ...] = ()

    @property
    def direction(self) -> str:
        """``faster is stronger`` or ``faster is weaker`` (by the sign of K)."""
        return "faster is stronger" if self.effect.per_decade > 0 else "faster is weaker"


def _heldout_errors(sounding: np.ndarray, unit: np.ndarray, value: np.ndarray, log_rate: np.ndarray
                    ) -> tuple[float, float]:
    """Σ of the held-out squared relative errors of (the reference model, the rate effect), each sounding left out
    in turn.  Per unit mean: its sounding's index, its unit's index (0…U−1), its value, and log10(v/v_ref) of its
    sounding's rate; the rate effect fitted by :func:`pencli.fit.rate_effect.solve_rate_law`."""
    U = int(unit.max()) + 1
    base = effect = 0.0
    for i in np.unique(sounding):
        out = sounding == i
        rest = ~out
        count = np.bincount(unit[rest], minlength=U)
        mean = np.bincount(unit[rest], weights=value[rest], minlength=U) / np.maximum(count, 1)
        known = out & (count[unit] > 0)
        reference = float(np.sum((value[known] / mean[unit[known]] - 1.0) ** 2))
        base += reference
        if rest.sum() <= np.count_nonzero(count) + 1 or np.ptp(log_rate[rest]) < MIN_RATE_SPAN:
            effect += reference  # too few left to fit the rate effect: the reference model's prediction
            continue
        p, K, _ = solve_rate_law(unit[rest], value[rest], log_rate[rest], U)
        effect += float(np.sum((p[unit[known]] * value[known] / (1.0 + K * log_rate[known]) - 1.0) ** 2))
    return base, effect


def diagnose_soundings(per_sounding: Sequence[Sequence[UnitMean]], *, reference_rate_mm_s: float = 20.0,
                       permutations: int = SHUFFLES, false_alarm: float = FALSE_ALARM,
                       seed: int = 0) -> SoundingDiagnosis:
    """The verdict on a site (module docstring) from each sounding's unit means (its rate: the median over its
    units of the rates they were pushed at)."""
    groups = [list(g) for g in per_sounding if len(g)]
    if len(groups) < MIN_SOUNDINGS:
        raise FitError(f"{len(groups)} soundings with unit means; a diagnosis needs at least {MIN_SOUNDINGS}")
    rates = np.array([float(np.median([m.rate_mm_s for m in g])) for g in groups])
    effect = fit_rate_effect([m for g in groups for m in g], reference_rate_mm_s)
    units = sorted({m.unit for g in groups for m in g})
    index = {u: k for k, u in enumerate(units)}
    sounding = np.array([i for i, g in enumerate(groups) for _ in g])
    unit = np.array([index[m.unit] for g in groups for m in g])
    value = np.array([m.value for g in groups for m in g])
    log_rates = np.log10(rates / reference_rate_mm_s)
    base, with_effect = _heldout_errors(sounding, unit, value, log_rates[sounding])
    improvement = base - with_effect
    exact = math.factorial(len(groups)) <= permutations + 1
    if exact:  # every ordering (the data's among them)
        orders = [np.array(order) for order in itertools.permutations(range(len(groups)))][1:]  # the first: the data's
    else:
        rng = np.random.default_rng(seed)
        orders = [rng.permutation(len(groups)) for _ in range(permutations)]
    null = np.array([np.subtract(*_heldout_errors(sounding, unit, value, log_rates[order][sounding]))
                     for order in orders])
    p_value = float((1 + np.sum(null >= improvement)) / (1 + len(orders)))
    n = sum(len(g) for g in groups)
    notes = []
    verdict = "rate_effect" if p_value <= false_alarm else "none"
    if verdict == "none" and abs(effect.t) > 2:
        notes.append(f"K = {effect.per_decade:+.3f} ± {effect.per_decade_se:.3f} per decade is {abs(effect.t):.1f} "
                     "standard errors from 0 fitted on all soundings, but with it a sounding left out is not "
                     f"predicted better than with shuffled rates at the {false_alarm:g} false-alarm rate "
                     f"(p = {p_value:.3f}): the soundings scatter about each other more than the unit means' "
                     "error says")
    if 1.0 / (1 + len(orders)) > false_alarm:
        notes.append(f"{len(orders)} {'orderings' if exact else 'shuffles'} of the rates cannot resolve a "
                     f"false-alarm rate of {false_alarm:g}: the smallest p-value is {1 / (1 + len(orders)):.3g}")
    return SoundingDiagnosis(verdict=verdict, effect=effect, improvement=float(improvement), p_value=p_value,
                             false_alarm=false_alarm, heldout_rms_reference=float(np.sqrt(base / n)),
                             heldout_rms_effect=float(np.sqrt(with_effect / n)), soundings=len(groups),
                             null_orderings=len(orders), exact=exact, notes=tuple(notes))
