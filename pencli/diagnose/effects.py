r"""The effect catalogue of CONTRACT §4: each unmodelled effect as a *family* of model extensions.

An effect is an extra term of the resistance-mode model (measured x, v and
a drive Eq. 9; the load cell reads R plus what the force chain adds).  A
family is wide enough to cover the effect's physical meaning, not one curve:
a strength layer is any step (sharp or with a soft edge) or plateau (a band) in depth;
velocity friction is any of several speed laws; sensor lag is a first-order,
second-order or pure-delay channel; ringing is one or two decaying modes.
Each family is a list of :class:`Member` shapes.  A member's nonlinear
parameters (a depth, an exponent, a time constant) are fixed; its linear
coefficients are fitted with the baseline's.  The engine chooses the member
on training runs only.

Law effects are written once as (Eq. 9 term × dimensionless profile); the
same definition gives the fitting columns and the extra force of the
dynamic model (:meth:`Member.force`).  Chain effects change what the load
cell reports and have no force.

Adding an effect is one new :class:`Effect` in :data:`EFFECTS`.  Columns are
in newtons per unit of the member's linear coefficient; the number of
coefficients is the number of columns (no second table).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property, lru_cache, partial
from typing import TYPE_CHECKING, Callable, Mapping, Sequence

from pencli.lazy import lazy

from pencli.filter.windows import PRE_TRIGGER_MARGIN_S, WINDOW_TRIM_S
from pencli.model.design import Design
from pencli.model.geometry import BLADE, force_steps_at_contact
from pencli.model.resistance import unit_terms

if TYPE_CHECKING:  # the catalogue is read by `pen diagnose --help`, which loads no numpy
    from pencli.run import Run

np = lazy("numpy")  # imported on first use: `pen --help` does not load numpy

# ----------------------------------------------------------------------------- run data


DEFAULT_ENCODER_STEP_M = 0.16e-3
"""Position quantum of a stage that does not record it: the rig's 0.16 mm encoder. [m]"""
STRENGTH_FACTOR_FLOOR = 1e-6
"""A baseline strength factor below this is a fit with no strength term: a plug's growth is stated against the
factor its column was built at instead. [–]"""
RELEASE_CLEARANCE_S = 2e-3
"""The flight is read from this long after the release: the springs' first push rings the rig. [s]"""
STOP_MARGINS_IN_RUN = 4
"""The window is cut short of a hard stop only for a run longer than this many stop margins after contact, so a
short run keeps most of its samples. [–]"""
MIN_NOISE_SAMPLES = 10
"""A standard deviation of fewer pre-trigger samples is no noise level; 1 N stands in. [–]"""
STOP_MARGIN_S = 2e-3
"""At a hard stop (``end == "full_depth"``) the diagnosis's window ends this long before the stop, not the tare's
0.5 ms: over the last counts before the hard stops the acceleration read from the encoder carries an error the
null replicates do not reproduce.  An arrest keeps the tare's end: its last milliseconds hold the lowest speeds,
which tell the speed laws apart. [s]"""


@dataclass(frozen=True)
class _RunView:
    """One conditioned run as the diagnosis reads it (SI, whole record): an adapter of a
    :class:`~pencli.run.Run` made by :func:`views`, private to the diagnosis."""

    run_id: str
    design: Design
    time_s: np.ndarray
    depth_m: np.ndarray
    velocity_m_s: np.ndarray
    acceleration_m_s2: np.ndarray
    force_n: np.ndarray
    """Tared axial force F. [N]"""
    resistance_n: np.ndarray
    """F − m_lc·a with the file's load-cell mass. [N]"""
    motion_start_s: float
    contact_s: float
    stop_s: float
    window_start_s: float
    window_end_s: float
    end: str
    contact_speed_m_s: float
    load_cell_mass_kg: float
    encoder_step_m: float = DEFAULT_ENCODER_STEP_M
    """Position quantum the derivatives were smoothed for (from the record). [m]"""
    derivative_method: str = "spline"
    force_contact_s: float | None = None
    """Contact as the force record sees it (:func:`pencli.filter.tare.force_onset`); differs from
    ``contact_s`` when the block's surface is not at the file's stand-off. [s]"""
    force_rise_s: float | None = None
    """The force's rise at contact where a lagging force chain puts it later than ``force_contact_s`` is looked
    for (:func:`pencli.filter.inertia.late_force_rise`), else None: the window starts after it, and the block's
    surface is read from it (:func:`surfaces`). [s]"""
    geometry: object = BLADE
    """The penetrator's geometry (:mod:`pencli.model.geometry`): whose four unit terms the baseline's columns are."""
    surface_m: float = 0.0
    """Where the block's surface lies on the depth record (0: at the file's stand-off); the Eq. 9 columns and the
    depth laws are evaluated at the depth below it (:func:`surfaces`). [m]"""
    corners_s: tuple[float, ...] = ()
    """When the tip passed a corner of its geometry's resistance (:attr:`pencli.filter.tare.Events.corners_s`),
    where the derivatives join. [s]"""

    @property
    def rate_hz(self) -> float:
        return (self.time_s.size - 1) / (self.time_s[-1] - self.time_s[0])

    @property
    def seen_contact_s(self) -> float:
        """Contact as the force sees it, else by position: where the acceleration jumps. [s]"""
        return self.contact_s if self.force_contact_s is None else self.force_contact_s

    @property
    def contact_span_s(self) -> tuple[float, float]:
        """Earliest and latest contact by position and by force. [s]"""
        seen = self.seen_contact_s
        return min(self.contact_s, seen), max(self.contact_s, seen)

    @property
    def flight(self) -> np.ndarray:
        """Free flight: :data:`RELEASE_CLEARANCE_S` after the release to the tare's window trim before the earliest
        contact."""
        return ((self.time_s > max(self.motion_start_s, 0.0) + RELEASE_CLEARANCE_S)
                & (self.time_s < self.contact_span_s[0] - WINDOW_TRIM_S))

    @property
    def window(self) -> np.ndarray:
        """The analysis window, starting no sooner than the tare's window trim after the latest contact or a late
        force rise and ending no later than :data:`STOP_MARGIN_S` before a hard stop (runs longer than
        :data:`STOP_MARGINS_IN_RUN` margins)."""
        start = max(self.window_start_s, self.contact_span_s[1] + WINDOW_TRIM_S,
                    -math.inf if self.force_rise_s is None else self.force_rise_s + WINDOW_TRIM_S)
        end = self.window_end_s
        if self.end == "full_depth" and self.stop_s - self.contact_s > STOP_MARGINS_IN_RUN * STOP_MARGIN_S:
            end = min(end, self.stop_s - STOP_MARGIN_S)
        return (self.time_s >= start) & (self.time_s <= end)

    @property
    def context(self) -> np.ndarray:
        """From just before the release to the window end: where filters run."""
        return ((self.time_s >= min(self.motion_start_s, 0.0) - PRE_TRIGGER_MARGIN_S)
                & (self.time_s <= self.window_end_s))

    @property
    def pre_trigger(self) -> np.ndarray:
        """At rest before the release, clear of it by the tare's pre-trigger margin: where the sensor noise is
        read."""
        return self.time_s < min(self.motion_start_s, 0.0) - PRE_TRIGGER_MARGIN_S

    @property
    def noise_n(self) -> float:
        """Standard deviation of the resistance over the pre-trigger span (sensor noise; 1 N without one). [N]"""
        pre = self.pre_trigger
        return float(np.std(self.resistance_n[pre])) if pre.sum() > MIN_NOISE_SAMPLES else 1.0


