r"""Leave-one-run-out least squares from per-run sufficient statistics, for many models and targets at once.

Every model the diagnosis scores is linear in its coefficients: a strength
factor per run (block scatter), shared P, C, K (≥ 0) and an effect's
coefficients (free, or ≥ 0 where the effect's meaning fixes their sign).  With each run's Gram matrix of all candidate columns,

.. math:: G_i = W_i^\top W_i / n_i, \qquad c_i = W_i^\top Y_i / n_i,

any model (a choice of columns), any fold (leave run k out) and any target
(the measured resistance or a bootstrap replicate of it) is a small solve:
the run's own strength factor is profiled out by a Schur complement, the
fold's normal equations are the sum over the other runs, and the held-out
residual of run k follows from its own Gram matrix.  Runs carry equal weight
(each Gram is divided by its sample count), so a held-out score is the mean
over runs of each run's mean squared residual. [N²]
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass, fields

import numpy as np
from numba import njit


_threads = 1
"""Threads the compiled solves below run on (:func:`compiled_threads`)."""

CHUNKS_PER_THREAD = 8
"""Slices of a batch per thread: systems differ in cost (the free sets their targets end on), so a thread that
finishes early takes another slice."""


@contextmanager
def compiled_threads(count: int):
    """The compiled solves below run on at most ``count`` threads inside the block.

    The kernels are serial and release the GIL; a batch is cut into slices
    run on a pool of Python threads (:func:`_sliced`).  Numba's own
    ``parallel=True`` would compile each kernel a second time for its
    threading layer: 7 s more for the bounded solve, once per process and
    fresh install.
    """
    global _threads
    before = _threads
    _threads = max(1, int(count))
    try:
        yield
    finally:
        _threads = before


_pools: dict[tuple[int, int], ThreadPoolExecutor] = {}
"""The thread pools of :func:`_sliced`, one per (process, thread count): kept between calls (a diagnosis makes
over a thousand), and never used across a fork."""


def _sliced(kernel, n: int, *args) -> None:
    """``kernel(lo, hi, *args)`` over [0, ``n``) in slices on :data:`_threads` threads (in this thread when one);
    each slice writes its own rows of the outputs."""
    if _threads == 1 or n < 2:
        kernel(0, n, *args)
        return
    key = (os.getpid(), _threads)
    pool = _pools.get(key)
    if pool is None:
        pool = _pools[key] = ThreadPoolExecutor(_threads, thread_name_prefix="pen-solve")
    edges = np.linspace(0, n, min(n, _threads * CHUNKS_PER_THREAD) + 1).astype(int)
    for done in [pool.submit(kernel, lo, hi, *args) for lo, hi in zip(edges[:-1], edges[1:]) if hi > lo]:
        done.result()


N_BOUNDED = 3
"""P, C, K: the shared Eq. 9 coefficients, bounded below by 0 (after the per-run strength factor)."""


@dataclass(frozen=True)
class Spec:
    """A model as column indices into the runs' candidate matrices.

    ``columns`` are [strength, P-column, C-column, K-column, extra...]; the
    target is y − W[:, offset].
    """

    columns: tuple[int, ...]
    offset: int
    scaled: tuple[int, ...] = ()
    """Positions in ``columns`` (extra columns only) of a strength law: its force is a share of the run's
    strength, so a block that is stronger throughout is stronger in the effect too (block scatter multiplies
    the effect's term as it multiplies the baseline's).  Their coefficients are shared; each run's columns
    are scaled by that run's strength factor relative to the mean (:meth:`Statistics.score`)."""


@dataclass(frozen=True)
class Scores:
    """Scores of a batch of models (axis 0) on every target (last axis)."""

    heldout: np.ndarray
    """(models, runs, targets): held-out mean squared residual of each run. [N²]"""
    train: np.ndarray
    """(models, runs, 1): training mean squared residual of the fold that leaves that run out, on the measured
    data (target 0) alone: nothing decides on it, so the replicates' are not computed. [N²]"""
    total: np.ndarray
    """(models, targets): mean squared residual of the all-runs fit. [N²]"""
    coefficients: np.ndarray
    """(models, 3 + k, targets): shared coefficients of the all-runs fit (P, C, K, extra...)."""
    strength: np.ndarray
    """(models, runs, targets): per-run strength factors of the all-runs fit."""
    folds: np.ndarray
    """(models, runs, 3 + k): shared coefficients of the fold that leaves each run out, measured data (target 0)."""
    run_scale: np.ndarray
    """(models, runs): the factor each run's ``scaled`` columns were multiplied by (1 where a model has none)."""
    profiled_scale: np.ndarray
    """(models, runs): each run's strength factor relative to the mean as this fit profiles it, with the
    effect's strength law riding on the strength (measured data); 1 where a model has no scaled columns."""


