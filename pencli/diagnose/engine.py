r"""Diagnosing the sim-to-real gap: where the model and the runs part, which effect, how far it closes.

Two views of each run:

- **resistance view**: Eq. 9 driven by the *measured* depth and speed,
  against the measured resistance (flight and penetration window).  A gap
  here lies in the resistance law or the force chain.
- **drive view**: measured against predicted contact speed.  A gap here lies
  on the drive side (the launcher).

Baseline: Eq. 9 with one strength factor per run (blocks scatter in
strength), shared P, C, K ≥ 0.  Every catalogue effect is a family of shapes
(:mod:`pencli.diagnose.effects`); each is added in turn, its coefficients
fitted on training runs, its shape the one of least held-out error on the
other folds, and scored on the run left out.

**Every decision is calibrated on the campaign at hand.**  Null replicates
of the campaign (:mod:`pencli.diagnose.null`: the baseline re-measured
through the campaign's own noise, encoder and derivative chain) go through
the same scoring.  For each statistic the data's value is compared with its
null distribution:

- an effect is significant when its held-out improvement, standardised by
  its own null spread, exceeds the null distribution of the *largest* such
  score over all effects (a family-wise test; Gumbel tail);
- once one is, the verdict names first the effect that improves the data's
  held-out error most among the significant ones and those whose
  improvement is beyond every replicate's (:func:`_named_first`): the test
  says whether an effect is there, the fit which one;
- the resistance view has a gap the runs share when a generic profile (any
  force profile in depth, or in time since contact, common to the runs)
  closes part of the baseline's misfit on held-out runs beyond what it
  closes on the replicates (:data:`~pencli.diagnose.effects.PROBES`; Gumbel
  tail over the probes); the absolute gap (``gap_z``) is reported, not used:
  a slight mismatch of the noise model would pass for a gap;
- the drive view has a gap when contact speeds fall below prediction by more
  than their scatter allows, after the measurement bias the replicates show
  (one-sided t-test), and the launcher loss fitted to them brings the
  predicted motion closer to the measured one (a loss that makes it worse
  explains nothing);
- a force drift joins a verdict that names another effect when the rest
  after the stops shows it (:mod:`pencli.diagnose.rest`: the drift family
  fitted to the change of the resting force, against noise made from each
  run's pre-trigger spectrum, at the effects' per-test rate).  It makes no
  verdict alone, so the rate on campaigns without effect stays the three's.

The campaign's false-alarm rate ``false_alarm`` is split equally between the
three.  One constant is a definition, not a tuning: an effect (or pair)
*explains* a gap when it removes at least half of its excess over the null
floor (:data:`EXPLAIN_SHARE`).
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import asdict, dataclass, field, replace
from functools import cached_property
from typing import Callable, Mapping, Sequence

import numpy as np

from pencli.diagnose import BOOTSTRAP, FALSE_ALARM, WORKERS  # the defaults live in the light package module (CLI)
from pencli.diagnose.effects import (EFFECTS, INDISTINGUISHABLE, PROBES, Basis, Effect, Member, _RunView, basis_of,
                                     column_strength_factor, surfaces, views)
from pencli.diagnose.linear import (MAX_COEFFICIENTS, Spec, Statistics, compiled_threads, heldout_residuals,
                                   heldout_residuals_every)
from pencli.diagnose import plan
from pencli.diagnose.rest import rest_drift
from pencli.diagnose.null import (ModelMotion, NoiseModel, PendingReplicates, RunNull, corner_spreads, fit_noise,
                                  gev_quantile, gumbel_quantile, normal_quantile, read_noise_chain, start_replicates,
                                  student_quantile)
from pencli.errors import FitError, ModelError, PenNotice
from pencli.filter.tare import Events
from pencli.fit.resistance import with_coefficients
from pencli.model.dynamics import flight_of, simulate
from pencli.model.geometry import BLADE, force_steps_at_contact
from pencli.run import Run

EXPLAIN_SHARE = 0.5
"""An effect (or a pair) explains a misfit when it removes at least this share of the misfit's excess over the
null floor; one that removes less and leaves a gap its own null would not is no explanation, whatever the
misfit's shape (shared by the runs, different in each, intermittent or one-sided)."""
CANDIDATES = 3
"""An ``unexplained`` verdict's notes name this many of the best catalogue candidates with their shares."""
AMBIGUITY_Z = 1.96
"""Effects whose held-out improvements differ by less than this many null standard deviations are alike."""

TESTS = 3
"""The campaign's false-alarm rate is split equally between this many tests: the effects, the shared misfit's
probes and the drive view. [–]"""
TAIL_REACH = 5.0
"""How far past its replicates the family-wise threshold may reach before a diagnosis says so: each of the three
tests runs at a third of the false-alarm rate, B replicates see the largest score's law down to a tail
probability of about 1/B, and a threshold further out than this factor rests on the fitted tail law alone
(40 replicates at 1/3000, 75 × past them: a threshold of 42 z where the Gumbel's was 9.9). [–]"""

ROUND_OFF = 1e-9
"""Products that are 1 in exact arithmetic may come out this far below it in floating point. [–]"""
CONTACT_PHASE_S = 3e-3
"""The misfit's ``contact`` phase: the first milliseconds in the material (CONTRACT §4's "first few ms"). [s]"""
REST_PHASE_S = (20e-3, 150e-3)
"""The misfit's ``rest`` phase after the stop: from when the stop's force step has settled to before a long
record's end. [s]"""
MIN_REST_SAMPLES = 10
"""A run shows its rest phase only with more samples of it than this. [–]"""
MIN_PHASE_SHARE = 0.05
"""A phase holding less than this share of the misfit's excess over the null floor is not listed in ``where``."""
AXIS_BINS = 20
"""Quantile bins of each axis the misfit is read along (``axes``); at least two samples a bin. [–]"""
RUN_DEPTH_BINS = 4
"""Quantile bins of each run's own depth profile in the ``run`` axis: coarse, so that a profile fitted to one
run's noise takes little (4 bins a run over thousands of samples). [–]"""
RUN_PROFILE_DEGREE = RUN_DEPTH_BINS - 1
"""Each run's own depth profile (:func:`_own_run_columns`): Legendre polynomials of degree 1 to this in the run's
depth in the material; degree 0 is the run's strength factor, which every model fits already.  As coarse as the
``run`` axis's bins: a misfit that differs from run to run over tens of millimetres, not one run's noise. [–]"""
MIN_TRAJECTORY_SAMPLES = 4
"""A simulated trajectory with fewer samples cannot be interpolated onto a run's clock. [–]"""

Progress = Callable[[str, float], None]


def tail_reach_notice(false_alarm: float, bootstrap: int) -> str | None:
    """What to tell a user whose ``false_alarm`` rate asks more of ``bootstrap`` null replicates than
    :data:`TAIL_REACH` allows (None when it does not)."""
    alpha = false_alarm / TESTS
    if alpha * bootstrap * TAIL_REACH >= 1.0 - ROUND_OFF:
        return None
    enough = math.ceil(1.0 / (alpha * TAIL_REACH) - 1e-9)
    return (f"--false-alarm {false_alarm:g} with --bootstrap {bootstrap}: each test's threshold lies "
            f"{1.0 / (alpha * bootstrap):.0f} × beyond what the replicates see and rests on the fitted tail law; "
            f"--bootstrap {enough} or more would see within {TAIL_REACH:g} × of it")


# ----------------------------------------------------------------------------- the candidate matrix
@dataclass
class _Columns:
    """All distinct candidate columns of all runs on their analysis samples."""

    per_run: list[list[np.ndarray]]
    keys: dict
    nonnegative: list[bool] = field(default_factory=list)
    """Per column: its coefficient is ≥ 0 in every model (the sign its effect's meaning fixes)."""

    def add(self, cols: Sequence[np.ndarray], nonnegative: bool = False) -> int:
        """Register one column (one array per run); returns its index (shared when already present)."""
        key = (hash(b"".join(c.tobytes() for c in cols)), nonnegative)
        if key not in self.keys:
            self.keys[key] = len(self.per_run[0])
            self.nonnegative.append(nonnegative)
            for run_cols, c in zip(self.per_run, cols):
                run_cols.append(c)
        return self.keys[key]

    def matrices(self) -> list[np.ndarray]:
        return [np.column_stack(cols) for cols in self.per_run]


@dataclass(frozen=True)
class _Candidate:
    member: Member
    spec: Spec


def _register(columns: _Columns, bases: Sequence[Basis], runs: Sequence[_RunView], uses, member: Member,
              base_spec: Spec, measured: Sequence[np.ndarray], varying: dict) -> _Candidate:
    """Register a member's columns.  A member that reads the acceleration is built from ``measured`` (per run,
    (context samples, targets): the data's acceleration, then each replicate's), its columns are the data's
    (target 0) and their per-target values go into ``varying`` (column index → one (n × T) array per run)."""
    if member.reads_acceleration:
        built = [member.columns(run, replace(basis, a=a)) for run, basis, a in zip(runs, bases, measured)]
    else:
        built = [member.columns(run, basis) for run, basis in zip(runs, bases)]

    def add(values: Sequence[np.ndarray], nonnegative: bool = False) -> int:
        """One column from its values per run: (n,), or (n, T) for a member that reads the acceleration."""
        if not member.reads_acceleration:
            return columns.add([v[u] for v, u in zip(values, uses)], nonnegative)
        q = columns.add([v[u, 0] for v, u in zip(values, uses)], nonnegative)
        varying[q] = [v[u] for v, u in zip(values, uses)]
        return q

    extra = [add([b.extra[:, j] for b in built], member.nonnegative) for j in range(built[0].extra.shape[1])]
    base = list(base_spec.columns)
    if built[0].base is not None:
        base = [columns.add([b.base[:, j][u] for b, u in zip(built, uses)]) for j in range(4)]
    offset = base_spec.offset
    if built[0].offset is not None:
        offset = add([b.offset for b in built])
    scaled = tuple(4 + j for j in member.strength_columns(len(extra)))
    return _Candidate(member, Spec(tuple(base + extra), offset, scaled))


def _fold_reach(bases: Sequence[Basis], uses: Sequence[np.ndarray]) -> float:
    """The depth every leave-one-run-out fold's training runs reach: the second-deepest run's deepest analysis
    sample (:attr:`~pencli.diagnose.effects.Member.reach_m`). [m]"""
    deepest = sorted(float(np.max(b.x[u], initial=0.0)) for b, u in zip(bases, uses))
    return deepest[-2]


def _measured_acceleration(basis: Basis, replicate: np.ndarray) -> np.ndarray:
    """(context samples, 1 + replicates): the data's acceleration, then each replicate's (``replicate``: its
    span, which starts where the context does; past the span, which no analysis sample reaches, the data's).
    [m/s²]"""
    out = np.repeat(basis.a[:, None], 1 + replicate.shape[1], axis=1)
    k = min(out.shape[0], replicate.shape[0])
    out[:k, 1:] = replicate[:k]
    return out


def _combine(a: _Candidate, b: _Candidate, base_spec: Spec) -> Spec | None:
    """Columns of two effects together (None when both replace the Eq. 9 columns)."""
    a_base = a.spec.columns[:len(TERMS)] != base_spec.columns or a.spec.offset != base_spec.offset
    b_base = b.spec.columns[:len(TERMS)] != base_spec.columns or b.spec.offset != base_spec.offset
    if a_base and b_base:
        return None
    lead = a if a_base else b
    shift = len(a.spec.columns) - 4  # b's extra columns follow a's
    return Spec(lead.spec.columns[:4] + a.spec.columns[4:] + b.spec.columns[4:], lead.spec.offset,
                a.spec.scaled + tuple(q + shift for q in b.spec.scaled))


# ----------------------------------------------------------------------------- scoring
@dataclass(frozen=True)
class _Family:
    """An effect's score on every target: per fold the member of least held-out error on the other folds,
    scored on the fold's held-out run."""

    per_run: np.ndarray
    """(runs, targets) the held-out mean squared residual of each run under its fold's choice. [N²]"""
    best: int
    """Index (into the candidates) of the member best on all runs, measured data."""
    chosen: list[int]
    """Per fold, the member chosen (measured data)."""

    @property
    def heldout(self) -> np.ndarray:
        """(targets,) mean over runs of the held-out mean squared residual. [N²]"""
        return self.per_run.mean(axis=0)


def _score_family(stats: Statistics, specs: Sequence[Spec], absent: np.ndarray | None = None,
                  admissible: Callable[[int, dict], bool] | None = None) -> tuple[_Family, dict]:
    """Score the members of one family (or of pairs) and pick members per fold and target.

    ``absent``: (runs, targets) the held-out mean squares of the model without the family, which then counts
    as one more choice of each fold: a fold whose other folds are fitted better without any member scores as
    the model without it (the family's size zero).  Given in the pair tests, where the second effect's
    columns beside the first's are often nearly collinear with them: on null replicates each member then
    extrapolates wildly to some held-out run, on more than half of them (dev pair-10 of ``--pairs 12 99500
    --drift-friction``: a velocity friction beside a drift, median improvement −37 N², to −159,000 N², against
    +96 N² on the data), which put the null's MAD at 46 N² and hid a friction that removed all of the drift's
    remainder.
    """
    groups: dict[int, list[int]] = {}
    for i, spec in enumerate(specs):
        groups.setdefault(len(spec.columns), []).append(i)
    n_targets = stats.cross.shape[2]
    heldout = np.empty((len(specs), stats.n_runs, n_targets))
    total = np.empty((len(specs), n_targets))
    coefficients: dict[int, np.ndarray] = {}
    strength: dict[int, np.ndarray] = {}
    for idx in groups.values():
        scores = stats.score([specs[i] for i in idx])
        heldout[idx], total[idx] = scores.heldout, scores.total
        for j, i in enumerate(idx):
            coefficients[i] = scores.coefficients[j]
            strength[i] = scores.strength[j]
    # each fold's member: the one whose held-out error on the other folds is least (not its training fit, which
    # favours the members with most columns however they extrapolate to a run they did not see)
    choices = heldout if absent is None else np.concatenate([heldout, absent[None]])
    others = choices.sum(axis=1, keepdims=True) - choices  # (members, runs, targets)
    pick = np.argmin(others, axis=0)  # (runs, targets)
    per_fold = np.take_along_axis(choices, pick[None], axis=0)[0]  # (runs, targets)
    best = _best_admissible(total[:, 0], coefficients, strength, admissible)
    members = np.argmin(others[:len(specs), :, 0], axis=0)  # the shapes reported: members only
    family = _Family(per_fold, best, [int(k) for k in members])
    return family, {"coefficients": coefficients[best], "strength": strength[best]}