def views(runs: Sequence[Run | _RunView]) -> list[_RunView]:
    """Each conditioned run (inertia stage) as the diagnosis reads it, its contact as the force sees it and a late
    force rise looked for (a view is passed on as it is)."""
    from pencli.filter.inertia import kinematic_events, late_force_rise
    from pencli.sensors.load_cell import unbroken_at_contact

    out = []
    for run in runs:
        if isinstance(run, _RunView):
            out.append(run)
            continue
        events, params = run.require_events(), run.stage_parameters
        reading = run.reading()
        for name in ("acceleration_m_s2", "force_n"):  # a stage without them: one line naming what it lacks
            run.column(name)
        t, depth, v, a = reading.time_s, reading.travel_m, reading.speed_m_s, reading.accel_m_s2
        force, resistance = reading.channels["force_n"], reading.force_n
        geometry = run.geometry
        mass = float(params["load_cell_mass_kg"])
        step = float(params.get("encoder_step_m", DEFAULT_ENCODER_STEP_M))
        method = str(params.get("method", "spline"))
        steps = force_steps_at_contact(geometry, run.design)
        if not steps:
            v, a, resistance = unbroken_at_contact(t, depth, force, events, mass, step, method)
        out.append(_RunView(run.run_id, run.design, t, depth, v, a, force, resistance, events.motion_start_s,
                            events.contact_s, events.stop_s, events.window_start_s, events.window_end_s,
                            events.end, events.contact_speed_m_s, mass, step, method,
                            kinematic_events(t, force, events).contact_s if steps else None,
                            late_force_rise(t, force, events, LAG_SPAN_S) if steps else None, geometry=geometry,
                            corners_s=events.corners_s))
    return out


@dataclass(frozen=True)
class Basis:
    """Eq. 9 columns of one run over its context span (N per file unit of Cs, P, C, K)."""

    strength: np.ndarray
    friction: np.ndarray
    damping: np.ndarray
    inertia: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    t: np.ndarray
    inside: np.ndarray
    blade_thickness_m: float
    frontal: np.ndarray | None = None
    """The baseline's frontal force (Cs·strength + C·damping + K·inertia) on this run, once fitted. [N]"""
    strength_factor: float | None = None
    """The baseline's strength factor of this run (with ``frontal``)."""
    strength_factor_mean: float | None = None
    """The baseline's strength factor, mean over the campaign's runs, by magnitude (:func:`column_strength_factor`;
    with ``frontal``)."""
    memo: dict = field(default_factory=dict, compare=False, repr=False)
    """Values that members build again and again from this run's times and motion alone (a ringing's modes, which
    its two-mode members share; a plateau layer's edges, :func:`_profile_values`; the motion inside the material,
    :func:`_inside_motion`), by what they are built from; shared by the copies :func:`dataclasses.replace` makes
    (which change the acceleration or the baseline's frontal force, which they do not read)."""

    def matrix(self) -> np.ndarray:
        return np.column_stack([self.strength, self.friction, self.damping, self.inertia])


def surfaces(runs: Sequence[_RunView]) -> list[float]:
    """Where each run's block surface lies on its depth record, read from when its force rose. [m]

    A block whose surface is not at the file's stand-off (stand-off scatter) puts every depth law of that run
    off by the difference, and a strong law that changes within millimetres of the surface no longer fits: a
    2.5 mm plug on dev plug 2 of ``--varied 12 82000 --only plug_growth`` (surfaces −0.6 to +2.3 mm off) left
    a held-out RMS of 54 N under its own exact shape against 2.5 N of noise (7.5 N without the scatter), and
    was named a layer.  The force's change point (:attr:`_RunView.force_contact_s`) sees the surface, but
    late: the force chain's filter and the change-point fit lag the contact by a time the campaign's runs share
    (0.2–0.4 mm at 8–12 m/s on dev null 21 of ``--nulls 40 43000``, whose surfaces scattered by 0.1–0.4 mm:
    depth laws below surfaces moved by that lag left a shared misfit of their own, and the null was called
    ``unexplained``).  Each run's surface is where the blade was when its force rose *less the campaign's
    median lag* behind the position's contact: on average the file's stand-off, for each run its own scatter
    about it.  A lag of the force chain itself, common to the runs, moves no surface.

    Where the rise came later than the narrow search looks (:attr:`_RunView.force_rise_s`), the rise is
    when the force rose: the narrow search's change point lies before it, in the noise.  Read from those points,
    dev sensor lag 1 of ``--varied 16 190000 --only sensor_lag`` (a 0.65 ms delay; five runs' points at −0.26 to
    −0.01 ms, the sixth's, whose slower contact widened its search, at +0.50 ms) had that sixth run's surface
    put 4.3 mm deep, the right delay scored 2,986 N² on it, and the campaign was named a load-cell mass error.
    """
    lags = [(r.seen_contact_s if r.force_rise_s is None else r.force_rise_s) - r.contact_s for r in runs]
    common = float(np.median(lags))
    return [float(np.interp(r.contact_s + lag - common, r.time_s, r.depth_m) - np.interp(r.contact_s, r.time_s,
                                                                                        r.depth_m))
            for r, lag in zip(runs, lags)]


def basis_of(run: _RunView) -> Basis:
    """The four Eq. 9 columns on the run's context span; zero above the block's surface
    (:attr:`_RunView.surface_m`)."""
    c = run.context
    x, v = run.depth_m[c] - run.surface_m, np.maximum(run.velocity_m_s[c], 0.0)
    inside = (x > 0) & (run.time_s[c] >= run.contact_span_s[0])
    xs = np.where(inside, x, 0.0)
    vs = np.where(inside, v, 0.0)
    terms = [np.where(inside, np.broadcast_to(term, x.shape), 0.0)
             for term in run.geometry.unit_terms(run.design, xs, vs)]
    return Basis(*terms, x, v, run.acceleration_m_s2[c], run.time_s[c], inside, run.design.blade_thickness_m)


# ----------------------------------------------------------------------------- members and families
@dataclass(frozen=True)
class Columns:
    """How a member enters the linear model on one run's context span."""

    extra: np.ndarray
    """Extra columns (n, k), N per unit coefficient."""
    base: np.ndarray | None = None
    """Replacement for the four Eq. 9 columns (n, 4) (a force-chain filter acts on them), or None."""
    offset: np.ndarray | None = None
    """Known force to subtract from the measured resistance (n,), or None. [N]"""


Profile = Callable[["np.ndarray", "np.ndarray"], "np.ndarray"]
"""Dimensionless multiplier of an Eq. 9 term as a function of depth x [m] and speed v [m/s]."""