class Statistics:
    """Per-run sufficient statistics of a candidate matrix W (n_i × Q) and targets Y (n_i × T).

    ``nonnegative`` (Q,) marks the columns whose coefficient is ≥ 0 whatever model it enters (an effect whose
    meaning fixes its sign: a plug widens the blade, sidewall pressure grows); P, C and K are bounded anyway.

    ``varying`` maps a column index to that column's values *per target* (one (n_i × T) array per run), for
    a regressor that is itself measured with an error the target shares: the acceleration, whose derivative
    error enters the resistance through the inertia subtraction (R = F − m·a).  Kept fixed at the data's
    values, such a column correlates with the data's residual but not with a replicate's, and every null
    replicate would understate what fitting it gains on the data.
    """

    def __init__(self, matrices: list[np.ndarray], targets: list[np.ndarray], nonnegative: np.ndarray | None = None,
                 varying: dict[int, list[np.ndarray]] | None = None, resolution: float = 0.0):
        self.resolution = float(resolution)
        """The smallest change of a held-out score that the targets' noise resolves (0: none given). [N²]"""
        self.nonnegative = (np.zeros(matrices[0].shape[1], dtype=bool) if nonnegative is None
                            else np.asarray(nonnegative, dtype=bool))
        # written in place, run by run: the Grams of a layer's two thousand columns are 200 MB, which a stack of
        # per-run products would hold twice and copy (these statistics: 2.4 s with the stack, 2.2 s without, on
        # the example's 6-run campaign under a profiler)
        Q, T = matrices[0].shape[1], targets[0].shape[1]
        self.gram = np.empty((len(matrices), Q, Q))  # (R, Q, Q)
        self.cross = np.empty((len(matrices), Q, T))  # (R, Q, T)
        for r, (W, Y) in enumerate(zip(matrices, targets)):
            np.matmul(W.T, W, out=self.gram[r])
            self.gram[r] /= W.shape[0]
            np.matmul(W.T, Y, out=self.cross[r])
            self.cross[r] /= W.shape[0]
        self.square = np.stack([np.einsum("nt,nt->t", Y, Y) / Y.shape[0] for Y in targets])  # (R, T)
        # per target: each varying column against all columns, against each varying column (itself included), and
        # against the target; all varying columns of a run in one product
        self.varying = np.array(sorted(varying or {}), dtype=int)  # (k,) column indices
        if self.varying.size:
            against, mutual, cross = [], [], []
            for r, (W, Y) in enumerate(zip(matrices, targets)):
                V = np.stack([varying[q][r] for q in self.varying], axis=2)  # (n, T, k)
                n, T, k = V.shape
                against.append((V.reshape(n, T * k).T @ W).reshape(T, k, -1) / n)  # (T, k, Q)
                mutual.append(np.einsum("ntk,ntj->tkj", V, V) / n)  # (T, k, k)
                cross.append(np.einsum("ntk,nt->tk", V, Y) / n)  # (T, k)
            self._against, self._mutual, self._cross = np.stack(against), np.stack(mutual), np.stack(cross)

    @property
    def n_runs(self) -> int:
        return self.gram.shape[0]

    def score(self, specs: list[Spec]) -> Scores:
        """Score models with equal numbers of columns (batched).

        A model with strength-law columns (:attr:`Spec.scaled`) is scored twice: first with its columns as
        they are, which gives each run's strength factor with the effect riding on the block's strength
        (:attr:`Scores.profiled_scale`), then with each run's columns multiplied by that factor.  The effect
        is then c_r·(strength + Σ θ_j·column_j) per run, a block scatter of a few per cent multiplying a strong
        effect as it does in the material; with the columns unscaled that scatter times the effect (8 % of the
        strength on a gradient that doubles it) is a per-run misfit no shared coefficient removes, and another
        family with a per-run handle (a speed law, a plug) took the verdict (dev gradient-10 of seed 41000: its
        own exact shape left 69 % of the baseline's held-out error; with the block scatter set to 0, 5 %).
        """
        first = self._score_scaled(specs, None)
        idx = [i for i, s in enumerate(specs) if s.scaled]
        if not idx:
            return first
        second = self._score_scaled([specs[i] for i in idx], first.profiled_scale[idx])
        merged = {}
        for f in fields(Scores):
            values = getattr(first, f.name).copy()
            values[idx] = getattr(second, f.name)
            merged[f.name] = values
        merged["profiled_scale"] = first.profiled_scale
        return Scores(**merged)

    def _score_scaled(self, specs: list[Spec], run_scale: np.ndarray | None) -> Scores:
        """:meth:`score` with the ``scaled`` columns of model m multiplied, on run r, by ``run_scale[m, r]``."""
        varying = set(self.varying.tolist())
        touched = [i for i, s in enumerate(specs) if varying.intersection((*s.columns, s.offset))]

        def part(idx):
            return None if run_scale is None else run_scale[idx]

        if not touched:
            return self._score(specs, self.gram, self.cross, self.square, run_scale)
        fixed = [i for i in range(len(specs)) if i not in touched]
        parts = [(fixed, self._score([specs[i] for i in fixed], self.gram, self.cross, self.square, part(fixed)))
                 ] if fixed else []
        per_target = []
        G = self.gram.copy()  # the varying rows and columns are overwritten for each target in turn
        q = self.varying
        for t in range(self.cross.shape[2]):  # a model with a varying column: its Gram differs per target
            C = self.cross[:, :, t:t + 1].copy()
            G[:, q, :] = self._against[:, t]
            G[:, :, q] = np.swapaxes(self._against[:, t], 1, 2)
            G[:, q[:, None], q[None, :]] = self._mutual[:, t]
            C[:, q, 0] = self._cross[:, t]
            per_target.append(self._score([specs[i] for i in touched], G, C, self.square[:, t:t + 1], part(touched),
                                          profile=t == 0))
        # targets side by side; the folds and scales are the measured data's (target 0) alone
        parts.append((touched, Scores(**{f.name: getattr(per_target[0], f.name) if f.name in _DATA_ONLY else
                                         np.concatenate([getattr(s, f.name) for s in per_target], axis=-1)
                                         for f in fields(Scores)})))
        order = np.argsort(np.concatenate([np.array(idx) for idx, _ in parts]))
        return Scores(**{f.name: np.concatenate([getattr(s, f.name) for _, s in parts], axis=0)[order]
                         for f in fields(Scores)})

    def fold_coefficients(self, spec: Spec) -> np.ndarray:
        """(runs, 3 + k, targets): the shared coefficients of the fold that leaves each run out, on every target
        (the data and each replicate), of a model with neither strength-law nor varying columns (the
        baseline's).  For figures: the scores keep the data's alone."""
        varying = set(self.varying.tolist())
        if spec.scaled or varying.intersection((*spec.columns, spec.offset)):
            raise ValueError("fold coefficients per target are kept for a model without strength-law or varying "
                             "columns")
        kept: list[np.ndarray] = []
        self._score([spec], self.gram, self.cross, self.square, profile=False, keep=kept)
        return np.stack([theta[0] for theta in kept], axis=0)

    def _score(self, specs: list[Spec], G: np.ndarray, C: np.ndarray, S: np.ndarray,
               run_scale: np.ndarray | None = None, profile: bool = True, keep: list | None = None) -> Scores:
        """Score ``specs`` on the targets of ``C``; the strength factors are profiled (:func:`_profiled_scale`)
        only on a first, unscaled pass over the measured data (``profile``): the second pass's are not used."""
        J = np.array([s.columns for s in specs])  # (M, p)
        off = np.array([s.offset for s in specs])  # (M,)
        mask = np.zeros(J.shape, dtype=bool)  # (M, p): the strength-law columns
        for m, spec in enumerate(specs):
            mask[m, list(spec.scaled)] = True
        scale = np.ones((self.n_runs, len(specs)))
        if run_scale is not None and mask.any():
            scale = np.asarray(run_scale, dtype=float).T  # (R, M)
        s = np.where(mask[None], scale[:, :, None], 1.0)  # (R, M, p)
        R, M, p, T = self.n_runs, len(specs), J.shape[1], C.shape[2]
        D, Dr = np.empty((R, M, p, p)), np.empty((R, M, p - 1, p - 1))
        cr, ttr, c0, c_data = np.empty((R, M, p - 1, T)), np.empty((R, M, T)), np.empty((R, M, T)), np.empty((R, M, p))
        _sliced(_profiled_pieces, R * M, np.ascontiguousarray(G), np.ascontiguousarray(C), np.ascontiguousarray(S),
                J, off, s, D, Dr, cr, ttr, c0, c_data)
        d00 = np.maximum(D[:, :, 0, 0], 1e-300)[..., None]  # (R, M, 1)
        A_all, b_all, t_all = Dr.sum(0), cr.sum(0), ttr.sum(0)
        bounded = np.column_stack([np.ones((len(specs), N_BOUNDED), dtype=bool), self.nonnegative[J[:, 1 + N_BOUNDED:]]])
        q = p - 1
        # every fold (leave run k out) of every model in one batch, then the all-runs fit
        A_fold, b_fold = A_all[None] - Dr, b_all[None] - cr  # (R, M, q, q), (R, M, q, T)
        theta_fold = bounded_solve(A_fold.reshape(R * M, q, q), b_fold.reshape(R * M, q, T),
                                   np.tile(bounded, (R, 1))).reshape(R, M, q, T)
        if keep is not None:
            keep.extend(theta_fold)
        folds = np.moveaxis(theta_fold[..., 0], 0, 1)  # (M, R, q): the measured data's target
        heldout = np.moveaxis(_quadratic(Dr, cr, ttr, theta_fold), 0, 1)
        data = slice(0, 1)  # the measured data's target
        train = np.moveaxis(_quadratic(A_fold, b_fold[..., data], t_all[None, :, data] - ttr[..., data],
                                       theta_fold[..., data]), 0, 1) / (R - 1)
        theta = bounded_solve(A_all, b_all, bounded)
        total = _quadratic(A_all, b_all, t_all, theta) / R
        # strength factors: cs_i = (c_i0 − D_i0,rest · θ) / D_i00
        strength = (c0 - np.einsum("rmq,mqt->rmt", D[:, :, 0, 1:], theta)) / d00
        profiled = (_profiled_scale(D, c_data, theta[..., 0], strength[..., 0], mask)
                    if profile and run_scale is None else np.ones((len(specs), self.n_runs)))
        return Scores(heldout, train, total, theta, np.moveaxis(strength, 0, 1), folds, scale.T, profiled)