def _best_admissible(total: np.ndarray, coefficients: Mapping[int, np.ndarray], strength: Mapping[int, np.ndarray],
                     admissible: Callable[[int, dict], bool] | None) -> int:
    """The member whose all-runs fit is best (``total``: each member's mean square on the data) among those
    ``admissible`` accepts (its index and fit); the best of all when none is."""
    if admissible is None:
        return int(np.argmin(total))
    order = np.argsort(total, kind="stable")
    for i in order:
        if admissible(int(i), {"coefficients": coefficients[int(i)], "strength": strength[int(i)]}):
            return int(i)
    return int(order[0])


@dataclass(frozen=True)
class _Tested:
    """A family scored against a reference model, with its standardised improvement."""

    family: _Family
    fit: dict
    z: float
    centre: float
    """Null median of the held-out improvement. [N²]"""
    scale: float
    """Null scale of it (:func:`_standardise`). [N²]"""


def _familywise(stats: Statistics, reference: np.ndarray, families: Mapping[str, Sequence[Spec]], alpha: float,
                absent: np.ndarray | None = None, admissible: Mapping[str, Callable[[int, dict], bool]] | None = None
                ) -> tuple[dict[str, _Tested], float]:
    """Score each family's held-out improvement over ``reference`` (held-out mean squares, data then null
    replicates) and the threshold its z must beat (:func:`familywise_threshold`); ``absent``: the reference per
    run, a choice of every fold (:func:`_score_family`)."""
    tested = {}
    floor = _score_floor(reference, stats)
    for name, specs in families.items():
        family, fit = _score_family(stats, specs, absent, (admissible or {}).get(name))
        tested[name] = _Tested(family, fit, *_standardise(reference - family.heldout, floor))
    if not tested:
        return tested, math.inf
    improvements = np.column_stack([reference - t.family.heldout for t in tested.values()])
    return tested, familywise_threshold(improvements, floor, alpha)


def _improves(reference: np.ndarray, tested: _Tested) -> bool:
    """Whether a tested family lowers the data's held-out error below ``reference``'s (target 0).

    The z says how far the data's improvement stands above the null replicates'; where the replicates' fits get
    much worse with the family (it extrapolates badly to held-out null runs), a family that makes the data's fit
    worse too can stand above them.  That is no evidence of the family: an effect present in the data lowers the
    data's held-out error.  (With the window ending 1 ms before the hard stops, tried and not kept, the
    suite's propulsion-loss campaign was called `unexplained` by a depth profile at
    z 3.78 against 3.77 that made the data's held-out error 21 % worse.)"""
    return float(reference[0]) > float(tested.family.heldout[0])


def _counts(reference: np.ndarray, tested: _Tested, threshold: float) -> bool:
    """Whether a tested family (an effect, or a generic profile) counts: its z beats ``threshold`` and it lowers
    the data's held-out error (:func:`_improves`)."""
    return tested.z > threshold and _improves(reference, tested)


def _shared_gap(reference: np.ndarray, probes: Mapping[str, _Tested], threshold: float) -> bool:
    """Whether the runs share a misfit: a generic profile counts (:func:`_counts`)."""
    return any(_counts(reference, t, threshold) for t in probes.values())


def _score_floor(reference: np.ndarray, stats: Statistics) -> float:
    """Held-out mean squares (or their differences) below this resolve nothing: the solver's round-off, or the
    change a coefficient fitted to the noise alone makes (:func:`noise_resolution`), whichever is larger. [N²]

    It floors the null scale an improvement is standardised by.  A sign-bounded family sits at its bound on
    nearly every replicate, and their improvements then spread by round-off alone: on a development null
    (``bench_null_ranks 40 121000``, null-1) a sidewall pressure growth gained 1.4·10⁻⁴ N² on the data, a
    shrink of 0.003 %, against a null scale of 1.9·10⁻⁶ N², and was called at z 74; the noise (1.6 N before
    the trigger, 15,184 samples over 6 runs) resolves no change below about 1.7·10⁻⁴ N² (z 0.84 with it)."""
    return max(1e-9 * float(np.median(np.abs(reference))), stats.resolution)


def noise_resolution(levels_n: Sequence[float], samples: Sequence[int]) -> float:
    """The change of a held-out score (a mean over runs of each run's mean squared residual) that one coefficient
    fitted to white noise makes, on its smaller side: σ²/N, the noise's mean variance over the runs, over the
    samples of all of them.  Fitted on the other runs, the coefficient's variance is about σ²/(N·G) for a column
    of mean square G, and it moves the held-out run's score by its square times G and by its product with the
    held-out run's own noise; simulated, the typical change is 1–4 × σ²/N (2.4 × on six runs of unequal noise,
    ``tests/test_diagnose_core.py``). [N²]"""
    total = int(np.sum(samples))
    return float(np.mean(np.square(levels_n))) / total if total > 0 else 0.0


def _share_of_remainder(reference: np.ndarray, better: np.ndarray, S0: np.ndarray) -> float:
    """Share that ``better`` removes of what ``reference`` leaves above the null floor (data, target 0)."""
    remainder = float(reference[0]) - float(np.mean(S0[1:]))
    return (float(reference[0]) - float(better[0])) / remainder if remainder > 0 else 0.0


HELD_OUT_SCALE_GUARD = 0.5
"""A replicate's scale without it is kept at least this fraction of the scale with it (a numerical guard, see
:func:`familywise_threshold`). [–]"""


def familywise_threshold(improvements: np.ndarray, floor: float, alpha: float) -> float:
    """The z the data's largest standardised improvement must beat: the upper ``alpha`` quantile of the largest
    z over the families (columns) on the null replicates (rows 1…; row 0 is the data), one test for the whole
    set.  The quantile is the larger of a Gumbel fitted by moments and a generalised extreme-value law fitted by
    probability-weighted moments (:func:`gev_quantile`): where the largest z has a heavy tail (a sign-bounded
    family fitting on a few replicates) the Gumbel falls short.  By simulation at 1/300 with 200 replicates and
    11 families (``python -m bench.bench_null_calibration 1500 7 --engine``, the same draws for both rules):
    false alarms 1.40 → 0.20 % on a point mass with 5 % χ²₁, 0.60 → 0.13 % on t₃, 0.13 % either way on normal
    and χ²₁.  Where the tail is bounded the GEV's lower quantile is not used.

    Each replicate is standardised as the data is, by the *other* replicates' centre and scale
    (:func:`_standardise`): the data's z is out of sample, and standardising the replicates by a scale they
    helped set narrows their tail (by simulation, 11 families and 60 replicates at ``alpha`` 1 %, 400 trials:
    false alarms 1.5, 5.8, 3.8 and 13.8 % with normal, χ²₁, t₃ and point-mass nulls in sample, 0.8, 2.0, 2.0
    and 8.8 % out of sample; ``python -m bench.bench_null_calibration 400 1``).  A replicate's scale without it is kept
    at :data:`HELD_OUT_SCALE_GUARD` of the scale with all of them or more, so that a family with one fitting
    replicate among a point mass cannot stand that replicate a million z out and blind the test to every
    family.
    """
    largest = replicate_z(improvements, floor).max(axis=0)
    return max(gumbel_quantile(largest, alpha), gev_quantile(largest, alpha))


def replicate_z(improvements: np.ndarray, floor: float) -> np.ndarray:
    """(families, replicates): each null replicate's z (rows 1… of ``improvements``), standardised by the
    *other* replicates' centre and scale, kept at :data:`HELD_OUT_SCALE_GUARD` of the scale with all of them or
    more (see :func:`familywise_threshold`)."""
    null = improvements[1:].T  # (families, replicates)
    n = null.shape[1]
    others = null[:, None, :].repeat(n, axis=1)[:, ~np.eye(n, dtype=bool)].reshape(null.shape[0], n, n - 1)
    centre, scale = _null_scale(others, floor)  # (families, replicates): each replicate without itself
    full = _null_scale(null, floor)[1]
    return (null - centre) / np.maximum(scale, HELD_OUT_SCALE_GUARD * full[:, None])


def _rest_evidence(runs: Sequence[_RunView], nulls: Sequence[RunNull], effect: Effect, bootstrap: int, seed: int,
                   alpha: float) -> dict | None:
    """``effect`` (a force drift) as the rest after each run's stop shows it
    (:func:`pencli.diagnose.rest.rest_drift`): its z against the campaign's own noise, the family-wise threshold
    at ``alpha``, and the shape and change it reads.  None when no run rests long enough after its stop."""
    members = effect.members
    test = rest_drift(runs, members, [n.noise for n in nulls], bootstrap, seed)
    if test is None:
        return None
    floor = noise_resolution([n.noise.level_n for n in nulls], [test.samples])
    z = _standardise(test.improvements, floor)[0]
    threshold = familywise_threshold(test.improvements[:, None], floor, alpha)
    return {"z": round(z, 2), "threshold": round(float(threshold), 3), "significant": bool(z > threshold),
            "runs": test.runs, "samples": test.samples, "shape": dict(members[test.member].params),
            "rms_n": round(float(np.sqrt(max(test.improvements[0], 0.0))), 4)}


# ----------------------------------------------------------------------------- drive side
def _predicted_contact_speed(run: _RunView, loss: float = 0.0) -> float:
    design = replace(run.design, efficiency=run.design.efficiency * (1.0 - loss))
    return flight_of(design).reach(design.surface_offset_m)[1]


DRIVE_LAWS = ("efficiency", "guide_friction")
"""How a launcher loses energy before contact, each a one-parameter law of the runs' contact-speed deficits
1 − (v/v̂)² (:func:`deficit_laws`); the drive view tests each and keeps the stronger (Bonferroni over the laws)."""


def deficit_laws(runs: Sequence[_RunView], predicted: np.ndarray) -> dict[str, np.ndarray]:
    """Per law, the deficit 1 − (v/v̂)² each run's contact speed shows per unit of the law's parameter: a share of
    the energy the launcher delivers ([–]: 1 in every run), or a friction force on the moving body over its travel
    from release to the surface ([1/N]: 2·L/(m·v̂²), L the travel, m the moving mass; the slowest runs lose the
    largest share, so a friction shows as a spread of deficits across spring counts, not as their mean)."""
    travel = np.array([r.design.surface_offset_m for r in runs])
    mass = np.array([r.design.effective_mass_kg for r in runs])
    return {"efficiency": np.ones(len(runs)),
            "guide_friction": 2.0 * travel / (mass * np.maximum(predicted, SPEED_FLOOR_M_S) ** 2)}


def _law_t(deficits: np.ndarray, unit: np.ndarray, measurement: float) -> tuple[float, float]:
    """(size, one-sided t) of a law: its parameter fitted by least squares to the deficits, against the
    residuals' scatter or the deficits' measurement error (per run), whichever is larger."""
    weight = float(unit @ unit)
    size = float(unit @ deficits) / weight
    scatter = math.sqrt(float(np.sum((deficits - size * unit) ** 2)) / (deficits.size - 1))
    return size, size / (max(scatter, measurement, T_FLOOR) / math.sqrt(weight))


def _dynamic_rms(run: _RunView, values: Mapping[str, float], loss: float = 0.0) -> tuple[float, float]:
    """RMS of measured − fully predicted resistance over the run's window, launched with efficiency × (1 − loss):
    in the material (the prediction's clock shifted so that its contact falls on the run's measured contact), and
    on the clock from release. [N]

    The first is what a launcher loss is judged on: a loss of another form than efficiency (a friction on the
    push rod) slows the flight otherwise, so the right contact speed comes at another time, and a comparison
    on the clock from release would read the flight's timing as a misfit in the material."""
    design = replace(with_coefficients(run.design, values), efficiency=run.design.efficiency * (1.0 - loss))
    result = simulate(design, output_rate_hz=run.rate_hz, rtol=1e-8, geometry=run.geometry)
    traj = result.trajectory
    w = run.window
    measured = run.resistance_n[w]
    out = []
    for t in (run.time_s[w] - run.contact_s + result.summary.contact_time_s, run.time_s[w]):
        r = np.interp(t, traj.time_s, traj.resistance_n)
        r[t > traj.time_s[-1]] = float(traj.resistance_n[-1]) if result.summary.end in ("arrest", "creep") else 0.0
        r[t < result.summary.contact_time_s] = 0.0
        out.append(float(np.sqrt(np.mean((measured - r) ** 2))))
    return out[0], out[1]


# ----------------------------------------------------------------------------- the report
@dataclass(frozen=True)
class EffectReport:
    """One catalogue effect, scored."""

    name: str
    side: str
    view: str
    """``resistance`` or ``drive``: which held-out RMS it is scored on."""
    params: dict
    intervals: dict
    heldout_rms_n: float
    shrink_pct: float
    significant: bool
    z: float = 0.0
    """Held-out improvement in null standard deviations (drive: the t statistic of the speed deficit)."""
    explained_share: float | None = None
    """Share of the gap's excess over the null floor that the effect removes."""
    detectable_rms_n: float | None = None
    """Smallest RMS this effect could leave after the baseline refit and still be found at the false-alarm rate. [N]"""
    trajectory_change: dict = field(default_factory=dict)
    axis: str = ""
    """What this effect's misfit follows (the registry's; compare the diagnosis' measured ``axes``)."""

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class Diagnosis:
    """What ``pen diagnose`` found (CONTRACT §4)."""

    runs: tuple[str, ...]
    baseline: dict
    where: tuple[dict, ...]
    effects: tuple[EffectReport, ...]
    verdict: str
    verdict_effects: tuple[str, ...]
    ambiguities: tuple[dict, ...]
    noise_floor_n: float
    notes: tuple[str, ...] = ()
    success: bool = True
    message: str = ""
    decision: dict = field(default_factory=dict)
    """False-alarm rate, thresholds found on the null replicates, and the null's figures."""
    axes: dict = field(default_factory=dict)
    """Share of the baseline's held-out misfit that organises along depth, speed, time since contact, acceleration."""
    series: tuple[dict, ...] = ()
    """Per run, for figures: time_s, depth_m, time_since_contact_s and the held-out residual [N] of the
    baseline and of the verdict's first effect; where the run rests after its stop, that span's time since
    contact and force less what holds the blade (``rest_time_since_contact_s``, ``rest_residual_n``; not in the
    JSON)."""
    suggestions: dict = field(default_factory=dict)
    """The next runs that would best tell the leading candidates apart (``diagnose(suggest=N)``;
    :mod:`pencli.diagnose.plan`): ``candidates``, ``runs`` (each a :class:`~pencli.diagnose.plan.Suggestion`),
    ``own_runs_separation_sigma`` and ``note``; empty when not asked for."""
    profiles: dict = field(default_factory=dict)
    """For figures, along ``depth_mm`` and ``time_since_contact_ms``: bin centres, samples per bin, the data's
    binned held-out residual under the baseline (``baseline_n``) and with the verdict's effect (``effect_n``),
    the band 95 % of the null replicates' binned means fall in (``null_low_n``, ``null_high_n``), and the
    lowest and highest run's binned fitted force of the effect, ``baseline_n − effect_n`` run by run
    (``force_low_n``, ``force_high_n``) [N] (not in the JSON)."""

    def to_dict(self) -> dict:
        return {
            "runs": list(self.runs),
            "baseline": self.baseline,
            "where": list(self.where),
            "effects": [e.to_dict() for e in self.effects],
            "verdict": self.verdict,
            "verdict_effects": list(self.verdict_effects),
            "ambiguities": list(self.ambiguities),
            "noise_floor_n": self.noise_floor_n,
            "decision": self.decision,
            "axes": self.axes,
            "detection_limits_rms_n": {e.name: e.detectable_rms_n for e in self.effects
                                       if e.detectable_rms_n is not None},
            "notes": list(self.notes),
            **({"suggestions": self.suggestions} if self.suggestions else {}),
        }