@dataclass(frozen=True)
class Member:
    """One shape of a family: fixed nonlinear parameters, linear coefficients to fit.

    Law members are ``term`` × each of ``profiles`` (one coefficient each);
    chain members give their columns through ``chain``.
    """

    params: Mapping[str, float | str]
    term: str | None = None
    """``strength`` (per unit Cs) or ``friction`` (per kPa of P)."""
    profiles: tuple[Profile, ...] = ()
    chain: Callable[[_RunView, Basis], Columns] | None = None
    dynamic: Callable[[Sequence[float], Design, Mapping[str, float]], Callable[[float, float], float]] | None = None
    """For members with their own columns that still act on the motion: their extra force (see :meth:`force`)."""
    strength_extra: tuple[int, ...] = ()
    """For a member with its own columns (``chain``): which extra columns are shares of the run's strength
    (:meth:`strength_columns`)."""
    nonnegative: bool = False
    """The coefficients are ≥ 0 by the effect's meaning (a plug widens, pressure grows): fitted with that bound,
    so that a family cannot mimic another's shape with the opposite, unphysical sign."""
    reads_acceleration: bool = False
    """``chain`` builds its extra columns or offset from the basis's measured acceleration ``a``, and accepts an
    (n, T) ``a`` (one measurement per column) as well as an (n,) one: the diagnosis then builds them again from
    each null replicate's own measured acceleration, whose derivative error that replicate's resistance carries
    (R = F − m·a)."""
    reach_m: float = 0.0
    """How deep every fold's training runs must reach for the member to be fitted at all: the second-deepest
    run of the campaign reaches this depth or the member is left out (the diagnosis leaves one run out, and a
    shape that bends deeper than its training runs go is unconstrained there: fitted on next to nothing, it
    extrapolates wildly to the run held out, on the data and on the null replicates alike). [m]"""

    def strength_columns(self, n_extra: int) -> tuple[int, ...]:
        """Which of the member's ``n_extra`` extra columns are shares of the run's strength (a law on the
        strength term): block scatter multiplies them as it multiplies the baseline's strength
        (:attr:`pencli.diagnose.linear.Spec.scaled`)."""
        if self.chain is None:
            return tuple(range(n_extra)) if self.term == "strength" else ()
        return self.strength_extra

    def columns(self, run: _RunView, basis: Basis) -> Columns:
        if self.chain is not None:
            return self.chain(run, basis)
        carrier = _carrier(self.term, basis)
        x, v = _inside_motion(basis)
        return Columns(np.column_stack([carrier * np.broadcast_to(_profile_values(p, basis, x, v), x.shape)
                                        for p in self.profiles]))

    def force(self, coefficients: Sequence[float], design: Design, values: Mapping[str, float], geometry=BLADE
              ) -> Callable[[float, float], float] | None:
        """Extra resistance f(x [m], v [m/s]) → N of this member in the dynamic model (law members only), on the
        terms of ``geometry``.

        ``values`` are the fitted coefficients in file units (CONTRACT §1 names) of the model the force joins;
        ``strength_factor_of_columns``, where given, is the mean strength factor at which the member's own
        columns were built (the baseline's: :attr:`Basis.strength_factor_mean`), else ``strength_factor``.
        """
        if self.dynamic is not None:
            return self.dynamic(coefficients, design, values)
        if self.chain is not None:
            return None
        coefs = [float(c) for c in coefficients]
        term, profiles = self.term, self.profiles

        def extra(x: float, v: float) -> float:
            x, v = max(x, 0.0), max(v, 0.0)
            strength, friction, damping, inertia = geometry.unit_terms(design, x, v)
            carrier = strength if term == "strength" else friction
            return float(carrier * sum(c * float(p(np.float64(x), np.float64(v))) for c, p in zip(coefs, profiles)))

        return extra


def _carrier(term: str | None, b: Basis) -> np.ndarray:
    if term == "strength":
        return b.strength
    if term == "friction":
        return b.friction
    raise ValueError(f"unknown carrier term {term!r}")


@dataclass(frozen=True)
class Effect:
    """A registered catalogue effect: a family of members and how to name its fitted parameters.

    ``describe(member, coefficients, context)`` turns a member's fitted
    coefficients into named physical parameters (``context``: the baseline's
    mean strength factor ``cs_mean``, sidewall pressure ``p_kpa`` and
    ``load_cell_mass_kg``).
    """

    name: str
    side: str
    """``law`` (resistance law), ``chain`` (force measurement) or ``drive`` (launcher)."""
    axis: str
    """What the misfit organises along: depth, speed, time, acceleration, contact or flight."""
    doc: str
    family: tuple[Member, ...] | Callable[[], tuple[Member, ...]]
    """The members, or a function that makes them (called once, on first use: not at import)."""
    describe: Callable[[Member, np.ndarray, Mapping[str, float]], dict]
    rest_evidence: bool = False
    """The family is also looked for in the rest after each run's stop, where no speed or depth law acts (a
    drift of the force offset shows there too); significant there, it joins a verdict that names another effect."""
    geometries: tuple[str, ...] = ()
    """The penetrator geometries the effect is written for (empty: every one): a plug grows on a blade's edge."""
    admissible: Callable[[Mapping], bool] | None = None
    """Whether a member's description (:attr:`describe`'s dict) is physically possible (a layer's strength is not
    negative); the member an effect is described by is the best-fitting admissible one (None: every one is)."""
    caveats: tuple[tuple[str, str], ...] = ()
    """(geometry, text): what a verdict naming the effect in a campaign of that geometry should be read with (what
    a bench found the diagnosis gets wrong there)."""

    def applies_to(self, geometry: str) -> bool:
        """Whether the effect is looked for in runs of ``geometry``."""
        return not self.geometries or geometry in self.geometries

    def caveat(self, geometry: str) -> str | None:
        """The effect's caveat for campaigns of ``geometry``, if any."""
        return dict(self.caveats).get(geometry)

    @cached_property
    def members(self) -> tuple[Member, ...]:
        """The family's members (thousands for a layer: made when the diagnosis first needs them)."""
        return self.family() if callable(self.family) else self.family


def law(term: str, *profiles: Profile, nonnegative: bool = False, reach_m: float = 0.0, **params) -> Member:
    return Member(params, term, tuple(profiles), nonnegative=nonnegative, reach_m=reach_m)


def _sigmoid(z):
    return 0.5 * (1.0 + np.tanh(z))


@lru_cache(maxsize=None)
def _step(depth_m: float, edge_m: float) -> Profile:
    """One profile object per edge: the members that share it share its values on a run
    (:func:`_profile_values`)."""
    return lambda x, v: _sigmoid((x - depth_m) / edge_m)


# depth grid of layer edges: every 5 mm (the truth's depth need not be on it: edge widths bridge the grid)
_LAYER_DEPTHS_MM = tuple(float(d) for d in range(5, 141, 5))
_LAYER_EDGES_MM = (1.0, 4.0, 12.0)


def _layer_members() -> tuple[Member, ...]:
    # each enters only where every fold's training runs reach an edge's width past its last edge
    # (:attr:`Member.reach_m`): deeper, the column on the training runs is a tanh's tail (3·10⁻⁷ of the strength
    # 90 mm above a 12 mm edge), which the solver scales to unit size, and the coefficient explodes on the run held
    # out (dev layer 2 of ``--varied 28 74000``: a null median of the layer's held-out improvement of −3·10¹⁷ N²,
    # z 0.7 against a shrink of 94 %)
    out = [law("strength", _step(d * 1e-3, e * 1e-3), depth_mm=d, edge_mm=e, shape="step", reach_m=(d + e) * 1e-3)
           for e in _LAYER_EDGES_MM for d in _LAYER_DEPTHS_MM]
    # a plateau is a band of other strength: its bottom edge goes back (or beyond), never on in the top's
    # direction, which would be a two-step staircase, a graded profile (PLATEAU_SIGNS)
    out += [law("strength", _signed(_step(d1 * 1e-3, e * 1e-3), top), _signed(_step(d2 * 1e-3, e * 1e-3), -top),
                nonnegative=True, depth_mm=d1, bottom_mm=d2, edge_mm=e, shape="plateau", band=band,
                reach_m=(d2 + e) * 1e-3)
            for band, top in PLATEAU_SIGNS.items()
            for e in _LAYER_EDGES_MM for i, d1 in enumerate(_LAYER_DEPTHS_MM) for d2 in _LAYER_DEPTHS_MM[i + 2:]]
    return tuple(out)


PLATEAU_SIGNS = {"stronger": 1.0, "weaker": -1.0}
"""A plateau layer's band and the sign of its top edge; the bottom edge has the other sign, and both coefficients
are ≥ 0.  With free signs the two edges also made staircases (both steps one way), graded profiles that took other
families' effects: dev wide plug 2 of ``--varied 12 99300 --only plug_growth --wide-plugs`` was named a layer by a
"plateau" 5–15 mm whose edges both rose (+0.70 and +1.02 of the strength; 996 N² held out against the plug's
1,060), and the best layer member of each S-shaped gradient that ``--varied 8 84000 --only strength_gradient
--s-gradients`` names a layer was such a staircase (as bands, 2 of those 3 stay layers)."""