@njit(cache=True, nogil=True, error_model="numpy")
def _profiled_pieces(lo: int, hi: int, G: np.ndarray, C: np.ndarray, S: np.ndarray, J: np.ndarray, off: np.ndarray,
                     s: np.ndarray, D: np.ndarray, Dr: np.ndarray, cr: np.ndarray, ttr: np.ndarray, c0: np.ndarray,
                     c_data: np.ndarray) -> None:
    """Per run r and model m (columns ``J[m]``, offset ``off[m]``, column factors ``s[r, m]``), from the run's
    Gram ``G`` (R, Q, Q), cross products ``C`` (R, Q, T) and squares ``S`` (R, T), in place: the model's Gram
    ``D`` (R, M, p, p) and, with the run's own strength factor (column 0) profiled out by a Schur complement,
    the reduced Gram ``Dr``, cross products ``cr`` with the target t = y − w_off, and |t|² ``ttr``; ``c0`` (R, M, T)
    is column 0's cross product, ``c_data`` (R, M, p) every column's on the measured data (target 0); the pairs
    (r, m) numbered r·M + m from ``lo`` to ``hi``."""
    R, M, p, _ = D.shape
    T = C.shape[2]
    for index in range(lo, hi):
        r, m = index // M, index % M
        o = off[m]
        for a in range(p):
            for b in range(p):
                D[r, m, a, b] = G[r, J[m, a], J[m, b]] * s[r, m, a] * s[r, m, b]
        d00 = max(D[r, m, 0, 0], 1e-300)
        for a in range(1, p):
            for b in range(1, p):
                Dr[r, m, a - 1, b - 1] = D[r, m, a, b] - D[r, m, a, 0] * D[r, m, 0, b] / d00
        g_off = G[r, o, o]
        for t in range(T):
            first = (C[r, J[m, 0], t] - G[r, J[m, 0], o]) * s[r, m, 0]
            for a in range(1, p):
                ca = (C[r, J[m, a], t] - G[r, J[m, a], o]) * s[r, m, a]
                cr[r, m, a - 1, t] = ca - D[r, m, a, 0] * first / d00
                if t == 0:
                    c_data[r, m, a] = ca
            ttr[r, m, t] = (S[r, t] - 2 * C[r, o, t] + g_off) - first ** 2 / d00
            c0[r, m, t] = first
        c_data[r, m, 0] = c0[r, m, 0]