# ----------------------------------------------------------------------------- where and along what
def _residual_series(runs, uses, residuals):
    out = []
    for run, use, res in zip(runs, uses, residuals):
        c = run.context
        t = run.time_s[c][use]
        out.append((run, t, run.depth_m[c][use] - run.surface_m, np.maximum(run.velocity_m_s[c][use], 0.0),
                    run.acceleration_m_s2[c][use], res))
    return out


def _rest_residual(run: _RunView) -> tuple[np.ndarray, np.ndarray] | None:
    """The run's ``rest`` phase (:data:`REST_PHASE_S` after the stop) as (mask of the record's samples, force
    less what holds the blade there: the springs and the weight after an arrest, nothing after a hard stop [N]);
    None with too few samples."""
    rest = (run.time_s > run.stop_s + REST_PHASE_S[0]) & (run.time_s < run.stop_s + REST_PHASE_S[1])
    if rest.sum() <= MIN_REST_SAMPLES:
        return None
    d = run.design
    x_end = float(np.median(run.depth_m[rest]))
    held = (d.drive_stiffness_n_m * max(d.stroke_m - x_end - d.surface_offset_m, 0.0)
            + d.effective_mass_kg * d.gravity_m_s2) if run.end == "arrest" else 0.0
    return rest, run.resistance_n[rest] - held


def _where(series, floor_sq: float) -> list[dict]:
    """Split the baseline's held-out misfit by phase, with depth, time and speed bands."""
    phases: dict[str, dict[str, list]] = {}
    for run, t, x, v, _, res in series:
        phase = np.where(t < run.contact_s, "flight",
                         np.where(t < run.contact_s + CONTACT_PHASE_S, "contact", "penetration"))
        for name in ("flight", "contact", "penetration"):
            sel = phase == name
            if sel.any():
                d = phases.setdefault(name, {"r": [], "t": [], "x": [], "v": [], "tc": []})
                for key, values in (("r", res), ("t", t), ("x", x), ("v", v), ("tc", t - run.contact_s)):
                    d[key].append(values[sel])
        rest = _rest_residual(run)
        if rest is not None:
            mask, r = rest
            d = phases.setdefault("rest", {"r": [], "t": [], "x": [], "v": [], "tc": []})
            d["r"].append(r)
            d["t"].append(run.time_s[mask])
            d["x"].append(run.depth_m[mask])
            d["v"].append(np.zeros(int(mask.sum())))
            d["tc"].append(run.time_s[mask] - run.contact_s)
    excess = {}
    for name, d in phases.items():
        r = np.concatenate(d["r"])
        excess[name] = max(float(np.sum(r ** 2)) - r.size * floor_sq, 0.0)
    total = sum(excess.values())
    out = []
    for name, d in phases.items():
        if total <= 0 or excess[name] / total < MIN_PHASE_SHARE:
            continue
        r, t, x, v, tc = (np.concatenate(d[k]) for k in ("r", "t", "x", "v", "tc"))
        weight = r ** 2
        band = _dense_band(x, weight) if name not in ("flight", "rest") else None
        time_band = _dense_band(t, weight)
        rms = float(np.sqrt(np.mean(r ** 2)))
        out.append({
            "phase": name,
            "depth_mm": None if band is None else [round(band[0] * 1e3, 1), round(band[1] * 1e3, 1)],
            "time_ms": [round(time_band[0] * 1e3, 2), round(time_band[1] * 1e3, 2)],
            "time_since_contact_ms": [round(float(np.min(tc)) * 1e3, 2), round(float(np.max(tc)) * 1e3, 2)],
            "speed_m_s": [round(float(np.min(v)), 2), round(float(np.max(v)), 2)],
            "rms_n": rms,
            "share_of_gap": round(excess[name] / total, 3),
            "above_noise": bool(rms ** 2 > floor_sq),
        })
    out.sort(key=lambda item: -item["share_of_gap"])
    return out


def _quantile_bins(values: np.ndarray, bins: int) -> np.ndarray:
    """Each value's bin among ``bins`` quantile bins of ``values`` (fewer where values repeat)."""
    edges = np.unique(np.quantile(values, np.linspace(0, 1, bins + 1)))
    return np.clip(np.searchsorted(edges, values, side="right") - 1, 0, max(edges.size - 2, 0))


def _binned_means(bins: np.ndarray, res: np.ndarray) -> np.ndarray:
    """The mean of ``res`` in each sample's bin."""
    counts = np.bincount(bins)
    return (np.bincount(bins, weights=res) / np.maximum(counts, 1))[bins]


def _axes(series) -> dict:
    """Share of the baseline's held-out misfit explained by its mean along each axis (20 quantile bins), and
    ``run``: the share that differs from run to run (each run's own depth profile, in :data:`RUN_DEPTH_BINS`
    quantile bins, of what the runs' shared depth profile leaves).

    Computed over the penetration samples (flight vs penetration is its own
    entry): the axis with the largest share is what the misfit follows.
    """
    parts = {"depth": [], "speed": [], "time_since_contact": [], "acceleration": [], "residual": [], "run": []}
    flight_ss = pen_ss = 0.0
    for k, (run, t, x, v, a, res) in enumerate(series):
        inside = t >= run.contact_s
        flight_ss += float(np.sum(res[~inside] ** 2))
        pen_ss += float(np.sum(res[inside] ** 2))
        for key, values in (("depth", x), ("speed", v), ("time_since_contact", t - run.contact_s),
                            ("acceleration", a), ("residual", res)):
            parts[key].append(values[inside])
        parts["run"].append(np.full(int(np.count_nonzero(inside)), k))
    res = np.concatenate(parts.pop("residual"))
    run = np.concatenate(parts.pop("run"))
    out = {"flight_share": round(flight_ss / max(flight_ss + pen_ss, 1e-300), 3)}
    ss = float(np.sum(res ** 2))
    if res.size < AXIS_BINS * 2 or ss <= 0:
        return out
    for key, chunks in parts.items():
        means = _binned_means(_quantile_bins(np.concatenate(chunks), AXIS_BINS), res)
        out[key] = round(float(np.sum(means ** 2)) / ss, 3)
    depth = np.concatenate(parts["depth"])
    left = res - _binned_means(_quantile_bins(depth, AXIS_BINS), res)
    cells = run * RUN_DEPTH_BINS + np.concatenate([_quantile_bins(depth[run == k], RUN_DEPTH_BINS)
                                                   for k in np.unique(run)])
    out["run"] = round(float(np.sum(_binned_means(cells, left) ** 2)) / ss, 3)
    return out


def _dense_band(values: np.ndarray, weight: np.ndarray, share: float = 0.8) -> tuple[float, float]:
    """The narrowest value range holding ``share`` of the weight (sorted, two-pointer)."""
    order = np.argsort(values)
    v, w = values[order], weight[order]
    cum = np.concatenate([[0.0], np.cumsum(w)])
    total = cum[-1]
    if total <= 0:
        return float(v[0]), float(v[-1])
    best = (float(v[0]), float(v[-1]))
    j = 0
    for i in range(v.size):
        while j < v.size and cum[j + 1] - cum[i] < share * total:
            j += 1
        if j >= v.size:
            break
        if v[j] - v[i] < best[1] - best[0]:
            best = (float(v[i]), float(v[j]))
    return best


def _effect_force(member: Member, coefficients, own: Mapping[str, float], values: Mapping[str, float]):
    """``design -> f(x [m], v [m/s]) [N]``: a law effect's fitted force on any design, on the Eq. 9 coefficients
    ``own`` of the fit with it in; its strength columns were built at the baseline's (``values``) strength
    factor (:func:`~pencli.diagnose.effects.column_strength_factor`)."""
    at = dict(own, strength_factor_of_columns=column_strength_factor(values["strength_factor"]))
    return lambda design, geometry=BLADE: member.force(coefficients, design, at, geometry)


TRAJECTORY_RTOL = 1e-8
"""Tolerance of the trajectory-change simulations: their figures are reported to 0.1 % and 0.1 mm. [–]"""
TRAJECTORY_EVALUATIONS = 20_000
"""Evaluations a trajectory-change simulation may take: a run's penetration takes a few hundred, and a fitted
force that holds the blade creeping towards a rest depth (the model's creep rule does not apply with an effect's
force) took the whole default budget (2·10⁶ evaluations, four minutes of a 4.5-minute diagnosis) for a side
note. [–]"""