@dataclass(frozen=True)
class _Signed:
    """A profile times a sign; the profile's values on a run are computed once for every member that holds it
    (a plateau layer's edges: 84 distinct edges in 2,106 plateaus)."""

    profile: Profile
    sign: float

    def __call__(self, x, v):
        return self.sign * self.profile(x, v)


def _signed(profile: Profile, sign: float) -> Profile:
    return _Signed(profile, sign)


def _profile_values(p: Profile, b: Basis, x: np.ndarray, v: np.ndarray):
    """``p(x, v)`` on the run of ``b`` (``x``, ``v``: its motion inside the material, :func:`_inside_motion`); a
    signed profile's inner values kept in the run's memo for the members that share them."""
    if not isinstance(p, _Signed):
        return p(x, v)
    key = ("profile", p.profile)
    if key not in b.memo:
        b.memo[key] = p.profile(x, v)
    return p.sign * b.memo[key]


def _inside_motion(b: Basis) -> tuple[np.ndarray, np.ndarray]:
    """(depth, speed) inside the material, 0 outside, computed once per run. [m, m/s]"""
    key = ("inside motion",)
    if key not in b.memo:
        b.memo[key] = (np.where(b.inside, b.x, 0.0), np.where(b.inside, b.v, 0.0))
    return b.memo[key]


def _describe_layer(m: Member, c, ctx) -> dict:
    top = PLATEAU_SIGNS.get(m.params.get("band"), 1.0)  # the coefficients' signs (a step's is free)
    out = {"depth_mm": m.params["depth_mm"], "ratio": 1.0 + top * float(c[0]) / ctx["cs_mean"],
           "edge_mm": m.params["edge_mm"], "shape": m.params["shape"]}
    if m.params["shape"] == "plateau":
        out["bottom_mm"] = m.params["bottom_mm"]
        out["band"] = m.params["band"]
        out["ratio_below"] = 1.0 + top * (float(c[0]) - float(c[1])) / ctx["cs_mean"]
        out = {**_main_edge(out, float(c[0]), float(c[1]), ctx.get("coefficient_spread")), **out}  # read first
    return out


def _main_edge(plateau: Mapping, top_change: float, bottom_change: float, spread=None) -> dict:
    """The edge of a plateau whose change of strength is the more certain (the larger ratio of its coefficient to
    that coefficient's spread over the null replicates, where known; else the larger change), and the strength
    below it over the strength above it: a band that barely differs from the material above is the top of a
    step at its bottom edge (a cone's stronger layer was described as a plateau from 15 mm, ×0.99, to 50 mm,
    ×2.9 below), and a bottom edge that only the runs' last millimetres see is poorly determined however large."""
    if spread is not None and len(spread) == 2 and min(spread) > 0:
        top_first = top_change / spread[0] >= bottom_change / spread[1]
    else:
        top_first = top_change >= bottom_change
    if top_first:
        return {"main_edge_mm": plateau["depth_mm"], "main_edge_ratio": plateau["ratio"]}
    below = plateau["ratio_below"] / plateau["ratio"] if plateau["ratio"] > 0 else math.inf
    return {"main_edge_mm": plateau["bottom_mm"], "main_edge_ratio": below}


def _layer_possible(description: Mapping) -> bool:
    """A layer's strength, and a plateau's below it, are not negative: a weaker band fitted at −0.54 of the strength
    (a sharp cone's strength column is small near the surface, so a band there can take any sign of misfit) is
    no layer the material can hold."""
    return description["ratio"] >= 0 and description.get("ratio_below", 1.0) >= 0


_LENGTHS_MM = (5.0, 10.0, 20.0, 40.0, 80.0, 160.0)
_EXPONENTS = (0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0, 2.5, 3.0)
_GRADIENT_LENGTHS_MM = tuple(round(5.0 * 2.0 ** (k / 4), 1) for k in range(25))
_EXPONENTIAL_MIN_LENGTH_MM = 40.0
"""Exponential gradients start at this length: shorter, e^(x/L) explodes over a 130 mm block. [mm]"""
"""A gradient's saturating and exponential lengths, a factor 2^¼ (19 %) apart from 5 to 320 mm (exponentials from
40 mm).  A factor 2 apart (5–160 mm), an exponential of 73 mm (strength ×3.95 at 100 mm) fitted at 80 mm left
5 × the null floor, and a strength layer beside it took that as a second effect (dev gradient-17 of
``--varied 28 106000``)."""


_MONOTONE_CENTRES_MM = (0.0, 50.0, 100.0)
"""Where the rises of the monotone gradient's elements are centred; each rises over ±75 mm.  Six rises
30 mm apart (±45 mm) fitted the folds' runs better than any one curve but extrapolated worse to the held-out
run, while the family picked each fold's member by its training fit (it now picks by held-out error on
the other folds): on dev gradients of seed 51000, 12 of 16 named a gradient against 14 of 16 without
them; three 75 mm wide ones, 14 of 16."""


def _rise(centre_m: float, half_width_m: float) -> Profile:
    """A smooth rise from 0 to 1 over centre ± half width: the integral of a quadratic B-spline (an I-spline)."""
    from scipy.interpolate import BSpline  # here: `pen --help` imports this module and must not load scipy

    knots = centre_m + half_width_m * np.array([-1.0, -1.0 / 3.0, 1.0 / 3.0, 1.0])
    integral = BSpline.basis_element(knots, extrapolate=False).antiderivative()
    top = float(integral(knots[-1]))
    return lambda x, v: integral(np.clip(x, knots[0], knots[-1])) / top


def _monotone_members() -> list[Member]:
    """Smooth monotone strength profiles: non-negative sums of rises (or of falls), for the profiles no one
    curve of the other members matches (smooth monotone profiles).  Dev gradients of two slopes
    (sim truth shape 3; seed 53000): 7 of 10 named a gradient with them, 3 of 10 without (the others a
    plateau layer or a capped-ramp plug)."""
    rises = [_rise(c * 1e-3, 75e-3) for c in _MONOTONE_CENTRES_MM]
    falls = [_signed(r, -1.0) for r in rises]
    return [law("strength", *rises, nonnegative=True, shape="monotone", direction="rising"),
            law("strength", *falls, nonnegative=True, shape="monotone", direction="falling")]


_RISE_CENTRES_MM = tuple(range(20, 100, 10))
_RISE_WIDTHS_MM = (18.0, 27.0, 40.0)
"""Single S-shaped rises (or falls: the coefficient is free), tanh((x − centre)/width) as a layer's edge but
wider than any (a layer's edges are at most 12 mm): centred every 10 mm, 10–90 % over 40, 59 or 88 mm, and only
where the S's toe lies in the block (centre ≥ width: at most 12 % risen at the surface; a shallower S is a
saturating rise, which the saturating members cover).  Added for the S-shaped development gradients of
``bench_diagnose --s-gradients``, most of which went to a layer's 12 mm edge.  Each enters a campaign only where
every fold's training runs reach a width past its centre (:attr:`Member.reach_m`)."""


def _s_rise(centre_m: float, width_m: float) -> Profile:
    """A layer's edge, ½(1 + tanh((x − centre)/width)), less its value at the surface: 0 there, as every gradient."""
    step = _step(centre_m, width_m)
    at_surface = float(_sigmoid(-centre_m / width_m))
    return lambda x, v: step(x, v) - at_surface