_DATA_ONLY = {"train", "folds", "run_scale", "profiled_scale"}
"""Fields of :class:`Scores` that are the measured data's alone (no target axis)."""


def _profiled_scale(D: np.ndarray, c: np.ndarray, theta: np.ndarray, strength: np.ndarray, mask: np.ndarray
                    ) -> np.ndarray:
    """(models, runs): each run's strength factor, relative to the runs' mean, with a model's strength-law columns
    (``mask``, (M, p)) riding on it: the least-squares c_r of c_r·(w₀ + Σ γ_j w_j) against the run's target less
    its other terms, γ_j = θ_j / mean(cs) from the all-runs fit.  Not the fit's own cs, in which the effect's
    mean over the run's depths or speeds is added to the block's scatter, amplified on runs that go deep.
    1 for a model without such columns, or where a run's factor comes out non-positive.

    ``D`` (R, M, p, p) and ``c`` (R, M, p) are the per-run Gram and cross products of the model's columns;
    ``theta`` (M, p − 1) the all-runs shared coefficients; ``strength`` (R, M) the per-run strength factors.
    """
    R, M, p, _ = D.shape
    out = np.ones((M, R))
    rows = np.flatnonzero(mask.any(axis=1))
    if rows.size == 0:
        return out
    mean_cs = strength[:, rows].mean(axis=0)  # (m,)
    full = np.concatenate([np.zeros((M, 1)), theta], axis=1)[rows]  # (m, p): column 0 is the run's own
    m_mask = mask[rows]
    a = np.where(m_mask, full / np.where(np.abs(mean_cs) > 0, mean_cs, 1.0)[:, None], 0.0)
    a[:, 0] = 1.0  # u = w₀ + Σ γ_j w_j
    b = np.where(m_mask, 0.0, full)  # the other terms, at their shared coefficients
    b[:, 0] = 0.0
    Dm, cm = D[:, rows], c[:, rows]  # (R, m, p, p), (R, m, p)
    uu = np.einsum("mp,rmpq,mq->rm", a, Dm, a)
    ut = np.einsum("mp,rmp->rm", a, cm) - np.einsum("mp,rmpq,mq->rm", a, Dm, b)
    k = ut / np.maximum(uu, 1e-300)  # (R, m)
    ok = np.all(np.isfinite(k) & (k > 0), axis=0) & (mean_cs > 0)
    rel = k / k.mean(axis=0)
    out[rows[ok]] = rel[:, ok].T
    return out


