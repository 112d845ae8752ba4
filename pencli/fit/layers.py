r"""Layers of a sounding: where its cone resistance changes law with depth.

A profile is cut into layers, each a straight line of q against depth
(a resistance that grows with depth at a constant rate, as a normally
consolidated clay's does, or stays level, as a sand's about does), by
optimal partitioning: the cut that minimises

.. math:: \sum_\text{layers} \sum_\text{rows} \left(\frac{q - q_\text{line}}{\tilde q}\right)^2 + \beta \cdot (\text{layers})

(each row's residual relative to the resistance there, :math:`\tilde q`
the running median over the thinnest layer's rows, a weighted
least-squares line per layer: the sensors' scatter is a share of the
reading, and a single reading near 0 does not outweigh the rest)

over every cut whose layers are at least ``min_thickness_m`` thick,
found exactly by dynamic programming over the rows (the lines' sums of
squares from cumulative sums, so each candidate layer costs a few
operations).  The penalty is the Bayesian information criterion's, a
layer adding three parameters (its top, its line's level and slope):
:math:`\beta = 3\,\hat\sigma^2 \ln n`, with :math:`\hat\sigma` the
profile's own row-to-row scatter, read from its second differences
(robust: the median absolute value, which a boundary's few rows do not
move).

A real profile's small-scale variation is not white noise: a sand's
resistance wanders over decimetres, so neighbouring rows' departures from
a layer's line run together, and a cut at the white-noise penalty finds a
layer every half metre.  The cut is therefore made twice: the first cut's
residuals give their own variance :math:`s^2` and lag-one correlation
:math:`\rho`, and the second cut's penalty is the criterion's on the
residuals' long-run variance, :math:`\beta = 3\,s^2 \frac{1+\rho}{1-\rho}
\ln n` (an AR(1) series' variance of a mean is that much larger than white
noise's), where it is larger.  On white noise :math:`\rho \approx 0` and
the second cut is the first.  Nothing is set on the data it is checked
on: the constants are the criterion's, the scatter and correlation each
profile's own.  ``min_thickness_m`` bounds the thinnest layer; the default
(0.3 m) is one the cone resolves, about eight cone diameters.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pencli.errors import DataError
from pencli.fit import LAYER_MIN_THICKNESS_M

MIN_THICKNESS_M = LAYER_MIN_THICKNESS_M
"""Thinnest layer the cut keeps by default (defined numpy-free, for the CLI's help). [m]"""

TRANSITION_M = 0.5
"""One or two layers each at most this thick whose resistance runs from the layer above's to the layer below's
are the cone crossing a boundary, not layers: the cone senses a few diameters ahead and behind, so a step in
the ground reads as a ramp. [m]"""

PARAMETERS_PER_LAYER = 3
"""What a layer adds to the model: its top, its line's level and its slope (the criterion's count)."""

SCATTER_FROM_SECOND_DIFFERENCES = math.sqrt(6.0)
"""White noise of standard deviation σ gives second differences of standard deviation √6·σ."""

MAD_TO_SD = 1.4826
"""A normal variable's standard deviation per median absolute deviation."""

MAX_CORRELATION = 0.99
"""The residuals' lag-one correlation is read at most this high: beyond it the stretch (1 + ρ)/(1 − ρ) says
the profile is one smooth curve, and a cut of it says nothing."""


@dataclass(frozen=True)
class Layer:
    """One layer of a cut: from ``top_m`` to ``bottom_m``, q = ``q_top`` + ``gradient``·(z − top) on its rows (q in
    the profile's unit)."""

    top_m: float
    bottom_m: float
    rows: tuple[int, int]
    """Its first row and the row past its last."""
    q_top: float
    """Its line's q at its top."""
    gradient_per_m: float
    """dq/dz. [q's unit per m]"""

    @property
    def q_bottom(self) -> float:
        return self.q_top + self.gradient_per_m * (self.bottom_m - self.top_m)

    def mean_of(self, values: np.ndarray | None) -> float | None:
        """The mean of another column of the profile (the sleeve friction) over the layer's rows; None where the
        profile has no such column or the layer no finite value of it."""
        if values is None:
            return None
        inside = np.asarray(values, dtype=float)[slice(*self.rows)]
        return float(np.nanmean(inside)) if np.isfinite(inside).any() else None


@dataclass(frozen=True)
class Cut:
    """A profile's layers and what decided them."""

    layers: tuple[Layer, ...]
    scatter: float
    """The scatter of q about the layers' lines, as a share of q: the second cut's residuals' where their
    correlation stretched the penalty, else σ̂ from the second differences."""
    penalty: float
    """β, what a layer must save in the sum of relative squares to be kept."""
    correlation: float = 0.0
    """ρ, the lag-one correlation of the first cut's residuals, which stretched β (0: none, or a given β)."""

    @property
    def boundaries_m(self) -> list[float]:
        """Depths between layers (each layer's top but the first). [m]"""
        return [layer.top_m for layer in self.layers[1:]]


def detect_layers(depth_m: np.ndarray, q: np.ndarray, *, min_thickness_m: float = MIN_THICKNESS_M,
                  penalty: float | None = None) -> Cut:
    """The optimal cut of the profile ``q`` (> 0; NaN rows are left out) against ``depth_m`` (increasing) into
    straight lines of q, each row's residual relative to its reading (module docstring).  ``penalty``: β, in
    relative squares, instead of the criterion's (then no second cut)."""
    depth_m, q = np.asarray(depth_m, dtype=float), np.asarray(q, dtype=float)
    keep = np.isfinite(depth_m) & np.isfinite(q) & (q > 0)
    z, y = depth_m[keep], q[keep]
    n = z.size
    if n < 8:
        raise DataError(f"layers: {n} rows with a positive resistance; at least 8 are needed")
    if np.any(np.diff(z) <= 0):
        raise DataError("layers: the depths do not increase from row to row")
    step = float(np.median(np.diff(z)))
    shortest = max(int(math.ceil(min_thickness_m / step - 1e-9)), 3)  # rows; a line needs three to leave anything
    second = np.diff(np.log(y), 2)
    scatter = MAD_TO_SD * float(np.median(np.abs(second - np.median(second)))) / SCATTER_FROM_SECOND_DIFFERENCES
    beta = PARAMETERS_PER_LAYER * max(scatter, 1e-6) ** 2 * math.log(n) if penalty is None else float(penalty)
    w = _weights(y, shortest)
    layers = _cut(z, y, w, keep, shortest, beta)
    correlation = 0.0
    if penalty is None:  # the residuals' own variance, stretched by how far they run together (AR(1))
        before = np.cumsum(keep)  # kept rows up to and including each profile row
        spans = [(int(before[layer.rows[0]]) - 1, int(before[layer.rows[1] - 1])) for layer in layers]
        residual = np.concatenate([(y[a:b] - (layer.q_top + layer.gradient_per_m * (z[a:b] - layer.top_m)))
                                   * np.sqrt(w[a:b]) for layer, (a, b) in zip(layers, spans)])
        correlation = float(np.clip(np.corrcoef(residual[:-1], residual[1:])[0, 1], 0.0, MAX_CORRELATION))
        if correlation > 0.0:
            scatter = float(np.sqrt(np.mean(residual * residual)))
            beta = max(beta, PARAMETERS_PER_LAYER * scatter ** 2 * (1 + correlation) / (1 - correlation) * math.log(n))
            layers = _cut(z, y, w, keep, shortest, beta)
    return Cut(layers, scatter, beta, correlation)


def _cut(z: np.ndarray, y: np.ndarray, w: np.ndarray, keep: np.ndarray, shortest: int, beta: float
         ) -> tuple[Layer, ...]:
    """The optimal cut at penalty ``beta``, transitions made boundaries."""
    starts = _optimal_starts(z, y, w, shortest, beta)
    layers = []
    end = z.size
    while end > 0:
        start = starts[end]
        layers.append(_line(z, y, w, start, end, keep))
        end = start
    return _without_transitions(list(reversed(layers)), z, y, w, keep)


def _without_transitions(layers: list[Layer], z: np.ndarray, y: np.ndarray, w: np.ndarray, keep: np.ndarray
                         ) -> tuple[Layer, ...]:
    """The cut with each transition made a boundary: one or two thin layers (each at most :data:`TRANSITION_M`)
    between two others, rising or falling as the step between those does and passing the level half-way between
    them (a large step's ramp is not one straight line).  The boundary is where the ramp passes that level; the
    ramp's rows go to the layers either side, whose lines are refitted."""
    index = {int(i): k for k, i in enumerate(np.flatnonzero(keep))}  # profile row -> kept row
    out = list(layers)
    k = 1
    while k < len(out) - 1:
        for size in (2, 1):
            if k + size >= len(out):
                continue
            above, ramp, below = out[k - 1], out[k:k + size], out[k + size]
            half = 0.5 * (above.q_bottom + below.q_top)
            jump = below.q_top - above.q_bottom
            crossing = [layer for layer in ramp if min(layer.q_top, layer.q_bottom) <= half
                        <= max(layer.q_top, layer.q_bottom)]
            if not crossing or not all(layer.bottom_m - layer.top_m <= TRANSITION_M + 1e-9
                                       and jump * layer.gradient_per_m > 0 for layer in ramp):
                continue
            at = crossing[0]
            depth = at.top_m + (half - at.q_top) / at.gradient_per_m
            split = int(np.searchsorted(z, depth))
            first, past = index[above.rows[0]], index[below.rows[1] - 1] + 1
            split = min(max(split, first + 1), past - 1)
            out[k - 1:k + size + 1] = [_line(z, y, w, first, split, keep), _line(z, y, w, split, past, keep)]
            break
        else:
            k += 1
    return tuple(out)


def _weights(y: np.ndarray, shortest: int) -> np.ndarray:
    """1/q̃² per row, q̃ the running median of q over the thinnest layer's rows: each row's residual relative to the
    reading there, without a single reading near 0 (a pause, a rod added) weighing thousands of times the rest."""
    from scipy.ndimage import median_filter

    level = median_filter(y, size=shortest | 1, mode="nearest")
    return 1.0 / np.maximum(level, np.max(level) * 1e-6) ** 2


def _optimal_starts(z: np.ndarray, y: np.ndarray, w: np.ndarray, shortest: int, beta: float) -> np.ndarray:
    """For each end row e, the start of the last layer of the best cut of rows [0, e) (dynamic programming over
    weighted least-squares lines, weights ``w`` from :func:`_weights`)."""
    n = z.size

    def sums(values):
        return np.concatenate([[0.0], np.cumsum(values)])

    c, sz, sy, szz, szy, syy = (sums(v) for v in (w, w * z, w * y, w * z * z, w * z * y, w * y * y))
    best = np.full(n + 1, np.inf)
    best[0] = -beta  # the first layer pays no boundary beyond the criterion's count
    starts = np.zeros(n + 1, dtype=int)
    for end in range(shortest, n + 1):
        s = np.arange(0, end - shortest + 1)
        s = s[np.isfinite(best[s])]
        if s.size == 0:
            continue
        m = c[end] - c[s]
        mz, my = (sz[end] - sz[s]) / m, (sy[end] - sy[s]) / m
        vzz = (szz[end] - szz[s]) - m * mz * mz
        vzy = (szy[end] - szy[s]) - m * mz * my
        vyy = (syy[end] - syy[s]) - m * my * my
        sse = vyy - np.where(vzz > 0, vzy * vzy / np.where(vzz > 0, vzz, 1.0), 0.0)
        total = best[s] + np.maximum(sse, 0.0) + beta
        k = int(np.argmin(total))
        best[end], starts[end] = float(total[k]), int(s[k])
    return starts


def _line(z: np.ndarray, y: np.ndarray, w: np.ndarray, start: int, end: int, keep: np.ndarray) -> Layer:
    """The layer of rows [start, end) of the kept rows, with its rows numbered in the whole profile."""
    zz, yy = z[start:end], y[start:end]
    index = np.flatnonzero(keep)
    top = float(zz[0]) if start == 0 else 0.5 * float(z[start - 1] + zz[0])
    bottom = float(zz[-1]) if end == z.size else 0.5 * float(zz[-1] + z[end])
    slope, level = np.polyfit(zz - top, yy, 1, w=np.sqrt(w[start:end])) if zz.size > 1 else (0.0, float(yy[0]))
    return Layer(top, bottom, (int(index[start]), int(index[end - 1]) + 1), float(level), float(slope))


__all__ = ["Cut", "Layer", "MIN_THICKNESS_M", "detect_layers"]