_KINKS_MM = tuple(float(d) for d in range(10, 100, 10))
"""Where a two-slope gradient's slope changes: every 10 mm.  Each member enters only where every fold's training
runs pass its kink by 20 mm (:attr:`Member.reach_m`), so that the second slope is fitted on every fold.  Added
for the development gradients of two slopes (``--two-slopes``, sim truth shape 3): without them 5 of
``--varied 12 176000``'s 12 were named a strength layer, a step at the kink being the nearest other shape."""


def _two_slopes(kink_m: float) -> tuple[Profile, Profile]:
    """A straight rise, and a second slope from the kink on: x/100 mm and max(x − kink, 0)/100 mm."""
    return (lambda x, v: x / 0.1), (lambda x, v: np.maximum(x - kink_m, 0.0) / 0.1)


def _gradient_members() -> tuple[Member, ...]:
    out = [law("strength", (lambda x, v, p=p: (x / 0.1) ** p), exponent=p, shape="power") for p in _EXPONENTS]
    out.append(law("strength", lambda x, v: x / 0.1, lambda x, v: (x / 0.1) ** 2, shape="quadratic"))
    out += [law("strength", (lambda x, v, L=L * 1e-3: -np.expm1(-x / L)), length_mm=L, shape="saturating")
            for L in _GRADIENT_LENGTHS_MM]
    out += [law("strength", (lambda x, v, L=L * 1e-3: np.expm1(x / L)), length_mm=L, shape="exponential")
            for L in _GRADIENT_LENGTHS_MM if L >= _EXPONENTIAL_MIN_LENGTH_MM]
    out += [law("strength", _s_rise(c * 1e-3, w * 1e-3), centre_mm=float(c), width_mm=w, shape="s_rise",
                reach_m=(c + w) * 1e-3)  # past the S's centre by a width: 88 % risen, its top constrained
            for c in _RISE_CENTRES_MM for w in _RISE_WIDTHS_MM if c >= w]
    out += [law("strength", *_two_slopes(d * 1e-3), kink_mm=d, shape="two_slopes", reach_m=(d + 20.0) * 1e-3)
            for d in _KINKS_MM]
    return tuple(out + _monotone_members())


def _describe_gradient(m: Member, c, ctx) -> dict:
    change = sum(float(k) * float(p(np.float64(0.1), np.float64(0.0))) for k, p in zip(c, m.profiles))
    out = {"change_per_100mm": change / ctx["cs_mean"], **{k: v for k, v in m.params.items()}}
    if m.params["shape"] == "two_slopes":  # the slope past the kink over the slope above it
        out["slope_ratio"] = (float(c[0]) + float(c[1])) / float(c[0]) if float(c[0]) != 0.0 else None
    return out


_PLUG_LENGTHS_MM = tuple(round(5.0 * 2.0 ** (i / 4), 1) for i in range(21))
"""Plug lengths, a factor 2^¼ (19 %) apart from 5 to 160 mm.  A factor 2 apart, a capped ramp between two of them
lost to a strength layer, whose edges sit every 5 mm with three widths (dev plugs of seed 40000: the four capped
ramps, lengths 16–30 mm, all named a layer once the layer rode on each block's strength).  A factor √2 apart, a
capped ramp of 11.4 mm (dev plug 7 of ``--varied 12 82000``) fitted at 10 or 14.1 mm left a held-out RMS of 33 N
where its own length left 9 N, and lost to a layer; an exponential of 23.3 mm fitted at 28.3 mm came out 4.8 mm
wide for 2.5 (dev plug 2)."""


def column_strength_factor(strength_factor: float) -> float:
    """The strength factor a plug's strength column is built at: the baseline's mean, by its magnitude. [–]

    A strong plug can push the baseline's strength factors below 0 (its P and K take the depth's growth; dev plug
    6 of ``--varied 12 99300 --only plug_growth --wide-plugs``, 2.7 mm on blades of 1–2 mm: −1.0 to −0.1), and a
    column built at a negative one points against the plug, whose growth is bounded ≥ 0: the plug's own exact
    shape was then held at zero growth and left 48–173 N per held-out run, against 12–22 N with the column's
    sign kept."""
    return abs(strength_factor) if strength_factor != 0 else 1.0


def _plug_members() -> tuple[Member, ...]:
    # a plug adds a width g·h(x) ≥ 0 to every blade, whatever its thickness: T_eff = T + g·h(x), so every frontal
    # term gains (its force / T) × g·h(x); h is dimensionless (1 at saturation), g in metres.  The strength, damping
    # and inertia terms get a coefficient each (g, g·C, g·K, all ≥ 0): the baseline's C and K are themselves
    # biased by the plug, so a rate column built at their values has the wrong mix of v and v² (dev plug-3 of
    # seed 40000, a capped ramp: 72.5 % shrink with one rate column built from them, named a layer at 78.3 %;
    # 80.8 % with the two terms apart).
    def member(h, **params):
        return Member(params, chain=lambda run, b, h=h: _plug_columns(run, b, h),
                      dynamic=lambda c, design, values, h=h: _plug_force(c, design, values, h), nonnegative=True,
                      strength_extra=(0,))

    out = [member(lambda x, L=L * 1e-3: -np.expm1(-x / L), length_mm=L, shape="exponential") for L in _PLUG_LENGTHS_MM]
    out += [member(lambda x, L=L * 1e-3: (x / L) / (1.0 + x / L), length_mm=L, shape="hyperbolic")
            for L in _PLUG_LENGTHS_MM]
    # a plug that grows at a steady rate until it reaches its final size, then stays (a ramp with a corner)
    out += [member(lambda x, L=L * 1e-3: np.minimum(x / L, 1.0), length_mm=L, shape="capped_ramp")
            for L in _PLUG_LENGTHS_MM]
    # the same with a curved rise: a plug that forms fast at the surface (a square root) or slowly and then fast
    # (a square), then stays
    out += [member(lambda x, L=L * 1e-3, p=p: np.clip(x / L, 0.0, 1.0) ** p, length_mm=L, exponent=p,
                   shape="capped_power") for p in (0.5, 2.0) for L in _PLUG_LENGTHS_MM]
    out.append(member(lambda x: x / 0.1, shape="linear"))
    return tuple(out)


def _plug_columns(run: _RunView, b: Basis, h: Callable[[np.ndarray], np.ndarray]) -> Columns:
    x = np.where(b.inside, b.x, 0.0)
    profile = h(x) / b.blade_thickness_m
    # the strength column at the campaign's mean strength factor: the diagnosis scales it per run by the run's
    # own (a plug in a stronger block crushes stronger material), as it does every strength law
    mean = b.strength_factor_mean if b.strength_factor_mean is not None else (b.strength_factor or 1.0)
    return Columns(np.column_stack([b.strength * mean * profile, b.damping * profile, b.inertia * profile]))


def _plug_force(coefficients, design: Design, values: Mapping[str, float], h) -> Callable[[float, float], float]:
    """Extra frontal force of a plug: (strength term × g + damping term × g·C + inertia term × g·K) × h(x) / T,
    each product a fitted coefficient. [N]"""
    g_strength, g_damping, g_inertia = (float(c) for c in coefficients)
    mean = values.get("strength_factor_of_columns", values["strength_factor"])  # as in :func:`_plug_columns`

    def extra(x: float, v: float) -> float:
        x, v = max(x, 0.0), max(v, 0.0)
        strength, _, damping, inertia = unit_terms(design, x, v)
        rate = g_damping * damping + g_inertia * inertia
        profile = float(h(np.float64(x))) / design.blade_thickness_m
        return float((mean * strength * g_strength + rate) * profile)

    return extra