def heldout_residuals(matrices: list[np.ndarray], targets: list[np.ndarray], spec: Spec,
                      folds: np.ndarray, run_scale: np.ndarray | None = None) -> list[np.ndarray]:
    """Each run's residual when the model ``spec`` is fitted without it (``folds``: (runs, 3 + k) from
    :attr:`Scores.folds`; ``run_scale``: (runs,) from :attr:`Scores.run_scale`, multiplying the spec's
    ``scaled`` columns); the run's own strength factor is refitted, as in the scores. [N]"""
    out = []
    for r, (W, y, theta) in enumerate(zip(matrices, targets, folds)):
        X = W[:, list(spec.columns)]
        if spec.scaled and run_scale is not None:
            X[:, list(spec.scaled)] *= run_scale[r]
        rest = y - W[:, spec.offset] - X[:, 1:] @ theta
        s = X[:, 0]
        out.append(rest - (float(s @ rest) / max(float(s @ s), 1e-300)) * s)
    return out


def heldout_residuals_every(matrices: list[np.ndarray], targets: list[np.ndarray], spec: Spec,
                            folds: np.ndarray) -> list[np.ndarray]:
    """:func:`heldout_residuals` on every target at once (``targets``: per run (n, T); ``folds``: (runs, 3 + k, T)
    from :meth:`Statistics.fold_coefficients`): per run (n, T). [N]"""
    out = []
    for W, Y, theta in zip(matrices, targets, folds):
        X = W[:, list(spec.columns)]
        rest = Y - W[:, spec.offset][:, None] - X[:, 1:] @ theta
        s = X[:, 0]
        out.append(rest - np.outer(s, (s @ rest) / max(float(s @ s), 1e-300)))
    return out


