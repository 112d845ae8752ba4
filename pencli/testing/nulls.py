"""Null laws for checking the family-wise threshold: improvements drawn with no effect in them."""

from __future__ import annotations

import numpy as np

from pencli.diagnose.engine import _standardise


def point_mass(rng: np.random.Generator, shape) -> np.ndarray:
    """A sign-bounded family's improvements under the null: 0 (at its bound) on most draws, χ²₁ on 5 %."""
    values = np.zeros(shape)
    fits = rng.random(shape) < 0.05
    values[fits] = rng.chisquare(1, int(fits.sum()))
    return values


def largest_z(values: np.ndarray) -> float:
    """The data's (row 0) largest standardised improvement over the families (columns)."""
    return max(_standardise(values[:, k], 1e-9)[0] for k in range(values.shape[1]))