def _describe_plug(m: Member, c, ctx) -> dict:
    """The growth g of the strength term (its column is built at the baseline's mean strength factor, the fit's
    own is the block's), and g·C and g·K of the rate terms over the fit's C and K (None where the fit has that
    term at 0). [mm]"""
    def over(value, reference):
        return float(value) * 1e3 / reference if reference > 0 else None

    built_at = ctx["cs_columns"]
    # against the fit's own mean strength factor; a fit whose strength factors stay at or below 0 has none, and
    # the growth is then stated against the factor the column was built at
    own = ctx["cs_mean"] if ctx["cs_mean"] > STRENGTH_FACTOR_FLOOR else built_at
    growth = float(c[0]) * 1e3 * built_at / own
    return {"growth_mm": growth, "growth_mm_damping": over(c[1], ctx.get("c_kpa_s_m", 0.0)),
            "growth_mm_inertia": over(c[2], ctx.get("k", 0.0)), **dict(m.params)}


def _pressure_members() -> tuple[Member, ...]:
    # P(x) = P (1 + f(x)); friction = 2 μ w ∫P dz; column friction × (∫f)/x (friction carries x)
    out = [law("friction", (lambda x, v, n=n: (x / 0.1) ** n / (n + 1.0)), exponent=n, shape="power",
               nonnegative=True) for n in _EXPONENTS]
    out += [law("friction", (lambda x, v, L=L * 1e-3: 1.0 - L * -np.expm1(-x / L) / np.maximum(x, 1e-12)),
                length_mm=L, shape="saturating", nonnegative=True) for L in _LENGTHS_MM[1:]]
    return tuple(out)


def _pressure_rise(m: Member) -> float:
    """f(100 mm) of a member whose added sidewall pressure is c·f(x) kPa: (x/0.1)ⁿ, or 1 − e^(−x/L). [–]"""
    if m.params["shape"] == "power":
        return 1.0
    return float(-np.expm1(-100.0 / m.params["length_mm"]))


def _describe_pressure(m: Member, c, ctx) -> dict:
    # the column is friction at 1 kPa × (1/x)∫₀ˣ f dz, so the pressure added at depth x is c·f(x) kPa
    added = float(c[0]) * _pressure_rise(m)
    return {"added_kpa_at_100mm": added, "rise_at_100mm": added / ctx["p_kpa"], **dict(m.params)}


_SPEEDS = (0.5, 1.0, 2.0, 4.0, 8.0)


def _speed_laws(term: str) -> tuple[Member, ...]:
    out = [law(term, (lambda x, v, q=q: v ** q), exponent=q, shape="power") for q in _EXPONENTS[:-2]]
    out += [law(term, (lambda x, v, s=s: -np.expm1(-v / s)), speed_m_s=s, shape="saturating") for s in _SPEEDS]
    out += [law(term, (lambda x, v, s=s: np.log1p(v / s)), speed_m_s=s, shape="logarithmic") for s in _SPEEDS]
    return tuple(out)


def _velocity_friction_members() -> tuple[Member, ...]:
    # a Stribeck curve: friction falls with speed and saturates, and a viscous part rises in proportion past it
    # (two coefficients, each of the sign its meaning fixes: the fall's column is negated).  No one-law member
    # follows a fall and a rise: on dev Stribeck forms of ``--wide-friction`` two of five were named a plug,
    # whose damping and inertia columns grow with depth too.  With free signs the pair follows more than a Stribeck
    # curve, the held-out pick of the member got noisier, and two dev frictions that one law had named went to a
    # rate strength (dev 6 of ``--varied 12 91000``, dev 2 of ``--varied 12 93000 --slow-speeds``)
    out = list(_speed_laws("friction"))
    out += [law("friction", (lambda x, v, s=s: np.expm1(-v / s)), (lambda x, v: v / 10.0), speed_m_s=s,
                shape="stribeck", nonnegative=True) for s in _SPEEDS]
    return tuple(out)


def _describe_speed(reference: str) -> Callable[[Member, np.ndarray, Mapping[str, float]], dict]:
    def describe(m: Member, c, ctx) -> dict:
        at_5 = sum(float(k) * float(p(np.float64(0.0), np.float64(5.0))) for k, p in zip(c, m.profiles))
        at_5 /= ctx[reference]
        if m.params["shape"] == "stribeck":  # the fall at saturation and the viscous rise at 10 m/s, both ≥ 0
            return {"change_at_5_m_s": at_5, "fall": float(c[0]) / ctx[reference],
                    "viscous_rise_at_10_m_s": float(c[1]) / ctx[reference], **dict(m.params)}
        return {"change_at_5_m_s": at_5, **dict(m.params)}

    return describe


# ---- chain members
def _mass(run: _RunView, b: Basis) -> Columns:
    return Columns(b.a[:, None])  # (n, 1), or (n, 1, T) for per-target accelerations


def _filtered(run: _RunView, b: Basis, filt: Callable[[np.ndarray], np.ndarray]) -> Columns:
    """F_meas = H(R + m a); R_meas = F_meas − m a = H(R) + (H(m a) − m a)."""
    inertia_force = run.load_cell_mass_kg * b.a
    return Columns(np.zeros((b.t.size, 0)), base=filt(b.matrix()), offset=filt(inertia_force) - inertia_force)


def _poles(tau_ms: float, order: int) -> Callable[[_RunView, Basis], Columns]:
    def build(run: _RunView, b: Basis) -> Columns:
        from scipy.signal import lfilter

        alpha = math.exp(-1.0 / (tau_ms * 1e-3 * run.rate_hz))

        def filt(signal):
            for _ in range(order):
                signal = lfilter([1 - alpha], [1, -alpha], signal, axis=0)
            return signal

        return _filtered(run, b, filt)

    return build


def _delay(delay_ms: float) -> Callable[[_RunView, Basis], Columns]:
    def build(run: _RunView, b: Basis) -> Columns:
        shift = delay_ms * 1e-3 * run.rate_hz
        whole, frac = int(shift), shift - int(shift)

        def filt(signal):
            out = np.zeros_like(signal)
            for k, weight in ((whole, 1.0 - frac), (whole + 1, frac)):
                if weight > 0 and k < signal.shape[0]:
                    out[k:] += weight * signal[:signal.shape[0] - k]
            return out

        return _filtered(run, b, filt)

    return build


_TAUS_MS = (0.05, 0.1, 0.15, 0.2, 0.3, 0.45, 0.7, 1.0, 1.5)
_DELAYS_MS = (0.05, 0.075, 0.1, 0.125, 0.15, 0.2, 0.25, 0.3, 0.375, 0.45, 0.55, 0.7, 0.85, 1.0, 1.25, 1.5)
"""Pure delays 20–25 % apart past 0.1 ms (the time constants stay 50 % apart): a delay moves the whole force step,
and between 0.45 and 0.7 ms each fold of dev sensor lags 1 and 2 of ``--varied 16 190000 --only sensor_lag`` (0.65
and 0.58 ms) picked one or the other, the odd pick scoring 45–67 N² on its run against a baseline of 21–28 N²;
both were named a load-cell mass error.  A finer grid for every lag shape (101 members, 12 % apart) had called
lags on development nulls ; this adds 7 members."""
LAG_SPAN_S = max(_TAUS_MS + _DELAYS_MS) * 1e-3
"""The longest delay or time constant of the lag members: how late a lagging force chain can show contact. [s]"""


