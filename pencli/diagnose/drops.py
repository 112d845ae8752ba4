"""Diagnosis across free-fall drops into one bed: is there a layer the bed's straight law misses, and where?

The reference law is q = σ + b·z + c·v on the cone's frontal area
(:mod:`pencli.fit.freefall`), fitted across the drops with the probe's
drag and added mass.  A layer is a step Δ in q below a depth z_L that every
drop reaching it meets.  For each candidate depth (where at least
``MIN_DROPS_AT_DEPTH`` drops have samples above and below), the share of the
reference's residual sum of squares that the step removes is computed in
closed form; the statistic is the largest share over the depths.

Its null is made from the drops themselves: each drop's residual is rotated
along its own samples by a random offset and added back to the fitted law,
which keeps every drop's misfit, its size and its correlation from sample
to sample, but breaks any alignment of a step at one depth across drops.
The verdict:

- ``layer`` when the data's share is beyond the null's at the false-alarm
  rate and the step removes at least ``EXPLAINED_SHARE`` of the misfit (at
  its depth, with Δ and the held-out RMS of each drop left out with and
  without it);
- ``unexplained`` when the misfit is aligned across drops beyond the null
  but a step removes less than that share (the bed's law is wrong in some
  other way: a gradient that changes, a rate law that is not straight);
- ``none`` otherwise.

Before the bed, the sensors (:func:`accelerometer_check`): the probe lies
still after it stops, so the speed integrated from its accelerometers must
come back to 0 there.  A drop whose speed at rest is beyond what the
trapezoid rule and the sensors' noise leave (both read from the drop
itself, :class:`pencli.filter.freefall.DropMotion`), at the false-alarm rate
shared by the drops, carries a bias the rests before the release and after
the stop did not show: the verdict is ``accelerometer_bias``, whatever the
bed.  The same drop integrated with each sensor's bias stepping at the
impact instead of drifting between the rests (a shock's zero offset) says
whether that form accounts for it; where it does, the bed is read from that
motion.

Pure functions, no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np

from pencli.diagnose import FALSE_ALARM, SHUFFLES
from pencli.diagnose.null import normal_quantile

MATERIAL_SHARE = 0.05
"""A misfit whose held-out RMS is under this share of the bed's mean pressure is below what pen states a bed's
law to, and is not called ``unexplained`` however well it lines up across drops. [–]"""
EXPLAINED_SHARE = 0.5
"""Share of the reference's misfit a layer must remove to be named (pen's rule for every effect it names)."""
MIN_DROPS_AT_DEPTH = 2
"""Drops that must have samples above and below a candidate depth: a step met by one drop alone is that drop's."""
DEPTH_STEP_M = 0.002
"""Spacing of the candidate depths. [m]"""
MIN_SAMPLES_BESIDE = 20
"""Samples a drop needs on each side of a depth to count as having met it."""
DEGENERATE = 1e-9
"""A step whose column the straight law already spans to within this share of its rows removes nothing. [–]"""


@dataclass(frozen=True)
class BedRows:
    """One drop's samples in the bed: depth below the surface [m], speed [m/s], the bed's pressure on the cone's
    frontal area [kPa]."""

    name: str
    depth_m: np.ndarray
    speed_m_s: np.ndarray
    pressure_kpa: np.ndarray


@dataclass(frozen=True)
class DropDiagnosis:
    """The verdict on a set of drops and what it rests on."""

    verdict: str
    """``layer``, ``unexplained`` or ``none``."""
    layer_depth_m: float
    """Where the step that removes most of the misfit lies (reported whatever the verdict). [m]"""
    layer_step_kpa: float
    """Its size: the change in q below that depth. [kPa]"""
    share: float
    """The share of the reference law's residual sum of squares the step removes. [–]"""
    p_value: float
    false_alarm: float
    reference: tuple[float, float, float]
    """σ [kPa], b [kPa/m], c [kPa·s/m] of the reference law fitted on every drop."""
    heldout_rms_reference_kpa: float
    """RMS of each drop's pressure left out of the reference law's fit, over every drop. [kPa]"""
    heldout_rms_layer_kpa: float
    """The same with the step at its depth. [kPa]"""
    drops: int
    notes: tuple[str, ...] = ()
    bed_verdict: str = ""
    """The bed's own verdict (``layer``, ``unexplained``, ``none``); the verdict is ``accelerometer_bias`` instead
    where the sensors fail their check."""
    accelerometer: AccelerometerCheck | None = None


@dataclass(frozen=True)
class RestSpeed:
    """One drop's speed over the rest after its stop, under a bias model: the speed [m/s] and how many standard
    deviations of the sensors' integrated noise it stands beyond the trapezoid rule's bound (NaN: no rest after
    the stop)."""

    speed_m_s: float
    z: float