def _quadratic(A: np.ndarray, b: np.ndarray, tt: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """|t − Xθ|² from Gram pieces: tt − 2 θ·b + θᵀAθ, per model (any leading axes: A (..., q, q), b and θ
    (..., q, T), tt (..., T)) and target."""
    q, T = theta.shape[-2:]
    out = np.empty(tt.shape)
    _sliced(_quadratics, out.size // T, np.ascontiguousarray(A).reshape(-1, q, q),
            np.ascontiguousarray(b).reshape(-1, q, T), np.ascontiguousarray(tt).reshape(-1, T),
            np.ascontiguousarray(theta).reshape(-1, q, T), out.reshape(-1, T))
    return out


@njit(cache=True, nogil=True, error_model="numpy")
def _quadratics(lo: int, hi: int, A: np.ndarray, b: np.ndarray, tt: np.ndarray, theta: np.ndarray,
                out: np.ndarray) -> None:
    """:func:`_quadratic` compiled for models ``lo`` to ``hi`` (no (models, q, targets) temporaries)."""
    q, T = theta.shape[1:]
    for m in range(lo, hi):
        for t in range(T):
            acc = tt[m, t]
            for i in range(q):
                Ax = 0.0
                for j in range(q):
                    Ax += A[m, i, j] * theta[m, j, t]
                acc -= theta[m, i, t] * (2.0 * b[m, i, t] - Ax)
            out[m, t] = acc


MAX_COEFFICIENTS = 62
"""Coefficients a bounded solve takes at most: a free set is kept as the bits of a signed 64-bit integer."""

FACTOR_SLOTS = 24
"""Factorisations kept per system (the last sets solved on): a system's targets end on a dozen or two sets."""

SET_PASSES = 8
"""Free sets tried on all of a system's remaining targets at once before the rest are solved one at a time: a
system's replicates mostly end on a few sets (a null's noise moves a coefficient across its bound), and a
pass costs one factorisation and a substitution per target; more passes find sets that few targets share."""


def bounded_solve(A: np.ndarray, b: np.ndarray, bounded: np.ndarray | None = None) -> np.ndarray:
    """Minimise ½ θᵀAθ − bᵀθ per model (A: (M, q, q); b: (M, q, T)) with θ ≥ 0 where ``bounded`` (M, q) says
    so (default: θ[:3] ≥ 0, P, C, K): the bounded least-squares optimum.

    Columns are scaled to unit diagonal and a tiny ridge keeps empty columns
    (a layer below every run's depth) at zero, so each system is positive
    definite and its optimum unique.  :func:`_bounded_optima` finds it,
    compiled, one system per thread: fix the negative bounded coefficients
    at 0 and refit the rest until none is negative, then, as Lawson and
    Hanson's active set, free a coefficient held at 0 whose gradient says
    the objective falls if it rises, until none does.  (The first stage
    alone ends above the optimum in 306 of 2,317 random systems, on a vertex
    that follows the last bits of near-collinear columns, so verdicts would
    move with the BLAS kernel.)
    """
    M, q, _ = A.shape
    if q > MAX_COEFFICIENTS:
        raise ValueError(f"a bounded solve of {q} coefficients: at most {MAX_COEFFICIENTS}")
    if bounded is None:
        bounded = np.zeros((M, q), dtype=bool)
        bounded[:, :N_BOUNDED] = True
    theta = np.empty(b.shape)
    _sliced(_bounded_optima, M, np.ascontiguousarray(A, dtype=float), np.ascontiguousarray(b, dtype=float), theta,
            np.ascontiguousarray(bounded))
    return theta


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _factor(A: np.ndarray, passive: np.ndarray, lu: np.ndarray, pivots: np.ndarray, index: np.ndarray) -> int:
    """LU factors (partial pivoting) of A's rows and columns that ``passive`` marks, in place in ``lu`` with the
    row swaps in ``pivots`` and the coefficients' positions in ``index``; returns their number."""
    q = A.shape[0]
    n = 0
    for i in range(q):
        if passive[i]:
            index[n] = i
            n += 1
    for a in range(n):
        for c in range(n):
            lu[a, c] = A[index[a], index[c]]
    for col in range(n):
        pivot = col
        for r in range(col + 1, n):
            if abs(lu[r, col]) > abs(lu[pivot, col]):
                pivot = r
        pivots[col] = pivot
        if pivot != col:
            for c in range(n):
                lu[col, c], lu[pivot, c] = lu[pivot, c], lu[col, c]
        for r in range(col + 1, n):
            lu[r, col] /= lu[col, col]
            factor = lu[r, col]
            for c in range(col + 1, n):
                lu[r, c] -= factor * lu[col, c]
    return n


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _substitute(lu: np.ndarray, pivots: np.ndarray, index: np.ndarray, n: int, b: np.ndarray, rhs: np.ndarray,
                out: np.ndarray) -> None:
    """``out`` = the solution over the factored coefficients (:func:`_factor`) of A θ = b, 0 elsewhere."""
    for a in range(n):
        rhs[a] = b[index[a]]
    for col in range(n):
        pivot = pivots[col]
        if pivot != col:
            rhs[col], rhs[pivot] = rhs[pivot], rhs[col]
    for r in range(n):  # unit lower triangle
        acc = rhs[r]
        for c in range(r):
            acc -= lu[r, c] * rhs[c]
        rhs[r] = acc
    for r in range(n - 1, -1, -1):
        acc = rhs[r]
        for c in range(r + 1, n):
            acc -= lu[r, c] * rhs[c]
        rhs[r] = acc / lu[r, r]
    for i in range(out.shape[0]):
        out[i] = 0.0
    for a in range(n):
        out[index[a]] = rhs[a]


@njit(cache=True, nogil=True, error_model="numpy")
def _solve_on(A: np.ndarray, b: np.ndarray, passive: np.ndarray, keys: np.ndarray, lus: np.ndarray,
              pivots: np.ndarray, index: np.ndarray, sizes: np.ndarray, rhs: np.ndarray, out: np.ndarray) -> None:
    """``out`` = the solution of A θ = b over the coefficients ``passive`` marks, 0 elsewhere.  The factors of the
    last ``FACTOR_SLOTS`` sets are kept: ``keys`` (slots,) each slot's set as bits (−1 none), ``lus``, ``pivots``,
    ``index`` its factors (:func:`_factor`), ``sizes`` (slots + 1,) its number of free coefficients and, last, the
    slot the next new set overwrites."""
    key = 0
    for i in range(A.shape[0]):
        if passive[i]:
            key |= 1 << i
    slots = keys.shape[0]
    k = -1
    for j in range(slots):
        if keys[j] == key:
            k = j
            break
    if k < 0:
        k = sizes[slots]
        sizes[slots] = (k + 1) % slots
        sizes[k] = _factor(A, passive, lus[k], pivots[k], index[k])
        keys[k] = key
    _substitute(lus[k], pivots[k], index[k], sizes[k], b, rhs, out)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _slot(passive: np.ndarray, keys: np.ndarray) -> int:
    """The slot of :func:`_solve_on`'s kept factors that holds the set ``passive`` marks (−1: none)."""
    key = 0
    for i in range(passive.shape[0]):
        if passive[i]:
            key |= 1 << i
    for j in range(keys.shape[0]):
        if keys[j] == key:
            return j
    return -1


@njit(cache=True, nogil=True, error_model="numpy")
def _bounded_optima(lo: int, hi: int, A_all: np.ndarray, b_all: np.ndarray, theta: np.ndarray,
                    bounded: np.ndarray) -> None:
    """``theta`` (M, q, T) = each system's minimiser of ½ θᵀAθ − bᵀθ with θ ≥ 0 where ``bounded``, found in the
    system's unit-diagonal coordinates with a ridge of 10⁻¹⁰ (:func:`bounded_solve`), for systems ``lo`` to
    ``hi`` (a slice of :func:`_sliced`).

    Within one system, a target is solved
    alone (:func:`_bounded_target`), and the set of coefficients it ends
    with free is every pending target's first guess, solved for all of them
    at once on that set's factors (:func:`_substitute_all`).  A target whose
    solution there meets the optimality conditions (no bounded free
    coefficient negative, no held coefficient's gradient b − Aθ positive
    beyond 10⁻¹² of its largest |b|) has its optimum, to the last digit of
    the one-target path from that set; the first of the others starts the
    next pass (``SET_PASSES`` of them: a null's noise moves a coefficient
    across its bound, and a system's replicates end on a dozen or so sets),
    and what the passes leave is solved one target at a time, each from the
    set the previous one ended with.  The optimum is unique (the ridge), so
    the starting set changes the path, not the answer; the last
    ``FACTOR_SLOTS`` sets' factors are kept (:func:`_solve_on`).

    Only the smallest helpers are inlined; the others, the factorisation
    included (:func:`_solve_on`), are called: with every helper inlined the
    kernel took 87 s to compile on this two-core machine (once per fresh
    install, and in each test worker), called 9 s, for about 20 % more time
    in the kernel.
    """
    for m in range(lo, hi):
        _bounded_system(A_all[m], b_all[m], theta[m], bounded[m])


@njit(cache=True, nogil=True, error_model="numpy")
def _bounded_system(A_all: np.ndarray, b_all: np.ndarray, theta: np.ndarray, bounded: np.ndarray) -> None:
    """One system of :func:`_bounded_optima`: ``theta`` (q, T) from ``A_all`` (q, q), ``b_all`` (q, T)."""
    q, T = theta.shape
    scale = np.empty(q)
    for i in range(q):
        scale[i] = math.sqrt(max(A_all[i, i], 0.0))
        if scale[i] == 0.0:
            scale[i] = 1.0
    A = np.empty((q, q))
    for i in range(q):
        for j in range(q):
            A[i, j] = A_all[i, j] / scale[i] / scale[j] + (1e-10 if i == j else 0.0)
    B = np.empty((q, T))
    for i in range(q):
        for t in range(T):
            B[i, t] = b_all[i, t] / scale[i]
    b = np.empty(q)
    keys = np.full(FACTOR_SLOTS, -1, dtype=np.int64)
    lus = np.empty((FACTOR_SLOTS, q, q))
    pivots = np.empty((FACTOR_SLOTS, q), dtype=np.int64)
    index = np.empty((FACTOR_SLOTS, q), dtype=np.int64)
    sizes = np.zeros(FACTOR_SLOTS + 1, dtype=np.int64)
    passive = np.ones(q, dtype=np.bool_)
    rhs = np.empty(q)
    x = np.empty(q)
    s = np.empty(q)
    pending = np.arange(T)
    free = passive.copy()
    for _ in range(SET_PASSES):
        if pending.size == 0:
            break
        # the first pending target alone, from the last set; the set it ends with is every other's first guess
        first = pending[0]
        for i in range(q):
            b[i] = B[i, first]
        _bounded_target(A, b, bounded, passive, x, s, keys, lus, pivots, index, sizes, rhs)
        for i in range(q):
            theta[i, first] = x[i] / scale[i]
            free[i] = passive[i]
        rest = pending[1:]
        _solve_on(A, b, free, keys, lus, pivots, index, sizes, rhs, s)  # its factors: kept, or made here
        k = _slot(free, keys)
        X = _substitute_all(lus[k], pivots[k], index[k], sizes[k], B, rest)
        keep = _not_optimal_on(A, B, bounded, free, X, rest, scale, theta)
        pending = rest[keep]
    for t in pending:  # what the passes left: one at a time, each from the set the previous ended with
        for i in range(q):
            b[i] = B[i, t]
        _bounded_target(A, b, bounded, passive, x, s, keys, lus, pivots, index, sizes, rhs)
        for i in range(q):
            theta[i, t] = x[i] / scale[i]


@njit(cache=True, nogil=True, error_model="numpy")
def _not_optimal_on(A: np.ndarray, B: np.ndarray, bounded: np.ndarray, free: np.ndarray, X: np.ndarray,
                    columns: np.ndarray, scale: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Of the targets ``columns`` (B's columns, X's in that order) solved on the set ``free``: which miss the
    optimality conditions (a bounded free coefficient negative, or a held one whose gradient b − Aθ is positive
    beyond 10⁻¹² of the target's largest |b|).  The others' solutions are written to ``theta`` (q, T), unscaled."""
    q = A.shape[0]
    missed = np.zeros(columns.size, dtype=np.bool_)
    for k in range(columns.size):
        t = columns[k]
        largest = 0.0
        for i in range(q):
            largest = max(largest, abs(B[i, t]))
        tol = 1e-12 * max(largest, 1e-300)
        for i in range(q):
            if bounded[i]:
                if free[i]:
                    if X[i, k] < 0.0:
                        missed[k] = True
                else:
                    w = B[i, t]
                    for c in range(q):
                        w -= A[i, c] * X[c, k]
                    if w > tol:
                        missed[k] = True
        if not missed[k]:
            for i in range(q):
                theta[i, t] = X[i, k] / scale[i]
    return missed


@njit(cache=True, nogil=True, error_model="numpy")
def _substitute_all(lu: np.ndarray, pivots: np.ndarray, index: np.ndarray, n: int, B: np.ndarray,
                    columns: np.ndarray) -> np.ndarray:
    """(q, len(columns)): :func:`_substitute` on the ``columns`` of ``B`` at once, each column's operations in the
    same order as there (the same numbers), the targets innermost."""
    q = B.shape[0]
    T = columns.size
    R = np.empty((n, T))
    for a in range(n):
        for k in range(T):
            R[a, k] = B[index[a], columns[k]]
    for col in range(n):
        pivot = pivots[col]
        if pivot != col:
            for t in range(T):
                R[col, t], R[pivot, t] = R[pivot, t], R[col, t]
    for r in range(n):  # unit lower triangle
        for c in range(r):
            f = lu[r, c]
            for t in range(T):
                R[r, t] -= f * R[c, t]
    for r in range(n - 1, -1, -1):
        for c in range(r + 1, n):
            f = lu[r, c]
            for t in range(T):
                R[r, t] -= f * R[c, t]
        d = lu[r, r]
        for t in range(T):
            R[r, t] = R[r, t] / d
    X = np.zeros((q, T))
    for a in range(n):
        for t in range(T):
            X[index[a], t] = R[a, t]
    return X


@njit(cache=True, nogil=True, error_model="numpy")
def _bounded_target(A: np.ndarray, b: np.ndarray, bounded: np.ndarray, passive: np.ndarray, x: np.ndarray,
                    s: np.ndarray, keys: np.ndarray, lus: np.ndarray, pivots: np.ndarray, index: np.ndarray,
                    sizes: np.ndarray, rhs: np.ndarray) -> None:
    """``x`` = the optimum for one target ``b``, from the free set ``passive`` (updated in place to the optimum's):
    solve on that set; fix the negative bounded coefficients at 0 and solve again, until none is negative (a
    feasible point, optimal on its free set); then Lawson–Hanson from there (:func:`_lawson_hanson`)."""
    q = A.shape[0]
    _solve_on(A, b, passive, keys, lus, pivots, index, sizes, rhs, x)
    for _ in range(q):  # fix the negatives at 0 until none is negative
        grew = False
        for i in range(q):
            if bounded[i] and passive[i] and x[i] < 0.0:
                passive[i] = False
                grew = True
        if not grew:
            break
        _solve_on(A, b, passive, keys, lus, pivots, index, sizes, rhs, x)
    _lawson_hanson(A, b, bounded, passive, x, s, keys, lus, pivots, index, sizes, rhs)


@njit(cache=True, nogil=True, error_model="numpy")
def _lawson_hanson(A: np.ndarray, b: np.ndarray, bounded: np.ndarray, passive: np.ndarray, x: np.ndarray,
                   s: np.ndarray, keys: np.ndarray, lus: np.ndarray, pivots: np.ndarray, index: np.ndarray,
                   sizes: np.ndarray, rhs: np.ndarray) -> None:
    """From the feasible point ``x`` (optimal on its free set ``passive``), in place: free the held coefficient
    whose gradient b − Aθ is most positive, solve, step back to the bounds where a member comes out ≤ 0, until
    no held coefficient's gradient is positive (relative 10⁻¹²); at most 3q entries of 3q steps each."""
    q = A.shape[0]
    scale_b = 0.0
    for i in range(q):
        scale_b = max(scale_b, abs(b[i]))
    tol = 1e-12 * max(scale_b, 1e-300)
    for _outer in range(3 * q):  # free a held coefficient whose gradient is positive
        best, enter = tol, -1
        for j in range(q):
            if bounded[j] and not passive[j]:
                w = b[j]
                for c in range(q):
                    w -= A[j, c] * x[c]
                if w > best:
                    best, enter = w, j
        if enter < 0:
            break
        passive[enter] = True
        for _inner in range(3 * q):
            _solve_on(A, b, passive, keys, lus, pivots, index, sizes, rhs, s)
            alpha, leave = 1.0, -1
            for i in range(q):
                if bounded[i] and passive[i] and s[i] <= 0.0:
                    step = x[i] / (x[i] - s[i]) if x[i] > s[i] else 0.0
                    if leave < 0 or step < alpha:
                        alpha, leave = step, i
            if leave < 0:
                for i in range(q):
                    x[i] = s[i]
                break
            for i in range(q):
                x[i] += alpha * (s[i] - x[i])
            x[leave] = 0.0
            for i in range(q):
                if bounded[i] and passive[i] and x[i] <= 0.0:
                    passive[i] = False
                    x[i] = 0.0