def _lag_members() -> tuple[Member, ...]:
    # The offset H(m·a) − m·a keeps the data's acceleration on every replicate (``reads_acceleration`` off).  Built
    # from each replicate's own, it raised the lag's z on nulls (dev null-1 of seed 9000: 4.8 → 5.3, and a
    # propulsion-loss campaign named a lag at z 12.4 against 4.9): the data's acceleration carries a smoothing
    # bias the replicates' does not , and with the data's offset on every target that
    # bias costs the data's fit twice and a replicate's once, which errs towards `none`.
    # Tried again once the release was placed by the first counts (which removed that flight bias): on 42 varied
    # development campaigns (seed 26000) both propulsion-loss campaigns were then named a lag (z 11.7 against
    # 5.8, 9.1 against 4.2; 0.3 and −0.3 with the data's offset), so the data's offset stays.
    # Tried a third time with the sign mended: the lag's null rank on 60 dev nulls rose from 15
    # to 22 of 60, but the per-replicate null is narrower and the test suite's propulsion-loss campaign was named
    # a lag (z 7.2 against 2.1 for the same 0.45 % improvement): the data's own error in every replicate's target
    # had been hiding a lag-like feature of the data that the replicates lack.
    out = [Member({"tau_ms": t, "order": 1, "shape": "first_order"}, chain=_poles(t, 1)) for t in _TAUS_MS]
    out += [Member({"tau_ms": t, "order": 2, "shape": "second_order"}, chain=_poles(t, 2)) for t in _TAUS_MS[:-1]]
    out += [Member({"delay_ms": t, "shape": "delay"}, chain=_delay(t)) for t in _DELAYS_MS]
    return tuple(out)


def _mode_columns(run: _RunView, b: Basis, frequency_hz: float, damping_ratio: float, scale: float,
                  first_order: bool = True) -> np.ndarray:
    # struck when the tip meets the material: the force's contact, not the file's stand-off
    struck = run.seen_contact_s
    tc = np.maximum(b.t - struck, 0.0)
    w0 = 2 * math.pi * frequency_hz
    wd = w0 * math.sqrt(1 - damping_ratio ** 2)
    env = np.where(b.t > struck, np.exp(-damping_ratio * w0 * tc), 0.0) * scale
    sin, cos = env * np.sin(wd * tc), env * np.cos(wd * tc)
    # ``first_order``: with the mode's first-order change in its frequency and its decay rate (∂/∂ω and ∂/∂σ of
    # e^(−σt)·sin(ωt + φ) span t·e^(−σt)·sin and t·e^(−σt)·cos; time in units of the decay time): a mode between
    # two grid frequencies (7.9 % apart) or two damping ratios is followed, not left as a beat.  On the
    # development ringings (``--varied 12 102000 --only rig_ringing``) the verdict's held-out shrink went from a
    # median of 61.6 % to 71.6 %; the exact two-mode form of one of them (dev 0) takes 90 %, the grid 64 %, the
    # grid with these 81 %
    if not first_order:
        return np.column_stack([sin, cos])
    decays = tc * (damping_ratio * w0)
    return np.column_stack([sin, cos, decays * sin, decays * cos])


def _modes(modes: Sequence[tuple[float, float]], by: str) -> Callable[[_RunView, Basis], Columns]:
    def build(run: _RunView, b: Basis) -> Columns:
        if by == "speed":  # struck by the impact: amplitude ∝ contact speed [N per m/s]
            scale = run.contact_speed_m_s
        else:  # struck by the force step at contact: amplitude ∝ the frontal force there [N per N]
            frontal = b.frontal if b.frontal is not None else b.strength
            after = np.flatnonzero(b.inside)
            scale = float(frontal[after[0]]) if after.size else 0.0
        # one mode follows its neighbourhood to first order; two modes keep two columns each: with four each,
        # some development ringings gained more (dev 1 of 102000: 83.5 % against 69.1 %), but diagnoses took 1.4×
        # as long (dev 0, 1, 3, 6: 69.9 s against 49.2 s; 43.1 s with no first-order columns)
        if len(modes) == 1:
            return Columns(_mode_columns(run, b, *modes[0], scale, True))
        built = []
        for f, z in modes:  # the two-mode members share their modes: each is built once per run
            key = ("mode", f, z, scale, run.seen_contact_s)
            if key not in b.memo:
                b.memo[key] = _mode_columns(run, b, f, z, scale, False)
            built.append(b.memo[key])
        return Columns(np.column_stack(built))

    return build


_FREQS_HZ = tuple(150.0 * 40.0 ** (i / 47) for i in range(48))  # 48 geometrically spaced, 150 Hz to 6 kHz
"""Mode frequencies 7.9 % apart: a mode that rings for n cycles drifts n × that in phase at worst (half-way)."""
_ZETAS = (0.01, 0.02, 0.04, 0.08)


def _ringing_members() -> tuple[Member, ...]:
    coarse = _FREQS_HZ[::2]
    out = [Member({"frequency_hz": f, "damping_ratio": z, "modes": 1, "struck_by": "speed"},
                  chain=_modes([(f, z)], "speed")) for z in _ZETAS for f in _FREQS_HZ]
    out += [Member({"frequency_hz": f, "damping_ratio": z, "modes": 1, "struck_by": "force"},
                   chain=_modes([(f, z)], "force")) for z in _ZETAS for f in coarse]
    # two modes of one damping ratio: coarser frequency grid, the second above the first
    out += [Member({"frequency_hz": f1, "second_frequency_hz": f2, "damping_ratio": z, "modes": 2,
                    "struck_by": "speed"}, chain=_modes([(f1, z), (f2, z)], "speed"))
            for z in _ZETAS for i, f1 in enumerate(coarse) for f2 in coarse[i + 2:]]
    return tuple(out)


def _describe_ringing(m: Member, c, ctx) -> dict:
    unit = "n_per_m_s" if m.params["struck_by"] == "speed" else "n_per_n"
    return {**dict(m.params), f"amplitude_{unit}": float(math.hypot(c[0], c[1]))}


def _drift_cols(profile: Callable[[np.ndarray], np.ndarray]) -> Callable[[_RunView, Basis], Columns]:
    return lambda run, b: Columns(profile(np.maximum(b.t, 0.0)))


_DRIFT_TAUS_S = tuple(round(0.005 * 2.0 ** (k / 2), 4) for k in range(16))  # 5 ms to 0.9 s, √2 apart


def _drift_members() -> tuple[Member, ...]:
    out = [Member({"shape": "linear"}, chain=_drift_cols(lambda t: t[:, None])),
           Member({"shape": "quadratic"}, chain=_drift_cols(lambda t: np.column_stack([t, t * t])))]
    out += [Member({"shape": "power", "exponent": p}, chain=_drift_cols(lambda t, p=p: ((t / 0.1) ** p)[:, None]))
            for p in (0.5, 0.75, 1.5)]
    out += [Member({"shape": "exponential", "time_constant_s": tau},
                   chain=_drift_cols(lambda t, tau=tau: -np.expm1(-t / tau)[:, None]))
            for tau in _DRIFT_TAUS_S]
    out += [Member({"shape": "logarithmic", "time_constant_s": tau},
                   chain=_drift_cols(lambda t, tau=tau: np.log1p(t / tau)[:, None]))
            for tau in _DRIFT_TAUS_S]
    return tuple(out)


def _describe_drift(m: Member, c, ctx) -> dict:
    if m.params["shape"] in ("exponential", "logarithmic"):  # amplitude × (1 − e^(−t/τ)) or × ln(1 + t/τ)
        return {**dict(m.params), "amplitude_n": float(c[0])}
    if m.params["shape"] == "power":  # amplitude × (t / 100 ms)^exponent
        return {**dict(m.params), "amplitude_at_100_ms_n": float(c[0])}
    return {**dict(m.params), "rate_n_per_s": float(c[0])}


SHARP_TIP_LAYERS = ("in simulated cone campaigns the diagnosis never tuned on (bench/bench_cone_diagnose.py), the "
                    "layer's edge (a step's, or a plateau's main edge) lay within 5 mm of a true edge for 6 of 7 "
                    "stronger layers and 3 of 3 softer ones, and a plateau's top edge alone for 4 of the 7 stronger; "
                    "read the main edge, and check it against the runs' depths")