@dataclass(frozen=True)
class AccelerometerCheck:
    """Whether the drops' accelerometers carry a bias their rests did not show."""

    biased: tuple[str, ...]
    """Drops whose speed at rest is beyond what the integration and the noise leave."""
    stepped: tuple[str, ...]
    """Of those, the ones a bias stepping at the impact accounts for (their bed is read from that motion)."""
    ramp: dict[str, RestSpeed]
    """Each drop's speed at rest with the bias drifting in a straight line between the rests (pen's reading)."""
    step: dict[str, RestSpeed]
    """The same with each sensor's bias stepping at the impact."""
    threshold_z: float
    """The z a drop must exceed: two-sided, the false-alarm rate shared by the drops."""
    untested: tuple[str, ...] = ()
    """Drops with no rest after the stop to check."""


def rest_speed(motion) -> RestSpeed:
    """The speed at rest of a :class:`pencli.filter.freefall.DropMotion` and its z."""
    v = float(motion.rest_speed_m_s)
    z = (abs(v) - motion.rest_speed_bound_m_s) / max(motion.rest_speed_sd_m_s, 1e-12)
    return RestSpeed(v, float(z))


def accelerometer_check(motions: dict, false_alarm: float = FALSE_ALARM) -> AccelerometerCheck:
    """The check of the drops' sensors: ``motions`` maps each drop's name to its motion integrated with the bias
    drifting between the rests and with it stepping at the impact
    (:func:`pencli.filter.freefall.drop_motion`'s two models)."""
    ramp = {name: rest_speed(pair[0]) for name, pair in motions.items()}
    step = {name: rest_speed(pair[1]) for name, pair in motions.items()}
    untested = tuple(name for name, r in ramp.items() if not np.isfinite(r.z))
    tested = max(1, len(ramp) - len(untested))
    threshold = normal_quantile(false_alarm / (2 * tested))  # two-sided, shared by the drops tested
    biased = tuple(name for name, r in ramp.items() if r.z > threshold)
    stepped = tuple(name for name in biased if step[name].z <= threshold)
    return AccelerometerCheck(biased, stepped, ramp, step, threshold, untested)


SENSOR_CHECKS = {"accelerometers": ({"bias_at": "impact"}, accelerometer_check)}
"""Each sensor chain's own check on the drops it read, by the chain's name (:data:`pencli.sensors.CHAINS`): the
chain's constants for a second reading of each drop, and the check, which takes ``{drop: (first reading's
account, second's)}`` and the false-alarm rate and returns a result whose ``stepped`` drops are read the second
way from then on.  A chain without an entry has no check of its own."""


