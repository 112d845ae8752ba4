r"""A force drift seen where nothing else acts: the rest after the stop.

Inside the penetration a slow drift of the force offset and a speed law
(velocity friction, rate strength) can take each other's place: the blade
slows as time goes on, so a function of speed is nearly a function of time
there, and a friction fitted first leaves a weak drift beside it too little
to count.  After the stop the blade is at rest and the material (or the
hard stops) holds it: no speed law, no depth law and no inertia acts, and
the tared force is a constant plus the sensor's noise plus the drift, which
goes on.  This module tests that span alone for the drift family's shapes
(functions of the time since the release, :data:`~pencli.diagnose.effects.EFFECTS`'
``force_drift`` members):

- each run's span starts :data:`SETTLE_S` after its stop (a lag, an arrest's
  rebound, a struck mode and the smoother's reach at the stop have died away
  by then) and ends :data:`EDGE_S` before the record's end, at most
  :data:`REST_MAX_S` long; a run with less than :data:`REST_MIN_S` of it
  takes no part;
- a drift shape is read there only where it still changes (at least
  :data:`REST_CHANGE_MIN` of its change since the release falls in the
  span): one all but finished before it fits, there, only a transient at the
  span's start;
- each run keeps its own rest level (a free constant: the weight the material
  holds, or what the stops leave, is not the model's business), so only the
  *change* of the force over the span is evidence;
- one set of drift coefficients is shared by the runs, as in the window's fit,
  each run weighted by its sample count (a mean over runs of each run's mean
  square, as the held-out scores are);
- the statistic is the largest reduction of that mean square over the
  family's shapes; its null comes from the campaign's own noise, each run's
  rest span synthesised from the spectrum its pre-trigger span shows
  (:class:`~pencli.diagnose.null.NoiseModel`, each replicate with a spectrum
  the estimate's own error allows).

Pure functions, no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace
from typing import Sequence

import numpy as np

from pencli.diagnose.effects import _RunView, Member
from pencli.diagnose.null import NoiseModel

SETTLE_S = 0.05
"""The rest span starts this long after the stop. [s]"""
EDGE_S = 0.002
"""…and ends this long before the record's end. [s]"""
REST_MAX_S = 0.5
"""Longest rest span used per run. [s]"""
REST_MIN_S = 0.05
"""A run with a shorter rest span takes no part. [s]"""
REST_CHANGE_MIN = 0.05
"""A drift shape is read at rest only where at least this share of its change since the release happens over the
rest span (mean over the runs): a shape all but finished before the rest is, there, a transient at the span's
start, which a struck mode still ringing or a force chain settling after the stop's step makes as well. [–]"""


def rest_span(run: _RunView) -> np.ndarray:
    """Boolean mask of the run's rest span after its stop (all False when shorter than :data:`REST_MIN_S`)."""
    t = run.time_s
    start = run.stop_s + SETTLE_S
    end = min(float(t[-1]) - EDGE_S, start + REST_MAX_S)
    if not np.isfinite(start) or end - start < REST_MIN_S:
        return np.zeros(t.size, dtype=bool)
    return (t >= start) & (t <= end)


@dataclass(frozen=True)
class RestTest:
    """The rest span's drift statistic on the data (row 0) and on noise-only replicates (rows 1…)."""

    improvements: np.ndarray
    """(1 + replicates,): the largest reduction over the drift shapes of the runs' mean squared rest force
    (each run's own constant removed). [N²]"""
    member: int
    """Index of the data's best shape among the members given."""
    coefficients: np.ndarray
    """The data's best shape's shared coefficients (its columns' units: N per unit of the shape)."""
    runs: int
    """Runs that have a rest span."""
    samples: int
    """Their rest samples, all together."""


def _demeaned(columns: np.ndarray) -> np.ndarray:
    return columns - columns.mean(axis=0, keepdims=True)


def _rest_change(columns: np.ndarray) -> float:
    """The share of a drift shape's change since the release (its value there is 0) that happens over a rest span
    (``columns``: its columns on the span, (n, k)); the largest over its columns."""
    end = np.abs(columns[-1])
    return float(np.max(np.abs(columns[-1] - columns[0]) / np.maximum(end, 1e-300)))


def rest_drift(runs: Sequence[_RunView], members: Sequence[Member], noises: Sequence[NoiseModel],
               count: int, seed: int) -> RestTest | None:
    """The drift statistic of :class:`RestTest` over the runs' rest spans, with ``count`` noise replicates drawn
    from ``noises`` (one model per run, read from its pre-trigger span) by a generator seeded with ``seed``.
    None when no run has a rest span or no shape still changes there.  ``members``: the drift family's shapes (chain members of the time since
    the release, built on the rest span's times)."""
    rng = np.random.default_rng([seed, 7919])
    spans = [rest_span(r) for r in runs]
    used = [i for i, s in enumerate(spans) if s.any()]
    if not used:
        return None
    targets, shapes, keep = [], [], []
    for i in used:
        run, span = runs[i], spans[i]
        n = int(span.sum())
        noise = noises[i]
        spectra = noise.spectra(count, rng)
        replicas = noise.simulate(n, rng, count, spectra)  # (n, count)
        y = np.column_stack([run.resistance_n[span], replicas])
        targets.append(_demeaned(y))
        t = SimpleNamespace(t=np.maximum(run.time_s[span], 0.0))
        raw = [np.asarray(m.chain(run, t).extra, dtype=float).reshape(n, -1) for m in members]
        keep.append([_rest_change(X) for X in raw])
        shapes.append([_demeaned(X) for X in raw])
    best = np.full(count + 1, -np.inf)
    best_member, best_coef = 0, np.zeros(0)
    readable = np.flatnonzero(np.mean(keep, axis=0) >= REST_CHANGE_MIN)
    if not readable.size:
        return None
    for j in readable:
        k = shapes[0][j].shape[1]
        A = np.zeros((k, k))
        b = np.zeros((k, count + 1))
        for X, Y in zip((s[j] for s in shapes), targets):
            A += X.T @ X / X.shape[0]
            b += X.T @ Y / X.shape[0]
        scale = np.sqrt(np.maximum(np.diag(A), 1e-300))
        As = A / scale[:, None] / scale[None, :] + 1e-10 * np.eye(k)
        theta = np.linalg.solve(As, b / scale[:, None]) / scale[:, None]  # (k, 1 + count)
        gain = np.einsum("kt,kt->t", theta, b) / len(used)  # reduction of the mean over runs of the mean square
        if gain[0] > best[0]:
            best_member, best_coef = j, theta[:, 0].copy()
        best = np.maximum(best, gain)
    return RestTest(best, best_member, best_coef, len(used), int(sum(int(spans[i].sum()) for i in used)))