"""The strength layer's caveat for a campaign of a penetrator other than the blade."""


EFFECTS: dict[str, Effect] = {e.name: e for e in (
    Effect("strength_layer", "law", "depth",
           "Microstructural strength steps to another value at a depth: a step with a sharp or soft edge, or a "
           "plateau (a layer of finite thickness). Signature: a misfit that jumps at one depth in every run, "
           "whatever its speed.",
           _layer_members, _describe_layer, admissible=_layer_possible,
           caveats=(("cone", SHARP_TIP_LAYERS), ("tapered_blade", SHARP_TIP_LAYERS))),
    Effect("strength_gradient", "law", "depth",
           "Strength varies continuously with depth (power, quadratic, exponential or saturating "
           "profiles, an S-shaped rise or fall wider than a layer's edge, two straight slopes meeting at a depth, "
           "or any non-negative sum of smooth rises, or of falls, 150 mm wide and 50 mm apart). "
           "Signature: a misfit growing smoothly with depth in proportion to the blade's frontal area.",
           _gradient_members, _describe_gradient),
    Effect("plug_growth", "law", "depth",
           "A crushed plug widens the effective frontal thickness with depth (exponential or hyperbolic "
           "saturation, a ramp capped at its final size, or linear): every frontal term grows. Signature: grows with depth, early, and more so "
           "for thin blades relative to their thickness.",
           _plug_members, _describe_plug, geometries=("blade", "tapered_blade")),
    Effect("sidewall_pressure_growth", "law", "depth",
           "Sidewall pressure rises with depth (power laws or saturating): friction grows faster than x. "
           "Signature: a misfit growing with depth, the same for every blade thickness.",
           _pressure_members, _describe_pressure),
    Effect("velocity_friction", "law", "speed",
           "Blade–material friction varies with sliding speed (power, saturating or logarithmic laws, either "
           "sign, or a Stribeck fall with a viscous rise past it). Signature: a misfit in proportion to depth × "
           "a function of speed.",
           _velocity_friction_members, _describe_speed("p_kpa")),
    Effect("rate_strength", "law", "speed",
           "Strength varies with penetration rate (power, saturating or logarithmic laws). Signature: the "
           "strength misfit follows the speed, in proportion to frontal area.",
           partial(_speed_laws, "strength"), _describe_speed("cs_mean")),
    Effect("load_cell_mass_error", "chain", "acceleration",
           "The inertia subtraction used the wrong mass below the load cell. Signature: the 'resistance' follows "
           "the acceleration: non-zero in free flight, jumping at contact.",
           (Member({}, chain=_mass, reads_acceleration=True),),
           lambda m, c, ctx: {"delta_kg": float(c[0]), "ratio": 1.0 + float(c[0]) / ctx["load_cell_mass_kg"]}),
    Effect("sensor_lag", "chain", "contact",
           "The force channel lags the true force: a first- or second-order low-pass, or a pure delay. "
           "Signature: the measured rise at contact is late and rounded; the misfit follows the force's rate "
           "of change.",
           _lag_members, lambda m, c, ctx: dict(m.params)),
    Effect("rig_ringing", "chain", "time",
           "Structural resonances struck at contact: one or two decaying modes, amplitude in proportion to the "
           "contact speed or to the force step. Signature: a decaying oscillation after contact.",
           _ringing_members, _describe_ringing),
    Effect("force_drift", "chain", "time",
           "The force offset drifts during the run (linear, quadratic, a power, exponential or logarithmic in "
           "time since the release). Signature: a misfit growing with time, in flight as much as in the "
           "material.",
           _drift_members, _describe_drift, rest_evidence=True),
    Effect("propulsion_loss", "drive", "flight",
           "The launcher delivers less energy than modelled: a share of it (efficiency × (1 − loss)) or a "
           "friction on the moving body over its travel (the slowest runs lose most). Signature: measured "
           "contact speeds below the predicted ones; resistance with measured kinematics fits, the fully "
           "predicted run does not.",
           (), lambda m, c, ctx: {"loss": float(c[0])}),
)}
"""The catalogue by name (CONTRACT §4)."""


def _hats(values: np.ndarray, knots: np.ndarray) -> np.ndarray:
    """Piecewise-linear hat functions on ``knots`` evaluated at ``values`` (zero outside the knot range)."""
    out = np.zeros((values.size, knots.size))
    for j, k in enumerate(knots):
        left = knots[j - 1] if j > 0 else k
        right = knots[j + 1] if j + 1 < knots.size else k
        up = (values - left) / (k - left) if k > left else (values == k).astype(float)
        down = (right - values) / (right - k) if right > k else (values == k).astype(float)
        out[:, j] = np.clip(np.minimum(up, down), 0.0, 1.0)
    return out


def _depth_profile(run: _RunView, b: Basis) -> Columns:
    x = np.where(b.inside, b.x, -1.0)
    width = run.design.blade_width_m
    if not math.isfinite(width):  # not a blade: the side of a square of the geometry's largest frontal area
        width = math.sqrt(run.geometry.frontal_area_m2(run.design, float(run.design.penetration_depth_m)))
    return Columns(_hats(x, np.arange(0.0, 0.1401, 0.004)) * width * (b.inside[:, None]))


def _time_profile(run: _RunView, b: Basis) -> Columns:
    struck = run.seen_contact_s
    tc = np.where(b.t >= struck, b.t - struck, -1.0)
    return Columns(_hats(tc, np.arange(0.0, 0.0401, 0.001)))


PROBES: dict[str, Effect] = {e.name: e for e in (
    Effect("depth_profile", "probe", "depth",
           "Any force profile in depth shared by the runs (per metre of blade width; hats every 4 mm).",
           (Member({"knots_mm": 4.0}, chain=_depth_profile),), lambda m, c, ctx: dict(m.params)),
    Effect("time_profile", "probe", "time",
           "Any force profile in time since contact shared by the runs (hats every 1 ms).",
           (Member({"knots_ms": 1.0}, chain=_time_profile),), lambda m, c, ctx: dict(m.params)),
)}
"""Generic structure, not catalogue effects: a gap that one of these closes on held-out runs is a gap shared by
the runs (not noise, not one run's accident), whatever its cause.  They decide ``unexplained``."""


INDISTINGUISHABLE: dict[frozenset, str] = {
    frozenset({"strength_gradient", "sidewall_pressure_growth"}):
        "runs of another blade thickness: sidewall friction does not scale with T, frontal strength does",
    frozenset({"strength_gradient", "plug_growth"}):
        "runs of another blade thickness: a plug adds a fixed width, a strength gradient scales with T",
    frozenset({"plug_growth", "sidewall_pressure_growth"}):
        "runs at other contact speeds into the same depths, and deeper than the plug's length: neither force "
        "scales with T (a plug adds a fixed width), but a plug widens the frontal inertia term (K·ρ·v²) and "
        "stops growing, sidewall friction has no speed term and grows on",
    frozenset({"plug_growth", "velocity_friction"}):
        "runs at other contact speeds into the same depths: neither force scales with T (a plug adds a fixed "
        "width), friction follows the sliding speed, a plug mostly the depth",
    frozenset({"rate_strength", "velocity_friction"}):
        "runs at other contact speeds into the same depths, and of another blade thickness",
    frozenset({"strength_layer", "strength_gradient"}):
        "runs reaching past the suspected layer depth, at other speeds",
    frozenset({"force_drift", "load_cell_mass_error"}):
        "a longer free flight (more stand-off) or runs with other launcher energies",
    frozenset({"sensor_lag", "rig_ringing"}):
        "runs at other contact speeds (ringing scales with speed, lag with the force's rate of change)",
}
"""Effects that can look alike, and what run separates them."""