def _design(rows: Sequence[BedRows]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    depth = np.concatenate([r.depth_m for r in rows])
    speed = np.concatenate([r.speed_m_s for r in rows])
    X = np.column_stack([np.ones(depth.size), depth, speed])
    return X, np.concatenate([r.pressure_kpa for r in rows]), depth, np.repeat(np.arange(len(rows)),
                                                                                 [r.depth_m.size for r in rows])


def candidate_depths(rows: Sequence[BedRows]) -> np.ndarray:
    """Depths where at least ``MIN_DROPS_AT_DEPTH`` drops have ``MIN_SAMPLES_BESIDE`` samples above and below. [m]"""
    lo, hi = [], []
    for r in rows:
        z = np.sort(r.depth_m)
        if z.size > MIN_SAMPLES_BESIDE + MIN_SAMPLES_BESIDE:
            lo.append(z[MIN_SAMPLES_BESIDE])
            hi.append(z[-MIN_SAMPLES_BESIDE])
    if not lo:
        return np.zeros(0)
    grid = np.arange(min(lo), max(hi), DEPTH_STEP_M)
    met = sum((grid > a) & (grid < b) for a, b in zip(lo, hi))
    return grid[met >= MIN_DROPS_AT_DEPTH]


def step_shares(X: np.ndarray, y: np.ndarray, depth: np.ndarray, grid: np.ndarray) -> tuple[np.ndarray, float]:
    """The share of the straight law's residual sum of squares a step at each depth of ``grid`` removes, and that
    sum: with r the residual and h the step's column, (h·r)² / (h·(I − P)·h) of r·r, for all depths at once."""
    theta, *_ = np.linalg.lstsq(X, y, rcond=None)
    r = y - X @ theta
    rss = float(r @ r)
    order = np.argsort(depth)
    z = depth[order]
    below = z.size - np.searchsorted(z, grid, side="right")  # rows below each depth: the step's column is 1 there
    tail = lambda values: np.concatenate([np.cumsum(values[order][::-1])[::-1], [0.0]])  # noqa: E731
    hr = tail(r)[z.size - below]
    hX = np.column_stack([tail(X[:, k])[z.size - below] for k in range(X.shape[1])])
    inverse = np.linalg.inv(X.T @ X)
    hMh = below - np.einsum("ij,jk,ik->i", hX, inverse, hX)
    with np.errstate(divide="ignore", invalid="ignore"):
        share = np.where(hMh > DEGENERATE * np.maximum(below, 1), hr * hr / hMh, 0.0) / max(rss, 1e-300)
    return share, rss


def _heldout(rows: Sequence[BedRows], depth_m: float | None) -> float:
    """RMS of each drop's pressure predicted by the law fitted on the others (with the step at ``depth_m``). [kPa]"""
    errors = []
    for k in range(len(rows)):
        X, y, depth, _ = _design([r for j, r in enumerate(rows) if j != k])
        Xk, yk, depth_k, _ = _design([rows[k]])
        if depth_m is not None:
            X = np.column_stack([X, depth > depth_m])
            Xk = np.column_stack([Xk, depth_k > depth_m])
        theta, *_ = np.linalg.lstsq(X, y, rcond=None)
        errors.append(yk - Xk @ theta)
    e = np.concatenate(errors)
    return float(np.sqrt(np.mean(e * e)))


def diagnose_drops(rows: Sequence[BedRows], *, false_alarm: float = FALSE_ALARM, shuffles: int = SHUFFLES,
                   seed: int = 0) -> DropDiagnosis:
    """The verdict on ``rows`` (each drop's samples in the bed).  Raises ValueError with fewer than two drops or
    no depth that two drops cross."""
    if len(rows) < MIN_DROPS_AT_DEPTH:
        raise ValueError(f"{len(rows)} drop(s): a layer is told from a drop's own misfit only by "
                         f"{MIN_DROPS_AT_DEPTH} drops or more meeting it")
    grid = candidate_depths(rows)
    if grid.size == 0:
        raise ValueError(f"no depth that {MIN_DROPS_AT_DEPTH} drops cross with {MIN_SAMPLES_BESIDE} samples on each "
                         f"side")
    X, y, depth, drop = _design(rows)
    share, _ = step_shares(X, y, depth, grid)
    best = int(np.argmax(share))
    theta, *_ = np.linalg.lstsq(X, y, rcond=None)
    fitted, residual = X @ theta, y - X @ theta
    rng = np.random.default_rng(seed)
    starts = np.concatenate([[0], np.cumsum(np.bincount(drop))])
    exceed = 0
    for _ in range(shuffles):
        rotated = np.concatenate([np.roll(residual[a:b], int(rng.integers(b - a))) for a, b in
                                  zip(starts[:-1], starts[1:])])
        exceed += float(np.max(step_shares(X, fitted + rotated, depth, grid)[0])) >= share[best]
    p_value = (1 + exceed) / (1 + shuffles)
    with_step = np.column_stack([X, depth > grid[best]])
    step = float(np.linalg.lstsq(with_step, y, rcond=None)[0][-1])
    aligned = p_value <= false_alarm
    heldout = _heldout(rows, None)
    material = heldout >= MATERIAL_SHARE * float(np.mean(np.abs(y)))
    verdict = ("layer" if aligned and share[best] >= EXPLAINED_SHARE else
               "unexplained" if aligned and material else "none")
    notes = []
    if aligned and verdict != "layer":
        said = "the bed's law is wrong in some other way" if material else (
            f"at {100 * heldout / float(np.mean(np.abs(y))):.1f} % of the mean pressure it is below what pen states "
            f"a bed's law to ({100 * MATERIAL_SHARE:.0f} %)")
        notes.append(f"the drops' misfit lines up in depth beyond their own (p = {p_value:.3f}), but a layer at "
                     f"{1e3 * grid[best]:.0f} mm removes only {100 * share[best]:.0f} % of it: {said}")
    return DropDiagnosis(verdict, float(grid[best]), step, float(share[best]), p_value, false_alarm,
                         tuple(float(v) for v in theta), heldout, _heldout(rows, float(grid[best])), len(rows),
                         tuple(notes), bed_verdict=verdict)


def with_sensors(bed: DropDiagnosis, check: AccelerometerCheck) -> DropDiagnosis:
    """The bed's diagnosis with the sensors' check: verdict ``accelerometer_bias`` where a drop fails it, a note
    for each such drop and for drops that could not be checked."""
    notes = []
    for name in check.biased:
        ramp, step = check.ramp[name], check.step[name]
        said = (f"a bias stepping at the impact accounts for it ({step.speed_m_s:+.3f} m/s, z {step.z:.1f}); the "
                f"bed is read with it" if name in check.stepped else
                f"neither a drift between the rests nor a step at the impact accounts for it (a step leaves "
                f"{step.speed_m_s:+.3f} m/s, z {step.z:.1f})")
        notes.append(f"{name}: the speed after the stop is {ramp.speed_m_s:+.3f} m/s where the probe lies still "
                     f"(z {ramp.z:.1f} beyond what the integration and the noise leave, threshold "
                     f"{check.threshold_z:.1f}): an accelerometer bias the rests did not show; {said}")
    if check.untested:
        notes.append(f"{', '.join(check.untested)}: no rest after the stop, so the accelerometers' bias could not "
                     f"be checked there")
    if check.biased and bed.bed_verdict != "none":
        corrected = set(check.biased) == set(check.stepped)
        notes.append(f"the bed's own verdict, {bed.bed_verdict}, rests on motions "
                     f"{'corrected as above' if corrected else 'some of which are wrong'}")
    return replace(bed, verdict="accelerometer_bias" if check.biased else bed.verdict,
                   notes=(*notes, *bed.notes), accelerometer=check)


__all__ = ["AccelerometerCheck", "BedRows", "DropDiagnosis", "EXPLAINED_SHARE", "RestSpeed", "accelerometer_check",
           "candidate_depths", "diagnose_drops", "rest_speed", "step_shares", "with_sensors"]