def _trajectory_change(effect: Effect, member: Member | None, coefficients, runs: Sequence[_RunView],
                       values: Mapping[str, float], loss: float | Mapping[str, float] = 0.0,
                       own_values: Mapping[str, float] | None = None) -> dict:
    """Change of the CONTRACT §5 figures of the median-speed run from the baseline's dynamic model to the
    effect's: the fit with the effect in (``own_values``: its mean strength factor, P, C and K) and the
    effect's force.

    The baseline's coefficients absorb part of a strong effect; with the effect's force added to them it is
    counted twice (a 2 mm plug on the sim rig: the baseline stopped the blade 13 mm short of the measured
    depth, and the plug's force on top of it 27 mm short)."""
    if effect.side == "chain":
        return {"note": "a measurement effect: the trajectory does not change"}
    run = sorted(runs, key=lambda r: r.contact_speed_m_s)[len(runs) // 2]
    loss = loss.get(run.run_id, 0.0) if isinstance(loss, Mapping) else loss  # a drive loss: that run's share
    base_design = with_coefficients(run.design, values)
    budget = dict(rtol=TRAJECTORY_RTOL, max_evaluations=TRAJECTORY_EVALUATIONS, geometry=run.geometry)
    try:
        before = simulate(base_design, **budget).summary
        if effect.side == "drive":
            after = simulate(replace(base_design, efficiency=base_design.efficiency * (1 - loss)), **budget).summary
        else:
            own = values if own_values is None else own_values
            force = _effect_force(member, coefficients, own, values)(run.design, run.geometry)
            after = simulate(with_coefficients(run.design, own), extra_resistance=force, **budget).summary
    except ModelError as exc:  # the effect's fitted force can make the motion one the model cannot finish
        return {"run": run.run_id, "note": f"the dynamic model with this effect did not finish: {exc}"}
    return {
        "run": run.run_id,
        "penetration_time_pct": 100 * (after.penetration_time_s / before.penetration_time_s - 1)
        if before.penetration_time_s > 0 else None,
        "final_depth_mm": after.final_depth_mm - before.final_depth_mm,
        "peak_resistance_pct": 100 * (after.peak_resistance_n / before.peak_resistance_n - 1)
        if before.peak_resistance_n > 0 else None,
    }


# ----------------------------------------------------------------------------- the diagnosis
def _own_values(fit: Mapping[str, np.ndarray]) -> dict:
    """The Eq. 9 coefficients (file units, CONTRACT §1 names) of a fit with an effect in: its mean strength
    factor, P, C and K."""
    coefficients = fit["coefficients"][:, 0]
    return {"strength_factor": float(np.mean(fit["strength"][:, 0])), "sidewall_pressure_kpa": float(coefficients[0]),
            "damping_kpa_s_m": float(coefficients[1]), "inertia_coefficient": float(coefficients[2])}


def _own_context(context: Mapping[str, float], fit: Mapping[str, np.ndarray]) -> dict:
    """The reference values an effect's parameters are stated against, from the fit *with* that effect: its
    mean strength factor, P, C and K.  The baseline's own absorb part of a strong effect (a layer 1.8 × as strong
    over most of the depth raises every run's baseline strength factor, and the layer's ratio against that came
    out 1.52); ``cs_columns``, the strength factor a plug's strength column is built at
    (:func:`~pencli.diagnose.effects.column_strength_factor`), stays the baseline's."""
    strength, coefficients = fit["strength"][:, 0], fit["coefficients"][:, 0]
    own = dict(context)
    if float(np.mean(strength)) > 0:
        own["cs_mean"] = float(np.mean(strength))
    own.update(p_kpa=max(float(coefficients[0]), 1e-9), c_kpa_s_m=float(coefficients[1]), k=float(coefficients[2]))
    return own


def _null_of(run: _RunView, use_ctx: np.ndarray, fitted_ctx: np.ndarray, values: Mapping[str, float]
             ) -> RunNull:
    """A run's null-replicate recipe on the span from its context start to just past its stop.

    ``fitted_ctx``: the baseline resistance on the run's context span. [N]

    ``values``: the baseline's coefficients for this run (file units), whose dynamics give the replicates'
    motion in the material (:func:`_model_motion`).
    """
    t = run.time_s
    start = int(np.flatnonzero(run.context)[0])
    stop = int(np.searchsorted(t, run.stop_s)) + max(16, int(2e-3 * run.rate_hz))
    stop = min(stop, t.size)
    span = slice(start, stop)
    ts = t[span]
    use = np.zeros(ts.size, dtype=bool)
    ctx_idx = np.flatnonzero(run.context)
    use[ctx_idx[use_ctx] - start] = True
    events = Events(run.motion_start_s, run.contact_s, run.contact_speed_m_s, run.stop_s,
                    float(run.depth_m[min(stop, t.size) - 1]), run.end, run.window_start_s, run.window_end_s,
                    run.corners_s)
    at_rest = (ts < run.motion_start_s - 1.0 / run.rate_hz) | (ts > run.stop_s)
    pre = run.pre_trigger
    noise = fit_noise(run.resistance_n[pre])
    if noise.level_n == 0.0:
        noise = NoiseModel.white(max(run.noise_n, 1e-6))
    contact = run.seen_contact_s
    anti_alias, line = read_noise_chain(noise)
    baseline = np.zeros(ts.size)
    baseline[:fitted_ctx.size] = fitted_ctx[:ts.size]  # the context starts the span; nothing is analysed past it
    return RunNull(ts, run.depth_m[span], run.acceleration_m_s2[span], at_rest, use, fitted_ctx[use_ctx], events,
                   run.design.penetration_depth_m, run.encoder_step_m, run.load_cell_mass_kg, noise,
                   run.derivative_method, contact, _model_motion(run, contact, values),
                   anti_alias=anti_alias, noise_line=line, baseline_n=baseline,
                   contact_break=force_steps_at_contact(run.geometry, run.design))


def _model_motion(run: _RunView, contact_s: float, values: Mapping[str, float]) -> ModelMotion | None:
    """The baseline's own motion in the material from ``contact_s`` on, or None when the model does not move
    the blade.

    The encoder cannot resolve how the acceleration changes within a millisecond of contact or of the stop
    (at 0.1 mm steps a change of 20 m/s² over 0.5 ms moves the tip 2.5 µm); the smoothing spline through the
    record has its own shape there, which the data's true motion does not share.  Replicates made from the
    spline alone therefore miss the derivative error the data have near the ends of the penetration.  The
    reference model's dynamics, started where and as fast as the run met the material, give a motion with
    the jumps the physics puts there; the replicates are measured from it (each placed at its own contact,
    :func:`pencli.diagnose.null.replicate_run`), sampled 4 × as fast as the run so that it can be placed
    between samples.
    """
    i = int(np.searchsorted(run.time_s, contact_s))
    if not 0 < i < run.time_s.size:
        return None
    depth_c = float(run.depth_m[i])
    speed = float(run.velocity_m_s[i])
    if not speed > 0.0:
        return None
    design = replace(with_coefficients(run.design, values),
                     surface_offset_m=run.design.surface_offset_m + depth_c)  # the block's surface as met
    try:
        result = simulate(design, speed_at_contact_m_s=speed, output_rate_hz=4.0 * run.rate_hz, rtol=1e-8,
                          geometry=run.geometry)
    except ModelError:
        return None  # the replicates then come from the spline through the record
    if not result.success or result.trajectory.time_s.size < MIN_TRAJECTORY_SAMPLES:
        return None
    traj = result.trajectory
    return ModelMotion(traj.time_s, traj.depth_m, traj.acceleration_m_s2)


def _standardise(values: np.ndarray, floor: float = 0.0) -> tuple[float, float, float]:
    """(z of the data, null centre, null scale) of a statistic whose element 0 is the data and the rest the null.

    Centre: the median.  Scale: the larger of 1.4826 × MAD and the upper semi-deviation about the median
    (√(2·mean(max(v − median, 0)²)); both are σ for a normal null), and of ``floor``, the statistic's round-off.
    A false alarm comes from the null's upper tail only, and the two sides misbehave differently: a family nearly
    collinear with Eq. 9 sometimes extrapolates badly to a held-out run on null data, a long tail of *worse*
    scores below the median (one replicate at −10¹⁹ on dev varied-4 of seed 11000) that must not set the scale;
    a sign-bounded family sits at its bound on most replicates, gains exactly nothing there, and its MAD is the
    spread of that point mass while the replicates that do fit form the upper tail.  Standardised by the MAD
    alone, one such replicate stood 1,800 z out and put the family-wise threshold of every effect at 1,097 z
    (dev varied-16, seed 7000).  With the semi-deviation no replicate stands more than √(n/2) out.
    """
    centre, scale = _null_scale(values[1:], floor)
    return (float(values[0]) - float(centre)) / float(scale), float(centre), float(scale)


def _null_scale(null: np.ndarray, floor: float) -> tuple[np.ndarray, np.ndarray]:
    """(centre, scale) of :func:`_standardise` for each row of ``null`` (its last axis: the replicates)."""
    centre = np.median(null, axis=-1)
    deviation = null - centre[..., None]
    upper = np.maximum(deviation, 0.0)
    scale = np.maximum.reduce([1.4826 * np.median(np.abs(deviation), axis=-1),
                               np.sqrt(2.0 * np.mean(upper * upper, axis=-1)),
                               np.full_like(centre, floor), 1e-12 * np.abs(centre), np.full_like(centre, 1e-300)])
    return centre, scale


# ----------------------------------------------------------------------------- the stages
@dataclass(frozen=True)
class Request:
    """What the user asked for, checked: the effects to consider and how decisions are calibrated."""

    names: tuple[str, ...]
    false_alarm: float
    bootstrap: int
    seed: int
    workers: int
    suggest: int = 0
    """How many next runs to propose (0: none)."""

    @property
    def alpha(self) -> float:
        """Each of the :data:`TESTS` tests' share of the campaign's false-alarm rate."""
        return self.false_alarm / TESTS

    @property
    def drive_effect(self) -> str | None:
        """The asked-for effect on the launcher side (scored in the drive view), if any."""
        return next((n for n in self.names if EFFECTS[n].side == "drive"), None)

    @property
    def rest_effect(self) -> str | None:
        """The asked-for effect whose family is also looked for in the rest after the stops, if any."""
        return next((n for n in self.names if EFFECTS[n].rest_evidence), None)


@dataclass(frozen=True)
class Baseline:
    """Eq. 9 with a strength factor per run and shared P, C, K, fitted on the measured data of every run."""

    runs: tuple[_RunView, ...]
    """The runs, depth counted from each block's surface."""
    bases: tuple[Basis, ...]
    uses: tuple[np.ndarray, ...]
    """Per run, which context samples are analysed (flight and window)."""
    ys: tuple[np.ndarray, ...]
    """Per run, the measured resistance on those samples. [N]"""
    columns: _Columns
    """The candidate matrix: the baseline's columns, then every candidate's (added by the family scan)."""
    spec: Spec
    values: dict
    """The baseline's mean strength factor, P [kPa], C [kPa·s/m] and K (CONTRACT §1 names)."""
    strength_factors: np.ndarray
    shared: np.ndarray
    context: dict
    """What an effect's parameters are stated against (mean strength factor, P, load-cell mass)."""

    def run_values(self, k: int) -> dict:
        """The baseline's coefficients with run ``k``'s own strength factor."""
        return dict(self.values, strength_factor=float(self.strength_factors[k]))


@dataclass(frozen=True)
class NullCalibration:
    """The campaign's null replicates: the baseline re-measured through each run's own sensor chain; and the
    rest after the stops against the campaign's own noise (:func:`_rest_evidence`; None without a rest effect
    or a run resting long enough)."""

    nulls: tuple[RunNull, ...]
    pending: PendingReplicates
    rest: dict | None = None

    @cached_property
    def replicates(self) -> tuple:
        """Each run's replicates (waits for the processes making them)."""
        return tuple(self.pending.result())


@dataclass(frozen=True)
class FamilyScan:
    """Every resistance-view effect family and the generic probes, scored on the data and on each replicate."""

    law_effects: tuple[Effect, ...]
    candidates: dict
    matrices: list
    stats: Statistics
    S0: np.ndarray
    """The baseline's held-out mean square on the data (index 0) and on each replicate. [N²]"""
    z_gap: float
    floor_sq: float
    excess: float
    tested: dict
    z_threshold: float
    probes: dict
    gap_threshold: float
    z_probe: float
    resistance_gap: bool
    own_runs: tuple[int, ...] = ()
    """Column indices of each run's own depth profile (:func:`_own_run_columns`), run after run."""
    z_own: float | None = None
    """What each run's own depth profile takes from the baseline's residual, as a z against the replicates
    (:func:`own_columns_z`)."""
    run_gap: bool = False
    """Whether ``z_own`` beats ``run_threshold``: a misfit that differs from run to run (noted, not a gap)."""
    run_threshold: float = math.inf
    """The family-wise threshold over the two probes and the runs' own profiles, at least the probes' own."""
    targets: tuple = ()
    """Per run, (analysed samples, 1 + replicates): the measured resistance, then each replicate's. [N]"""
    varying: dict = field(default_factory=dict)
    """Column index → per run its values per target, for the columns that read the acceleration
    (:class:`~pencli.diagnose.linear.Statistics`)."""


@dataclass(frozen=True)
class DriveView:
    """Measured against predicted contact speeds, after the measurement bias the replicates show."""

    bias: np.ndarray
    ratios: np.ndarray
    t: float
    threshold: float
    gap: bool
    law: str
    """The law of :data:`DRIVE_LAWS` that the deficits follow best."""
    losses: np.ndarray
    """Each run's share of the launcher's energy lost before contact, by that law. [–]"""
    size: float
    """The law's parameter: the share lost [–], or the friction force [N]."""
    dynamic_rms_n: float | None = None
    """The baseline's fully predicted RMS in the material, where the drive effect was scored. [N]"""


@dataclass(frozen=True)
class Decision:
    """The verdict, the effects behind it, and the evidence the decision weighed."""

    verdict: str
    verdict_effects: tuple[str, ...]
    reports: dict
    notes: tuple[str, ...]
    top: EffectReport | None
    pair: dict | None
    naming: dict | None
    rest: dict | None
    ambiguities: tuple[dict, ...] = ()
    """The effects the verdict's first cannot be told from with these runs (:func:`_ambiguities`)."""


def diagnose(runs: Sequence[Run], *, effects: Sequence[str] | None = None,
             false_alarm: float = FALSE_ALARM, bootstrap: int = BOOTSTRAP, seed: int = 0, workers: int = WORKERS,
             suggest: int = 0, progress: Progress | None = None) -> Diagnosis:
    """Locate, explain and size the gap between the reference model and ``runs``.

    A pipeline of named stages, each taking and returning small frozen records: the request is checked, the
    baseline fitted (:func:`fit_baseline`), the null replicates made (:func:`calibrate_nulls`), every effect
    family and probe scored (:func:`scan_families`), the drive view read (:func:`read_drive`), each effect
    reported (:func:`report_effects`), the verdict decided (:func:`decide`), and the result located and
    assembled (:func:`locate`).

    Parameters
    ----------
    runs : conditioned runs (inertia stage; at least 3), e.g. a :class:`~pencli.run.Campaign`.
    effects : catalogue effects to consider (default all).
    false_alarm : probability that a campaign without effect gets a verdict other than ``none``.
    bootstrap : null replicates of the campaign (≥ :data:`MIN_BOOTSTRAP`).
    seed : seed of the replicates (the verdict is reproducible).
    workers : processes that make replicates, and threads of the compiled solves (the verdict does not depend
        on it).
    suggest : how many next runs to propose that would best tell the leading candidates apart
        (:func:`suggest_runs`; 0: none).
    progress : called with (stage, fraction done).
    """
    started = time.perf_counter()
    say = progress or (lambda stage, fraction: None)
    check_materials(runs)
    runs = views(runs)
    request = check_request(runs, effects, false_alarm, bootstrap, seed, workers, suggest)
    with compiled_threads(request.workers):
        return _diagnose(runs, request, say, started)


def _diagnose(runs: Sequence[_RunView], request: Request, say: Progress, started: float) -> Diagnosis:
    """The stages of :func:`diagnose`, in order."""
    say("baseline", PROGRESS["baseline"])
    baseline = fit_baseline(runs)
    say("null replicates", PROGRESS["null replicates"])
    nulls = calibrate_nulls(baseline, request)
    say("scoring effects", PROGRESS["scoring effects"])
    try:
        scan = scan_families(baseline, nulls, request)
    finally:
        nulls.pending.cancel()  # done by now, unless the scan failed
    say("scoring effects", PROGRESS["probes"])
    drive = read_drive(baseline, nulls, request)
    reports, drive = report_effects(baseline, scan, drive, request)
    say("pairs", PROGRESS["pairs"])
    decision = decide(baseline, nulls, scan, drive, reports, request)
    say("trajectories", PROGRESS["trajectories"])
    result = locate(baseline, nulls, scan, drive, decision, request, started)
    if request.suggest:
        say("suggesting runs", PROGRESS["suggesting runs"])
        result = replace(result, suggestions=suggest_runs(baseline, nulls, scan, decision, request))
    say("done", PROGRESS["done"])
    return result


PROGRESS = {"baseline": 0.0, "null replicates": 0.05, "scoring effects": 0.5, "probes": 0.85, "pairs": 0.88,
            "trajectories": 0.94, "suggesting runs": 0.97, "done": 1.0}
"""The share of a diagnosis's time done when each stage starts (for a progress bar). [–]"""
MIN_RUNS = 3
"""A run is held out and the rest must still fit the baseline's four shared terms and one factor per run."""
MIN_BOOTSTRAP = 20
"""Fewer null replicates cannot place a family-wise tail quantile at all. [–]"""


def check_materials(runs: Sequence[Run]) -> None:
    """One line when the runs were recorded in more than one material: the baseline shares P, C and K among the
    runs (only the strength factor is each run's), so another material's runs read as an effect (the example's
    grill brick and MPACS C runs together gave 'plug_growth with velocity_friction')."""
    counts: dict[str, int] = {}
    for run in runs:
        counts[run.material.name] = counts.get(run.material.name, 0) + 1
    if len(counts) > 1:
        listed = ", ".join(f"{name} ({n} runs)" for name, n in sorted(counts.items()))
        raise FitError(f"the runs are of {len(counts)} materials: {listed}; the diagnosis shares P, C and K among "
                       f"its runs, so diagnose one material's runs at a time (pen runs --material NAME lists them)")


def check_request(runs: Sequence[_RunView], effects: Sequence[str] | None, false_alarm: float, bootstrap: int,
                  seed: int, workers: int, suggest: int = 0) -> Request:
    """The request as a :class:`Request`, or one line saying what is wrong (and a notice when the replicates
    are too few to see the threshold the false-alarm rate asks for)."""
    if len(runs) < MIN_RUNS:
        raise FitError(f"diagnosis needs at least {MIN_RUNS} runs to hold one out and still fit (got {len(runs)})")
    if not 0.0 < false_alarm < MAX_FALSE_ALARM:
        raise FitError(f"false-alarm rate {false_alarm!r}: expected a probability between 0 and {MAX_FALSE_ALARM:g} "
                       f"(e.g. 0.01)")
    if bootstrap < MIN_BOOTSTRAP:
        raise FitError(f"--bootstrap {bootstrap}: at least {MIN_BOOTSTRAP} null replicates are needed to calibrate "
                       f"the decisions")
    names = tuple(effects or EFFECTS)
    unknown = [n for n in names if n not in EFFECTS]
    if unknown:
        raise FitError(f"unknown effect {unknown[0]!r}; the catalogue: {', '.join(EFFECTS)}")
    shapes = sorted({run.geometry.name for run in runs})
    if len(shapes) > 1:
        raise FitError(f"runs of {len(shapes)} penetrator geometries ({', '.join(shapes)}): diagnose one geometry's "
                       f"runs at a time")
    foreign = [n for n in names if not EFFECTS[n].applies_to(shapes[0])]
    if foreign and effects:
        raise FitError(f"effect {foreign[0]!r} is written for {' and '.join(EFFECTS[foreign[0]].geometries)} "
                       f"penetrators; these runs are of a {shapes[0].replace('_', ' ')}")
    names = tuple(n for n in names if n not in foreign)
    if not 0 <= suggest <= MAX_SUGGESTED:
        raise FitError(f"--suggest {suggest}: expected 0 to {MAX_SUGGESTED} runs")
    if suggest and shapes[0] != BLADE.name:
        raise FitError(f"--suggest {suggest}: the next runs are chosen among the rig's blades (thickness, width, "
                       f"springs); these runs are of a {shapes[0].replace('_', ' ')}")
    if workers < 1:
        raise FitError(f"workers {workers!r}: expected at least 1 process")
    notice = tail_reach_notice(false_alarm, bootstrap)
    if notice:
        warnings.warn(PenNotice(notice), stacklevel=3)
    return Request(names, false_alarm, bootstrap, seed, workers, suggest)


MAX_SUGGESTED = 3
"""At most this many next runs are proposed: beyond three, the forecast of each rests on runs not yet made."""
MAX_FALSE_ALARM = 0.5
"""A campaign-wise false-alarm rate of a half or more says nothing. [–]"""
TERMS = ("strength", "friction", "damping", "inertia")
"""Eq. 9's four terms, the baseline's first four columns in this order."""
SHARED_TERMS = len(TERMS) - 1
"""P, C and K are shared by the runs (the strength factor is per run): a fit's first coefficients, before any
effect's."""


def fit_baseline(runs: Sequence[Run]) -> Baseline:
    """The baseline on the measured data: depth from each block's surface, Eq. 9's columns, one strength factor
    per run and shared P, C, K ≥ 0; the frontal column and the context every effect is stated against."""
    runs = views(runs)
    runs = tuple(replace(r, surface_m=s) for r, s in zip(runs, surfaces(runs)))  # depth below each block's surface
    bases = [basis_of(r) for r in runs]
    uses = tuple((r.flight | r.window)[r.context] for r in runs)
    ys = tuple(r.resistance_n[r.context][u] for r, u in zip(runs, uses))
    columns = _Columns([[] for _ in runs], {})
    for key in TERMS:
        columns.add([getattr(b, key)[u] for b, u in zip(bases, uses)])
    zero = columns.add([np.zeros(int(u.sum())) for u in uses])
    spec = Spec(tuple(range(len(TERMS))), zero)
    first = Statistics(columns.matrices(), [y[:, None] for y in ys])
    _, fitted = _score_family(first, [spec])
    cs = fitted["strength"][:, 0]
    shared = fitted["coefficients"][:, 0]
    values = {"strength_factor": float(np.mean(cs)), "sidewall_pressure_kpa": float(shared[0]),
              "damping_kpa_s_m": float(shared[1]), "inertia_coefficient": float(shared[2])}
    built_at = column_strength_factor(values["strength_factor"])  # a plug's strength column's factor
    bases = tuple(replace(b, frontal=c * b.strength + shared[1] * b.damping + shared[2] * b.inertia,
                          strength_factor=float(c), strength_factor_mean=built_at)
                  for b, c in zip(bases, cs))
    context = {"cs_mean": max(values["strength_factor"], COEFFICIENT_FLOOR), "cs_columns": built_at,
               "p_kpa": max(values["sidewall_pressure_kpa"], COEFFICIENT_FLOOR),
               "load_cell_mass_kg": float(np.mean([r.load_cell_mass_kg for r in runs]))}
    return Baseline(runs, bases, uses, ys, columns, spec, values, cs, shared, context)


COEFFICIENT_FLOOR = 1e-9
"""A coefficient an effect's size is divided by is kept above this, so a term fitted to 0 gives a finite ratio."""


def calibrate_nulls(baseline: Baseline, request: Request) -> NullCalibration:
    """The null replicates: each run's noise, anti-alias filter and encoder read from its record, the
    filters' corners spread as the campaign's runs read them, the baseline re-measured through that chain."""
    b = baseline
    fitted_ctx = [c * basis.strength + basis.friction * b.shared[0] + basis.damping * b.shared[1]
                  + basis.inertia * b.shared[2] for basis, c in zip(b.bases, b.strength_factors)]
    nulls = [_null_of(r, u, f, b.run_values(k)) for k, (r, u, f) in enumerate(zip(b.runs, b.uses, fitted_ctx))]
    spreads = corner_spreads([r.rate_hz for r in b.runs], [n.anti_alias for n in nulls])
    nulls = [replace(n, anti_alias=replace(n.anti_alias, spread=s)) if n.anti_alias is not None else n
             for n, s in zip(nulls, spreads)]
    pending = start_replicates(nulls, request.bootstrap, request.seed, workers=request.workers)
    try:  # while the processes make the replicates
        name = request.rest_effect
        rest = None if name is None else _rest_evidence(b.runs, nulls, EFFECTS[name], request.bootstrap,
                                                        request.seed, request.alpha)
    except BaseException:
        pending.cancel()
        raise
    return NullCalibration(tuple(nulls), pending, rest)


LOG_FLOOR = 1e-300
"""Mean squares are kept above this before a logarithm (a perfect fit is 0). [N²]"""
GAP_Z_FLOOR = 1e-9
"""The gap's log mean square is standardised by a spread of at least this (replicates that agree exactly). [–]"""


def scan_families(baseline: Baseline, calibration: NullCalibration, request: Request) -> FamilyScan:
    """Every candidate of every resistance-view effect and of the probes, one matrix per run, scored on the
    data and on every replicate; the family-wise thresholds of the effects and of the probes."""
    b = baseline
    law_effects = tuple(EFFECTS[n] for n in request.names if EFFECTS[n].side not in ("drive",))
    varying: dict[int, list[np.ndarray]] = {}
    reach = _fold_reach(b.bases, b.uses)
    members = {e.name: [m for m in e.members if m.reach_m <= reach] for e in (*law_effects, *PROBES.values())}
    # the members that do not read the acceleration first, while the replicates may still be being made
    built = {(name, i): _register(b.columns, b.bases, b.runs, b.uses, m, b.spec, (), varying)
             for name, ms in members.items() for i, m in enumerate(ms) if not m.reads_acceleration}
    measured = [_measured_acceleration(basis, rep.acceleration_m_s2)
                for basis, rep in zip(b.bases, calibration.replicates)]
    candidates: dict[str, list[_Candidate]] = {
        name: [built[name, i] if (name, i) in built else
               _register(b.columns, b.bases, b.runs, b.uses, m, b.spec, measured, varying) for i, m in enumerate(ms)]
        for name, ms in members.items()}
    own_runs = _own_run_columns(b)
    matrices = b.columns.matrices()
    targets = tuple(np.column_stack([y, rep.resistance_n]) for y, rep in zip(b.ys, calibration.replicates))
    stats = Statistics(matrices, list(targets), np.array(b.columns.nonnegative), varying,
                       noise_resolution([n.noise.level_n for n in calibration.nulls], [y.size for y in b.ys]))
    reference, _ = _score_family(stats, [b.spec])
    S0 = reference.heldout
    z_gap = _standardise(np.log(np.maximum(S0, LOG_FLOOR)), GAP_Z_FLOOR)[0]
    floor_sq = float(np.mean(S0[1:]))
    tested, z_threshold = _familywise(stats, S0, {e.name: [c.spec for c in candidates[e.name]]
                                                  for e in law_effects}, request.alpha,
                                      admissible={e.name: _admissible(e, candidates[e.name], b.context)
                                                  for e in law_effects if e.admissible is not None})
    # a gap the runs share: a generic profile (in depth or in time since contact) closing part of it on held-out
    # runs beyond what it closes on the null replicates; or a misfit that differs from run to run: each run's own
    # coarse depth profile taking from the baseline's residual more than from the replicates'
    probes, probe_threshold = _familywise(stats, S0, {n: [c.spec for c in candidates[n]] for n in PROBES},
                                          request.alpha)
    own_drop = own_columns_drop(stats, b.spec, own_runs)
    floor = _score_floor(S0, stats)
    improvements = [S0 - t.family.heldout for t in probes.values()] + ([own_drop] if own_drop is not None else [])
    # the largest z over more tests is larger replicate by replicate, but its tail law fitted by moments can sit
    # lower when the added column is light-tailed and the probes' heavy (a null of the example workspace: 3.1
    # over the three, 3.9 over the probes): the run test's bar is at least the probes' own
    run_threshold = max(probe_threshold, familywise_threshold(np.column_stack(improvements), floor, request.alpha))
    z_own = None if own_drop is None else _standardise(own_drop, floor)[0]
    return FamilyScan(law_effects, candidates, matrices, stats, S0, z_gap, floor_sq, float(S0[0]) - floor_sq, tested,
                      z_threshold, probes, probe_threshold, max(t.z for t in probes.values()),
                      _shared_gap(S0, probes, probe_threshold), own_runs, z_own,
                      z_own is not None and z_own > run_threshold, run_threshold, targets, varying)


def _own_run_columns(b: Baseline) -> tuple[int, ...]:
    """Register each run's own depth profile: per run, :data:`RUN_PROFILE_DEGREE` columns that are Legendre
    polynomials of that run's depth in the material (scaled to [−1, 1] over the depths its analysis samples
    reach) and zero in every other run and in flight; their indices, run after run."""
    degree = np.arange(1, RUN_PROFILE_DEGREE + 1)
    own = []
    for r, (basis, used) in enumerate(zip(b.bases, b.uses)):
        x, inside = basis.x[used], basis.inside[used]
        lo, hi = (float(np.min(x[inside])), float(np.max(x[inside]))) if np.any(inside) else (0.0, 0.0)
        scaled = np.where(inside, 2.0 * (x - lo) / (hi - lo) - 1.0, 0.0) if hi > lo else np.zeros(x.size)
        values = np.polynomial.legendre.legvander(scaled, RUN_PROFILE_DEGREE)[:, degree] * inside[:, None]
        for j in range(degree.size):
            own.append(b.columns.add([values[:, j] if k == r else np.zeros(other.x[u].shape[0])
                                      for k, (other, u) in enumerate(zip(b.bases, b.uses))]))
    return tuple(own)


def _admissible(effect: Effect, candidates: Sequence[_Candidate], context: Mapping[str, float]
                ) -> Callable[[int, dict], bool]:
    """Whether candidate i's fit describes a physically possible effect (:attr:`Effect.admissible`)."""
    def check(i: int, fit: dict) -> bool:
        coefficients = fit["coefficients"][SHARED_TERMS:, 0]
        return bool(effect.admissible(effect.describe(candidates[i].member, coefficients,
                                                      _own_context(context, fit))))
    return check


SPEED_FLOOR_M_S = 1e-9
"""A predicted contact speed is kept above this before a ratio (a blade that never reaches the surface). [m/s]"""
T_FLOOR = 1e-12
"""The drive view's t statistic is divided by a spread of at least this (contact speeds that agree exactly)."""


def read_drive(baseline: Baseline, calibration: NullCalibration, request: Request) -> DriveView:
    """The drive view: how far the measured contact speeds, less the bias the replicates' detector shows, fall
    below the launcher's prediction, as each of :data:`DRIVE_LAWS` would make them fall, against the
    deficits' scatter about the law and their measurement error (one-sided t, the stronger law kept)."""
    runs, replicates = baseline.runs, calibration.replicates
    measured = np.array([r.contact_speed_m_s for r in runs])
    bias = np.array([float(np.nanmean(rep.contact_speed_m_s)) - rep.true_contact_speed_m_s
                     if np.isfinite(rep.contact_speed_m_s).any() else 0.0 for rep in replicates])
    predicted = np.array([_predicted_contact_speed(r) for r in runs])
    ratios = (measured - bias) / np.maximum(predicted, SPEED_FLOOR_M_S) - 1.0
    deficits = 1.0 - (1.0 + ratios) ** 2
    measurement = 2.0 * math.sqrt(float(np.mean([np.nanvar(rep.contact_speed_m_s) for rep in replicates]))) \
        / float(np.mean(predicted))  # of one run's deficit: d(1 − r²) = −2r·dr
    laws = deficit_laws(runs, predicted)
    sizes = {name: _law_t(deficits, unit, measurement) for name, unit in laws.items()}
    law = max(sizes, key=lambda name: sizes[name][1])
    t_drive = sizes[law][1]
    threshold = student_quantile(request.alpha / len(laws), len(runs) - 1)
    return DriveView(bias, ratios, t_drive, threshold, request.drive_effect is not None and t_drive > threshold,
                     law, sizes[law][0] * laws[law], sizes[law][0])


INTERVAL_Z = 1.96
"""A coefficient's 95 % interval is its value ± this many standard deviations of its replicates' values."""
PERCENT = 100.0


def report_effects(baseline: Baseline, scan: FamilyScan, drive: DriveView, request: Request
                   ) -> tuple[dict[str, EffectReport], DriveView]:
    """One report per effect: its best member's parameters and intervals, held-out RMS, shrink, z, share of the
    gap and detection limit; the drive effect scored on the fully predicted motion in the material (a loss that
    brings it no closer explains nothing, and the drive view's gap goes)."""
    reports: dict[str, EffectReport] = {}
    S0 = scan.S0
    for e in scan.law_effects:
        t = scan.tested[e.name]
        family, fit = t.family, t.fit
        cand = scan.candidates[e.name][family.best]
        coefs = fit["coefficients"][SHARED_TERMS:, 0]
        spread_c = np.std(fit["coefficients"][SHARED_TERMS:, 1:], axis=1, ddof=1) if coefs.size else np.zeros(0)
        shrink = PERCENT * (1.0 - math.sqrt(max(family.heldout[0], 0.0) / S0[0])) if S0[0] > 0 else 0.0
        chosen = [scan.candidates[e.name][k].member.params for k in family.chosen]
        intervals = {"coefficients_95": [[float(c - INTERVAL_Z * s), float(c + INTERVAL_Z * s)]
                                         for c, s in zip(coefs, spread_c)],
                     "shapes_chosen_per_fold": _shape_spread(chosen)}
        reports[e.name] = EffectReport(
            e.name, e.side, "resistance",
            e.describe(cand.member, coefs, {**_own_context(baseline.context, fit), "coefficient_spread": spread_c}),
            intervals, math.sqrt(max(family.heldout[0], 0.0)), round(shrink, 2), _counts(S0, t, scan.z_threshold),
            round(t.z, 2), (S0[0] - family.heldout[0]) / scan.excess if scan.excess > 0 else None,
            math.sqrt(max(t.centre + scan.z_threshold * t.scale, 0.0)))
    name = request.drive_effect
    if name is None:
        return reports, drive
    runs = baseline.runs
    losses = drive.losses
    base_rms = np.square([_dynamic_rms(r, baseline.run_values(k)) for k, r in enumerate(runs)])
    loss_rms = np.square([_dynamic_rms(r, baseline.run_values(k), float(losses[k])) for k, r in enumerate(runs)])
    (dyn_base, release_base), (dyn_loss, release_loss) = (map(float, np.sqrt(a.mean(0))) for a in (base_rms, loss_rms))
    gap = drive.gap and dyn_loss < dyn_base
    reports[name] = EffectReport(
        name, "drive", "drive",
        {"loss": float(np.mean(losses)), "law": drive.law,
         "loss_by_run": {r.run_id: round(float(x), 4) for r, x in zip(runs, losses)},
         **({"guide_friction_n": round(drive.size, 2)} if drive.law == "guide_friction" else {}),
         "contact_speed_deficit_pct": -PERCENT * float(np.mean(drive.ratios)),
         "dynamic_shrink_from_release_pct": round(PERCENT * (1 - release_loss / release_base), 2)
         if release_base > 0 else 0.0},
        {}, dyn_loss, round(PERCENT * (1 - dyn_loss / dyn_base), 2) if dyn_base > 0 else 0.0,
        bool(gap), round(drive.t, 2), None, None)
    return reports, replace(drive, gap=bool(gap), dynamic_rms_n=dyn_base)


def decide(baseline: Baseline, calibration: NullCalibration, scan: FamilyScan, drive: DriveView,
           reports: dict[str, EffectReport], request: Request) -> Decision:
    """The verdict: the effect (and second) that explains the resistance view's misfit, ``unexplained`` when a
    misfit stays that no catalogue effect or pair removes :data:`EXPLAIN_SHARE` of, the rest's drift
    and the drive effect beside it, ``none`` otherwise; with the notes a user needs to read it."""
    reports = dict(reports)
    verdict, verdict_effects, notes, pair, naming, top = "none", [], [], None, None, None
    if any(r.significant and r.view == "resistance" for r in reports.values()):
        verdict, verdict_effects, top, pair, naming = _resistance_verdict(scan, reports, request, notes,
                                                                          baseline)
    elif scan.resistance_gap:
        verdict = "unexplained"
        notes.append(f"the runs share a misfit (a generic profile closes it on held-out runs: z {scan.z_probe:.1f} "
                     f"against {scan.gap_threshold:.1f}) that no catalogue effect reduces significantly; see where "
                     f"and axes")
    elif scan.run_gap:
        # on campaigns without effect of the hold-out world and world three it fired in 2 of 200 (within the
        # stated 1 %), mostly on one run: in one, that run's acceleration at its entry lay 3.5 sd out of its
        # replicates'
        verdict = "unexplained"
        notes.append(f"each run has a misfit of its own (each run's own depth profile takes more of it than of the "
                     f"replicates': z {scan.z_own:.1f} against {scan.run_threshold:.1f}) that no catalogue effect "
                     f"reduces significantly; see where and axes")
    rest = _rest_beside(baseline, calibration, request, pair, verdict, verdict_effects, reports, notes)
    if drive.gap:
        if verdict == "none":
            verdict, verdict_effects = request.drive_effect, [request.drive_effect]
        else:
            verdict_effects.append(request.drive_effect)
    alike = _ambiguities(reports[verdict_effects[0]], [r for n, r in reports.items() if n not in verdict_effects],
                         scan.tested, scan.S0) if verdict_effects else []
    notes[:0] = [f"{a['effects'][0]} or {a['effects'][1]}: this campaign cannot tell them apart (their held-out "
                 f"improvements differ by {abs(a['difference_z']):.1f} null standard deviations); to separate "
                 f"them: {a['separate_with']}" for a in alike]
    notes += _context_notes(baseline.runs, verdict, reports, rest, request.false_alarm)
    return Decision(verdict, tuple(verdict_effects), reports, tuple(notes), top, pair, naming, rest, tuple(alike))


def _resistance_verdict(scan: FamilyScan, reports: dict[str, EffectReport], request: Request, notes: list[str],
                        baseline: Baseline):
    """The resistance view's verdict once an effect passed the family-wise test: the effect named first and a
    significant second, or ``unexplained`` when neither it nor the pair removes :data:`EXPLAIN_SHARE` of the
    misfit's excess over the null floor while a gap stays (the runs share a misfit, or the first effect's
    held-out error stands above its own null replicates'), or when the verdict's model holds a load-cell mass
    that the flight and the material read differently (:func:`flight_split_test`)."""
    S0, excess = scan.S0, scan.excess
    gate, top = _named_first(reports, scan.tested, S0)
    naming = {"familywise_first": gate.name, "named_first": top.name}
    if not top.significant:
        reports[top.name] = top = replace(top, significant=True)
        notes.append(f"{top.name} is named first: it closes most of the gap (held-out shrink {top.shrink_pct:.0f} %; "
                     f"its improvement beyond all {request.bootstrap} null replicates'); "
                     f"{gate.name} shows there is a gap (z {gate.z:.1f} against {scan.z_threshold:.1f} over all "
                     f"effects) but closes less ({gate.shrink_pct:.0f} %)")
    pair = _best_second(scan.stats, {e.name: scan.candidates[e.name] for e in scan.law_effects}, scan.tested,
                        top.name, baseline.spec, S0, request.alpha)
    top_share = reports[top.name].explained_share
    left_z = _left_z(scan.tested[top.name].family.heldout)
    own_z = _own_run_z(scan, top.name)
    bar = normal_quantile(request.alpha)
    leaves_gap = scan.resistance_gap or left_z > bar or (own_z is not None and own_z > bar)
    explains = not leaves_gap or top_share is None or top_share >= EXPLAIN_SHARE
    pair_share = (S0[0] - pair["heldout"]) / excess if pair and excess > 0 else None
    paired = bool(pair and pair["significant"])
    named = " with ".join([top.name] + ([pair["effect"]] if paired else []))
    split_z, split_bar = flight_split_test(scan, baseline, pair["spec"] if paired else scan.candidates[top.name][
        scan.tested[top.name].family.best].spec, request.alpha)
    naming["remainder"] = {"heldout_z": round(left_z, 2), "own_runs_z": None if own_z is None else round(own_z, 2),
                           "threshold_z": round(bar, 3),
                           "flight_split_z": None if split_z is None else round(split_z, 2),
                           "flight_split_threshold_z": None if split_z is None else round(float(split_bar), 3)}
    if not (explains or (paired and pair_share is not None and pair_share >= EXPLAIN_SHARE)):
        beside = "" if not pair else (
            f"; with {pair['effect']} beside it {PERCENT * max(pair_share or 0.0, 0.0):.0f} %"
            + ("" if pair["significant"] else f", but {pair['effect']} is not significant on top of it"))
        notes.append(f"a misfit stays that no catalogue effect explains: the best explanation ({top.name}) removes "
                     f"only {PERCENT * max(top_share or 0.0, 0.0):.0f} % of its excess over the null floor{beside}, "
                     f"and a gap stays ({_gap_said(scan, left_z, own_z, bar)}); {_candidates_said(reports)}")
        return "unexplained", [], top, pair, naming
    if split_z is not None and split_z > split_bar:
        notes.append(f"a misfit stays that no catalogue effect explains: the best explanation ({named}) removes "
                     f"{PERCENT * max((pair_share if paired else top_share) or 0.0, 0.0):.0f} % of its excess over "
                     f"the null floor, but with a load-cell mass that differs between the flight and the material "
                     f"(z {split_z:.1f} against {split_bar:.1f}), which a wrong mass would not; "
                     f"{_candidates_said(reports)}")
        return "unexplained", [], top, pair, naming
    verdict_effects = [top.name]
    if paired:
        verdict_effects.append(pair["effect"])
        reports[pair["effect"]] = replace(reports[pair["effect"]], significant=True)
        notes.append(f"{pair['effect']} is significant on top of {top.name} (z {pair['z']:.1f} against "
                     f"{pair['threshold']:.1f}); together they shrink the held-out error by "
                     f"{pair['shrink_pct']:.0f} %")
    return top.name, verdict_effects, top, pair, naming


def _candidates_said(reports: Mapping[str, EffectReport]) -> str:
    """The best catalogue candidates and their shares, for an ``unexplained`` note."""
    shares = sorted(((r.explained_share, r.name) for r in reports.values()
                     if r.view == "resistance" and r.explained_share is not None), reverse=True)
    listed = ", ".join(f"{name} {PERCENT * max(share, 0.0):.0f} %" for share, name in shares[:CANDIDATES])
    return (f"candidates: {listed}"
            + "; see where and axes for what the misfit follows")


def _rest_beside(baseline: Baseline, calibration: NullCalibration, request: Request, pair: dict | None, verdict: str,
                 verdict_effects: list[str], reports: dict[str, EffectReport], notes: list[str]) -> dict | None:
    """The rest effect (a force drift) as the rest after the stops shows it; it joins a verdict that names
    another effect when significant there, where no speed or depth law acts."""
    name = request.rest_effect
    if name is None or calibration.rest is None:
        return None
    rest = dict(calibration.rest)
    rest["beside_first_z"] = pair["beside"].get(name) if pair else None
    if rest["significant"] and verdict not in ("none", "unexplained") and name not in verdict_effects:
        verdict_effects.append(name)
        reports[name] = replace(reports[name], significant=True)
        notes.append(f"{name} is significant in the rest after the stop (z {rest['z']:.1f} against "
                     f"{rest['threshold']:.1f} over {rest['runs']} runs; {rest['rms_n']:.2g} N RMS of change), "
                     f"where no speed or depth law acts")
    return rest


MS_PER_S = 1e3
MM_PER_M = 1e3
UM_PER_M = 1e6


def _context_notes(runs: Sequence[_RunView], verdict: str, reports: Mapping[str, EffectReport],
                   rest: dict | None, false_alarm: float) -> list[str]:
    """Notes that help read the verdict: the named effect's caveat for the runs' geometry, runs whose force rises
    late, what a ``none`` could have seen, and a drift the rest shows beside a ``none`` or an ``unexplained``."""
    notes = []
    shape = runs[0].geometry.name
    caveat = EFFECTS[verdict].caveat(shape) if verdict in EFFECTS else None
    if caveat:
        notes.append(f"a {shape.replace('_', ' ')}'s campaign: {caveat}")
    late = _late_rises(runs)
    if late:
        notes.append(f"in {len(late)} of {len(runs)} runs the force rises {min(late.values()):.2f}–"
                     f"{max(late.values()):.2f} ms after the position's contact, later than a block surface within the "
                     f"stand-off tolerance allows (a lagging force chain, or a surface far from the stand-off); their "
                     f"windows start after the rise")
    if verdict == "none":
        limits = ", ".join(f"{r.name} {r.detectable_rms_n:.1f} N" for r in reports.values()
                           if r.detectable_rms_n is not None)
        notes.append(f"nothing found at a false-alarm rate of {false_alarm:g}; effects leaving at least this RMS "
                     f"after the baseline refit would have been seen: {limits}")
        if rest is not None and rest["significant"]:
            notes.append(f"the force drifts in the rest after the stop (z {rest['z']:.1f} against "
                         f"{rest['threshold']:.1f}; {rest['rms_n']:.2g} N RMS of change), too little within the "
                         f"windows to matter to the resistance model")
    if verdict == "unexplained" and rest is not None and rest["significant"]:
        notes.append(f"the force also drifts in the rest after the stop (z {rest['z']:.1f} against "
                     f"{rest['threshold']:.1f}; {rest['rms_n']:.2g} N RMS of change): a drift is present, but one "
                     f"shared by the runs does not explain the misfit in the material")
    return notes


def _rest_series(run: _RunView) -> dict:
    """For the figure: the run's rest phase after the stop as ``rest_time_since_contact_s`` and
    ``rest_residual_n`` (:func:`_rest_residual`), or nothing."""
    rest = _rest_residual(run)
    if rest is None:
        return {}
    mask, residual = rest
    return {"rest_time_since_contact_s": run.time_s[mask] - run.contact_s, "rest_residual_n": residual}


def _late_rises(runs: Sequence[_RunView]) -> dict[str, float]:
    """Per run whose force rises after the stand-off tolerance, how long after the position's contact. [ms]"""
    return {r.run_id: round((r.force_rise_s - r.contact_s) * MS_PER_S, 3) for r in runs if r.force_rise_s is not None}


def locate(baseline: Baseline, calibration: NullCalibration, scan: FamilyScan, drive: DriveView, decision: Decision,
           request: Request, started: float) -> Diagnosis:
    """How far each reported effect changes the trajectory, where the gap lies and along what, and the result
    assembled."""
    runs = baseline.runs
    final = sorted((_with_trajectory(r, baseline, scan, decision) for r in decision.reports.values()),
                   key=lambda r: (-int(r.significant), -r.shrink_pct))
    series_data = _residual_series(runs, baseline.uses, _residuals(scan.stats, scan.matrices, baseline.ys,
                                                                   baseline.spec))
    where = _where(series_data, scan.floor_sq)
    if drive.gap:
        where.insert(0, {"phase": "flight", "depth_mm": None,
                         "time_ms": [0.0, round(float(np.mean([r.contact_s for r in runs])) * MS_PER_S, 2)],
                         "contact_speed_error_pct": [round(PERCENT * float(drive.ratios.min()), 2),
                                                     round(PERCENT * float(drive.ratios.max()), 2)],
                         "share_of_gap": None, "above_noise": True, "view": "drive"})
    after = _verdict_residuals(scan.stats, scan.matrices, baseline.ys, scan.candidates, scan.tested,
                               list(decision.verdict_effects), baseline.spec)
    series = [{"run_id": run.run_id, "time_s": t, "depth_m": x, "time_since_contact_s": t - run.contact_s,
               "baseline_residual_n": res, "effect_residual_n": after[i] if after is not None else None,
               **_rest_series(run)}
              for i, (run, t, x, _, _, res) in enumerate(series_data)]
    noise_floor = math.sqrt(float(np.mean([r.noise_n ** 2 for r in runs])))
    profiles = _profiles(series_data, after, scan, baseline, calibration)
    return Diagnosis(tuple(r.run_id for r in runs), _baseline_record(baseline, scan, drive, decision), tuple(where),
                     tuple(final), decision.verdict, decision.verdict_effects, decision.ambiguities, noise_floor,
                     decision.notes, decision=_decision_record(calibration, scan, drive, request, runs, started),
                     axes=_axes(series_data), series=tuple(series), profiles=profiles)


def _law_candidate(name: str, baseline: Baseline, scan: FamilyScan) -> plan.Candidate:
    """A law effect as the diagnosis fitted it, for :mod:`pencli.diagnose.plan`."""
    t = scan.tested[name]
    own = _own_values(t.fit)
    return plan.Candidate(name, own, _effect_force(scan.candidates[name][t.family.best].member,
                                                   t.fit["coefficients"][SHARED_TERMS:, 0], own, baseline.values))


def suggest_runs(baseline: Baseline, calibration: NullCalibration, scan: FamilyScan, decision: Decision,
                 request: Request) -> dict:
    """The ``request.suggest`` next runs that best tell the verdict's first effect from the effects that fit as
    well (:data:`AMBIGUITY_Z`), or, with none, from the baseline (how firmly a run would confirm it); with no
    verdict effect, the best-fitting law effect against the baseline (:func:`pencli.diagnose.plan.plan`)."""
    laws = [e.name for e in scan.law_effects if e.side == "law"]
    lead = next((n for n in decision.verdict_effects if n in laws), None)
    notes = []
    if lead is None:
        if not laws:
            return {"runs": [], "note": "no law effect among those asked for: nothing a new run's resistance decides"}
        lead = min(laws, key=lambda n: float(scan.tested[n].family.heldout[0]))
        notes.append(f"the verdict names no law effect: the runs that would best show the best-fitting one, {lead}, "
                     f"if it is there")
    rivals = [a["effects"][1] for a in decision.ambiguities if a["effects"][1] in laws]
    skipped = [a["effects"][1] for a in decision.ambiguities if a["effects"][1] not in laws]
    candidates = [_law_candidate(lead, baseline, scan)]
    candidates += ([_law_candidate(n, baseline, scan) for n in rivals] if rivals
                   else [plan.Candidate("baseline", baseline.values, None)])
    noise = math.sqrt(float(np.mean([n.noise.level_n ** 2 for n in calibration.nulls])))
    rate = max(r.rate_hz for r in baseline.runs)
    runs, own = plan.plan(candidates, [r.design for r in baseline.runs], rate, noise, request.suggest)
    notes += [f"{name} is a measurement effect: a run's resistance does not tell it from {lead}" for name in skipped]
    return {"candidates": [c.name for c in candidates], "runs": [r.to_dict() for r in runs],
            "own_runs_separation_sigma": own, "noise_n": round(noise, 3),
            **({"note": "; ".join(notes)} if notes else {})}


PROFILE_BINS = 24
"""Bins of a residual profile along depth or time since contact (the figure's binned means). [–]"""
NULL_BAND = (2.5, 97.5)
"""Percentiles of the null replicates' binned means that bound the figure's band: where 95 % of the campaigns
without an effect fall. [%]"""


def _profiles(series_data, after, scan: FamilyScan, baseline: Baseline, calibration: NullCalibration) -> dict:
    """The held-out residual binned along depth and along time since contact, all runs' samples together: the
    data's mean per bin under the baseline (and with the verdict's effect), and the band that 95 % of the null
    replicates' binned means fall in.  For the figure; no decision reads it."""
    targets = [np.column_stack([y, rep.resistance_n]) for y, rep in zip(baseline.ys, calibration.replicates)]
    every = heldout_residuals_every(scan.matrices, targets, baseline.spec,
                                    scan.stats.fold_coefficients(baseline.spec))
    out = {}
    for axis, values in (("depth_mm", [x * MM_PER_M for _, _, x, _, _, _ in series_data]),
                         ("time_since_contact_ms", [(t - run.contact_s) * MS_PER_S
                                                    for run, t, _, _, _, _ in series_data])):
        along = np.concatenate(values)
        inside = along >= 0.0
        edges = np.linspace(0.0, float(along[inside].max()) if inside.any() else 1.0, PROFILE_BINS + 1)
        index = np.clip(np.searchsorted(edges, along, side="right") - 1, 0, PROFILE_BINS - 1)
        index[~inside] = -1
        residuals = np.concatenate(every, axis=0)  # (samples, targets)
        counts = np.bincount(index[inside], minlength=PROFILE_BINS)
        sums = np.stack([np.bincount(index[inside], weights=residuals[inside, t], minlength=PROFILE_BINS)
                         for t in range(residuals.shape[1])], axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            means = sums / counts[:, None]
        low, high = np.full(PROFILE_BINS, np.nan), np.full(PROFILE_BINS, np.nan)
        filled = counts > 0  # an empty bin has no mean and no band
        if means.shape[1] > 1 and filled.any():
            low[filled], high[filled] = np.percentile(means[filled, 1:], NULL_BAND, axis=1)
        profile = {"centres": 0.5 * (edges[:-1] + edges[1:]), "samples": counts, "baseline_n": means[:, 0],
                   "null_low_n": low, "null_high_n": high}
        if after is not None:
            effect = np.concatenate(after)
            with np.errstate(invalid="ignore", divide="ignore"):
                profile["effect_n"] = np.bincount(index[inside], weights=effect[inside],
                                                  minlength=PROFILE_BINS) / counts
            profile["force_low_n"], profile["force_high_n"] = _runs_range(
                index, residuals[:, 0] - effect, np.concatenate([np.full(v.size, k) for k, v in enumerate(values)]))
        out[axis] = profile
    return out


def _runs_range(index: np.ndarray, force: np.ndarray, run: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per bin of ``index`` (−1: outside every bin), the lowest and the highest of the runs' own binned means of
    ``force`` (each held-out run predicted by the fold fitted without it, so the spread holds the folds'
    disagreement as well as the runs' own); NaN where fewer than two runs have samples. [N]"""
    low, high = np.full(PROFILE_BINS, np.nan), np.full(PROFILE_BINS, np.nan)
    inside = index >= 0
    per_run = []
    for k in np.unique(run):
        mine = inside & (run == k)
        counts = np.bincount(index[mine], minlength=PROFILE_BINS)
        with np.errstate(invalid="ignore", divide="ignore"):
            per_run.append(np.bincount(index[mine], weights=force[mine], minlength=PROFILE_BINS) / counts)
    if not per_run:
        return low, high
    means = np.stack(per_run)  # (runs, bins), NaN where a run has no sample
    two = np.sum(np.isfinite(means), axis=0) >= 2
    if two.any():
        low[two], high[two] = np.nanmin(means[:, two], axis=0), np.nanmax(means[:, two], axis=0)
    return low, high


def _with_trajectory(report: EffectReport, baseline: Baseline, scan: FamilyScan, decision: Decision) -> EffectReport:
    """The report with how its effect changes the median-speed run's trajectory (significant or verdict effects
    only) and the axis its effect follows."""
    change = {}
    effect = EFFECTS[report.name]
    if report.significant or report.name in decision.verdict_effects:
        if effect.side == "drive":
            change = _trajectory_change(effect, None, (), baseline.runs, baseline.values,
                                        report.params["loss_by_run"])
        else:
            t = scan.tested[report.name]
            change = _trajectory_change(effect, scan.candidates[report.name][t.family.best].member,
                                        t.fit["coefficients"][SHARED_TERMS:, 0], baseline.runs, baseline.values,
                                        own_values=_own_values(t.fit))
    return replace(report, trajectory_change=change, axis=effect.axis)


def _baseline_record(baseline: Baseline, scan: FamilyScan, drive: DriveView, decision: Decision) -> dict:
    """The JSON's ``baseline``: the reference model's fit and misfit, and what each view's test read."""
    runs, S0 = baseline.runs, scan.S0
    out = {
        "heldout_rms_n": math.sqrt(float(S0[0])),
        "heldout_nrmse": math.sqrt(float(S0[0])) / float(np.mean([np.max(r.resistance_n[r.window]) for r in runs])),
        "null_rms_n": math.sqrt(scan.floor_sq),
        "gap_z": round(scan.z_gap, 2),
        "resistance_gap": bool(scan.resistance_gap),
        "own_runs_z": None if scan.z_own is None else round(scan.z_own, 2),
        "run_gap": bool(scan.run_gap),
        "probes": {name: {"z": round(t.z, 2), "shrink_pct": round(PERCENT * (1.0 - math.sqrt(
            max(t.family.heldout[0], 0.0) / S0[0])), 2)} for name, t in scan.probes.items()},
        "contact_speed_error_mean": float(np.mean(drive.ratios)),
        "drive_t": round(drive.t, 2),
        "drive_gap": bool(drive.gap),
        "dynamic_heldout_rms_n": drive.dynamic_rms_n,
        "coefficients": baseline.values,
        "strength_factor_per_run": {r.run_id: float(c) for r, c in zip(runs, baseline.strength_factors)},
        "late_force_rise_ms": _late_rises(runs),
        "surface_mm": {r.run_id: round(r.surface_m * MM_PER_M, 3) for r in runs},
    }
    if decision.rest is not None:
        out["rest_drift"] = decision.rest
    if decision.naming is not None:
        out["naming"] = decision.naming
    pair = decision.pair
    if pair is not None:
        out["best_pair"] = {"effects": [decision.top.name, pair["effect"]], "shrink_pct": pair["shrink_pct"],
                            "z": pair["z"], "share_of_remainder": pair["share_of_remainder"],
                            "beyond_own_family": pair["beyond_own_family"], "significant": pair["significant"],
                            "over_own_pair": pair["over_own_pair"]}
    return out


def _decision_record(calibration: NullCalibration, scan: FamilyScan, drive: DriveView, request: Request,
                     runs: Sequence[_RunView], started: float) -> dict:
    """The JSON's ``decision``: the rates asked for, the thresholds the replicates gave, each run's noise model."""
    return {
        "false_alarm": request.false_alarm, "bootstrap": request.bootstrap, "seed": request.seed,
        "effect_threshold_z": round(scan.z_threshold, 3), "gap_threshold_z": round(scan.gap_threshold, 3),
        "run_gap_threshold_z": round(scan.run_threshold, 3),
        "drive_threshold_t": round(drive.threshold, 3), "explain_share": EXPLAIN_SHARE,
        "noise_model": [{**n.noise.to_dict(),
                         "anti_alias": n.anti_alias.to_dict(r.rate_hz) if n.anti_alias else None,
                         "line": n.noise_line.to_dict(r.rate_hz) if n.noise_line else None,
                         "position_noise_um": round(rep.position_noise_m * UM_PER_M, 3)}
                        for n, r, rep in zip(calibration.nulls, runs, calibration.replicates)],
        "encoder_step_mm": [round(r.encoder_step_m * MM_PER_M, 4) for r in runs],
        "seconds": round(time.perf_counter() - started, 2),
    }


def _shape_spread(chosen: Sequence[Mapping]) -> dict:
    """Per shape parameter, the values chosen across the folds ([min, max] for numbers)."""
    out: dict = {}
    for params in chosen:
        for key, value in params.items():
            out.setdefault(key, []).append(value)
    return {k: ([min(v), max(v)] if all(isinstance(x, (int, float)) for x in v) else sorted(set(map(str, v))))
            for k, v in out.items()}


def _named_first(reports: Mapping[str, EffectReport], tested: Mapping[str, _Tested], S0: np.ndarray
                 ) -> tuple[EffectReport, EffectReport]:
    """(the family-wise first, the effect a verdict names first), once the family-wise test has found an effect:
    of the resistance-view effects that are significant (family-wise), the one that improves the data's held-out
    error most; and of those and the ones whose improvement is positive and beyond every null replicate's (a
    rank test at 1/(B + 1)), the one that improves it most.

    Whether an effect is present is the family-wise test's; which one it is, is the fit's.  A family of few,
    similar shapes has a narrow null and stands far out on a slight fit, a wide one (the speed laws on a coarse
    encoder's speeds) a broad one: dev campaign 22 of ``--varied 24 161000 --only velocity_friction`` had a plug growth at z 7.9 against 7.7 family-wise closing 7.7 % of the held-out
    error, and the true friction at z 5.3 closing 19.4 % (11.6 N², its replicates at most 0.6 N²).  Neither a
    threshold fitted to one family's replicates nor its z is the bar here: a wide family extrapolates badly to
    held-out replicate runs, and that long *lower* tail sets a moment fit's scale (the friction's own threshold
    8.7 z where 99 % of its replicates lay below 0.9) and splits the null in two (dev campaign 6 of ``--varied
    24 162000``: median −22 N², a cluster up to 19.7 N²), so the true friction improving by 44.4 N² stood at
    z 2.0.  The rate on campaigns without effect is unchanged: a verdict still needs the family-wise test."""
    def improvement(r: EffectReport) -> float:
        return float(S0[0] - tested[r.name].family.heldout[0])

    def beyond_every_replicate(t: _Tested) -> bool:
        gain = S0 - t.family.heldout
        return bool(gain[0] > 0.0 and gain[0] > np.max(gain[1:]))

    resistance = [r for r in reports.values() if r.view == "resistance"]
    eligible = [r for r in resistance if r.significant or beyond_every_replicate(tested[r.name])]
    return max((r for r in resistance if r.significant), key=improvement), max(eligible, key=improvement)


def _own_run_z(scan: FamilyScan, top: str) -> float | None:
    """How far what each run's own depth profile (:func:`_own_run_columns`) takes from the misfit ``top``'s best
    member leaves, fitted to all runs, stands above what it takes on the null replicates: z of the data's
    drop in mean square.  A paired test of the remainder (the same columns on the same replicates), where
    :func:`_left_z` compares the remainder's size with the replicates' spread of it; None when the runs' own
    columns would pass the solver's limit.

    The replicates carry no effect, but every model here is linear in its coefficients: what further columns
    take from the residual of ``top``'s fit does not depend on the size of ``top``'s effect in the target."""
    return own_columns_z(scan.stats, scan.candidates[top][scan.tested[top].family.best].spec, scan.own_runs)


def own_columns_z(stats: Statistics, spec: Spec, own: Sequence[int]) -> float | None:
    """z of what columns ``own`` take, fitted to all runs on top of ``spec``, from the data's mean square (target
    0) against what they take from each replicate's (the others), standardised as every statistic here; None
    when there are none or the model would pass the solver's limit."""
    drop = own_columns_drop(stats, spec, own)
    return None if drop is None else _standardise(drop, _score_floor(drop, stats))[0]


def own_columns_drop(stats: Statistics, spec: Spec, own: Sequence[int]) -> np.ndarray | None:
    """What columns ``own`` take, fitted to all runs on top of ``spec``, from each target's mean square (the
    data, then each replicate); None when there are none or the model would pass the solver's limit. [N²]"""
    if not own or len(spec.columns) - 1 + len(own) > MAX_COEFFICIENTS:
        return None
    return stats.score([spec]).total[0] - stats.score([replace(spec, columns=spec.columns + tuple(own))]).total[0]


SPLIT_ENERGY_FLOOR = 1e-6
"""A copy of a column that holds less than this share of the column's energy on the data is left out of a split:
nothing of it lies on that side. [–]"""


def flight_masks(baseline: Baseline) -> list[np.ndarray]:
    """Per run, the mask (over its analysed samples) of its flight, for :func:`split_drop`: the copy it adds is
    the column's flight apart from the material.  A term of the force chain that is the measured acceleration
    itself (a wrong load-cell mass) reads the launch's acceleration as it reads the penetration's.

    Only such columns are split (:func:`split_drop`): they have no shape of their own to get wrong.  A drift's
    shape is one of a family, and the flight part of a shape that follows the true drift only in part takes that
    mismatch (a logarithmic drift beside a velocity friction, 0.5 N of noise at 60 kHz: 4.8 z over its bar).  A
    split run by run is not made for the same reason: each run's own size of a family's best member takes its
    mismatch (on the development world the true layers, gradients, plugs and ringings of 5 campaigns in 20 stood
    4.7 to 900 z out of their replicates by it, and 6 in 20 even beside the family's best second shape)."""
    return [~basis.inside[u] for basis, u in zip(baseline.bases, baseline.uses)]


def split_drop(scan: FamilyScan, spec: Spec, masks: Sequence[np.ndarray]) -> np.ndarray | None:
    """What a copy of each of ``spec``'s extra columns that read the measured acceleration, restricted to
    ``masks`` (per run, over its analysed samples) and fitted beside them, takes from each target's mean square
    (the data, then each replicate); None when there is no such column with any of its energy inside the masks,
    or the model would pass the solver's limit. [N²]

    Built on its own small matrices (the model's columns, their copies): a paired test as
    :func:`own_columns_drop`, on the same replicates."""
    p, extra = len(spec.columns), spec.columns[len(TERMS):]
    local = [*spec.columns, spec.offset]

    def energy(q: int, inside: bool) -> float:
        return sum(float(np.sum(W[m if inside else slice(None), q] ** 2)) for W, m in zip(scan.matrices, masks))

    keep = [q for q in extra if q in scan.varying and energy(q, True) > SPLIT_ENERGY_FLOOR * energy(q, False)]
    if not keep or p - 1 + len(keep) > MAX_COEFFICIENTS:
        return None
    matrices = [np.column_stack([W[:, local]] + [W[:, q] * m for q in keep]) for W, m in zip(scan.matrices, masks)]
    varying = {i: scan.varying[q] for i, q in enumerate(local) if q in scan.varying}
    varying.update({p + 1 + i: [v * m[:, None] for v, m in zip(scan.varying[q], masks)] for i, q in enumerate(keep)})
    nonnegative = np.concatenate([scan.stats.nonnegative[local], np.zeros(len(keep), dtype=bool)])
    stats = Statistics(matrices, list(scan.targets), nonnegative, varying, scan.stats.resolution)
    base = Spec(tuple(range(p)), p, spec.scaled)
    split = Spec(base.columns + tuple(range(p + 1, p + 1 + len(keep))), p, spec.scaled)
    return stats.score([base]).total[0] - stats.score([split]).total[0]


def flight_split_test(scan: FamilyScan, baseline: Baseline, spec: Spec, alpha: float) -> tuple[float | None, float]:
    """(z, the bar) of what fitting the flight part of ``spec``'s acceleration columns apart (:func:`flight_masks`)
    takes from the data's mean square against what it takes from each replicate's (standardised as every
    statistic here), and the threshold of the replicates at ``alpha``; (None, inf) when the model has no such
    column.  A wrong load-cell mass is one size in flight and in the material; a mass standing in for an effect
    outside the catalogue often is not (a load cell whose gain rises with the force: the mass that fits the
    penetration's kilonewtons is not the one the launch's tens of newtons show)."""
    drop = split_drop(scan, spec, flight_masks(baseline))
    if drop is None:
        return None, math.inf
    floor = _score_floor(drop, scan.stats)
    return _standardise(drop, floor)[0], familywise_threshold(drop[:, None], floor, alpha)


def _gap_said(scan: FamilyScan, left_z: float, own_z: float | None, bar: float) -> str:
    """Which test says a gap stays, for the ``unexplained`` note."""
    said = []
    if scan.resistance_gap:
        said.append(f"a profile the runs share closes part of it, z {scan.z_probe:.1f}")
    if left_z > bar:
        said.append(f"held-out z {left_z:.1f}")
    if own_z is not None and own_z > bar:
        said.append(f"each run's own depth profile takes part of it, z {own_z:.1f}")
    return "; ".join(said)


def _left_z(heldout: np.ndarray) -> float:
    """How far the misfit a fit leaves (held-out mean squares, data then null replicates) stands above what it
    leaves on its own null replicates: the data's log mean square in their standard deviations."""
    return _standardise(np.log(np.maximum(heldout, LOG_FLOOR)), GAP_Z_FLOOR)[0]


def _best_second(stats: Statistics, candidates: Mapping[str, list[_Candidate]], tested: Mapping[str, _Tested],
                 top: str, base_spec: Spec, S0: np.ndarray, alpha: float) -> dict | None:
    """The effect that adds most on top of ``top`` (its best member held), tested against the null.

    Significant when (1) ``top`` leaves a gap its own null would not, (2) the second effect's standardised
    improvement beats the null's largest (family-wise, as for the first), and either
    (a) it removes at least :data:`EXPLAIN_SHARE` of what ``top`` leaves above the null floor and does better
    than the best second shape of ``top``'s own family by more than the null's noise, or (b) it still adds on
    top of that own pair: its z beats the same family-wise threshold and it removes :data:`EXPLAIN_SHARE` of
    what the own pair leaves.  At high signal-to-noise any family fits a little of the first effect's shape
    mismatch, and another shape of the first family fits it at least as well, while a second cause is
    something no shape of the first can mimic.  Two shapes of a flexible family (two drifts) can together match
    a second cause about as well as the cause does, and then only what the cause adds beyond them tells them
    apart.  (b) does not need (a)'s share: a first effect whose form one member
    follows only in part leaves a misfit of its own, which a second own shape takes and a second cause does
    not (two struck modes with their own decays left three times what a pressure growth beside them removed).
    """
    lead = candidates[top][tested[top].family.best]
    S_top = tested[top].family.heldout
    if _left_z(S_top) <= normal_quantile(alpha):
        return None  # the first effect leaves no gap its own null would not
    combined = {}
    for name, cands in candidates.items():
        specs = [spec for spec in (_combine(lead, c, base_spec) for c in cands if c is not lead) if spec is not None]
        if specs:
            combined[name] = specs
    own_specs = combined.pop(top, None)
    absent = tested[top].family.per_run
    scored, threshold = _familywise(stats, S_top, combined, alpha, absent)
    if not scored:
        return None
    name = max(scored, key=lambda n: S_top[0] - scored[n].family.heldout[0])
    second = scored[name]
    share = _share_of_remainder(S_top, second.family.heldout, S0)
    beyond_own, over_own, adds = True, None, False
    if own_specs:
        own, _ = _score_family(stats, own_specs, absent)
        diff = own.heldout - second.family.heldout  # > 0 when the other effect does better than a second own shape
        # standardised as every statistic here (median, and the larger of MAD and upper semi-deviation): a pair
        # that extrapolates wildly on a few replicates puts them at −10¹⁵ N², which says nothing of the upper
        # tail, and the plain sd then blinded the test (dev pair-2 of --pairs 12 60000: a layer beating a
        # second ringing shape by 11,902 N² against a null sd of 4·10¹⁴ and a MAD of 10)
        beyond_own = _standardise(diff, _score_floor(own.heldout, stats))[0] > AMBIGUITY_Z
        over_own = _over_own_pair(stats, _Candidate(lead.member, own_specs[own.best]), candidates[name], base_spec,
                                  own, S0, threshold)
        adds = bool(over_own and over_own["adds"])
    return {"effect": name, "spec": combined[name][second.family.best], "heldout": float(second.family.heldout[0]),
            "z": round(second.z, 2),
            "threshold": threshold, "share_of_remainder": round(share, 3), "beyond_own_family": bool(beyond_own or adds),
            "over_own_pair": over_own,
            "significant": bool(second.z > threshold and ((share >= EXPLAIN_SHARE and beyond_own) or adds)),
            "shrink_pct": round(100.0 * (1.0 - math.sqrt(max(second.family.heldout[0], 0.0) / S0[0])), 2),
            "beside": {n: round(t.z, 2) for n, t in scored.items()}}


def _over_own_pair(stats: Statistics, own_pair: _Candidate, cands: Sequence[_Candidate], base_spec: Spec,
                   own: _Family, S0: np.ndarray, threshold: float) -> dict | None:
    """What a second effect's family adds on top of the lead's best pair of own shapes: its z, the share it
    removes of what the own pair leaves above the null floor, and whether the z beats ``threshold`` (the pair
    test's family-wise one) and the share :data:`EXPLAIN_SHARE` (``adds``).

    The bar is the pair test's, not a Gumbel tail fitted to this one family's replicates: three shapes
    together often extrapolate wildly to a held-out replicate run, a long tail of *worse* scores (to −1,000 z
    on dev pair-2 of ``--pairs 10 55000 --drift-friction``) that says nothing of the upper tail but set the
    moment-fitted Gumbel's scale (threshold 784 z while no replicate stood above 1.3 z).  Each replicate's z is
    standardised as every family's is, so the largest over the pair families bounds one family's.
    """
    specs = [spec for spec in (_combine(own_pair, c, base_spec) for c in cands) if spec is not None]
    if not specs:
        return None
    S_own = own.heldout
    third, _ = _score_family(stats, specs, own.per_run)
    z = _standardise(S_own - third.heldout, _score_floor(S_own, stats))[0]
    share = _share_of_remainder(S_own, third.heldout, S0)
    return {"z": round(z, 2), "threshold": round(threshold, 3), "share_of_remainder": round(share, 3),
            "adds": bool(z > threshold and share >= EXPLAIN_SHARE)}


def _ambiguities(lead: EffectReport, others: Sequence[EffectReport], tested: Mapping[str, _Tested], S0
                 ) -> list[dict]:
    """The significant resistance-view effects among ``others`` (those the verdict does not name) whose held-out
    improvement is within :data:`AMBIGUITY_Z` null standard deviations of ``lead``'s (the verdict's first
    effect): with these runs, either explains the misfit as well as the other."""
    if lead.view != "resistance" or lead.name not in tested:
        return []
    d_lead = S0 - tested[lead.name].family.heldout
    out = []
    for other in (r for r in others if r.significant and r.view == "resistance"):
        diff = d_lead - (S0 - tested[other.name].family.heldout)
        sd = float(np.std(diff[1:], ddof=1))
        if abs(float(diff[0])) > AMBIGUITY_Z * max(sd, LOG_FLOOR):
            continue
        advice = INDISTINGUISHABLE.get(frozenset({lead.name, other.name}),
                                       "runs that vary blade thickness, contact speed and depth")
        out.append({"effects": [lead.name, other.name], "shrink_pct": [lead.shrink_pct, other.shrink_pct],
                    "difference_z": round(float(diff[0]) / max(sd, LOG_FLOOR), 2), "separate_with": advice})
    return out


def _residuals(stats: Statistics, matrices, ys, spec: Spec) -> list[np.ndarray]:
    """Each run's held-out residual under ``spec``, from the same fold fits as the scores (for figures). [N]"""
    scores = stats.score([spec])
    return heldout_residuals(matrices, ys, spec, scores.folds[0], scores.run_scale[0])


def _verdict_residuals(stats: Statistics, matrices, ys, candidates, tested: Mapping[str, _Tested],
                       verdict_effects: Sequence[str], base_spec: Spec) -> list[np.ndarray] | None:
    """Held-out residuals with the verdict's resistance-view effects added (None when there are none)."""
    chosen = [candidates[n][tested[n].family.best] for n in verdict_effects if n in tested]
    if not chosen:
        return None
    spec = chosen[0].spec
    if len(chosen) > 1:
        spec = _combine(chosen[0], chosen[1], base_spec) or spec
    return _residuals(stats, matrices, ys, spec)
