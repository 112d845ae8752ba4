"""Design-space sweeps on the batch simulator: variables, grids, samples, sensitivity, inverse solves.

Pure: takes the base design as a mapping of CONTRACT §1 keys (file units)
and variable specifications; returns arrays.  Chunking, processes, files and
progress live at the edge (``pencli.api.sweep``).

A variable is any CONTRACT §1 key, or ``speed_at_contact`` [m/s] (BAM's
"speed at comet contact": the flight is skipped and the blade starts at the
surface with that speed).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

import numpy as np
from numba import njit

from pencli.errors import ParameterError
from pencli.model.dynamics import check_contact_speed
from pencli.params.definitions import BY_KEY
from pencli.predict.batch import designs_from
from pencli.predict.compiled import JIT as _JIT

SPEED = "speed_at_contact"
"""The extra sweep variable: speed at contact [m/s]."""


@dataclass(frozen=True)
class Variable:
    """One swept quantity: its key and the values it takes (file units)."""

    key: str
    values: np.ndarray
    discrete: bool = False
    """A set of values (a list, or a whole-number key): a sample draws from the set, not the range."""

    def domain(self) -> tuple[float, float] | np.ndarray:
        """What a sample draws from: the set of values, or the (low, high) range."""
        return self.values if self.discrete else (float(self.values.min()), float(self.values.max()))

    @property
    def unit(self) -> str:
        return "m/s" if self.key == SPEED else BY_KEY[self.key].unit


def parse_vary(spec: str, base: Mapping[str, float], resolution: int, geometry: str = "blade",
               drive: str = "springs") -> Variable:
    """``KEY=+20%,-50%`` (BAM ± deltas), ``KEY=LO:HI`` (range) or ``KEY=V1,V2,...`` (list).

    Percentages are of the base value; ranges and deltas get ``resolution`` points.  ``geometry``: the
    penetrator's, whose keys alone may vary.
    """
    if "=" not in spec:
        raise ParameterError(f"--vary {spec!r}: expected KEY=+20%,-50% or KEY=LO:HI or KEY=V1,V2,...")
    key, _, text = (part.strip() for part in spec.partition("="))
    if key != SPEED and key not in BY_KEY:
        hint = f" (did you mean 'coefficients.{key}'?)" if f"coefficients.{key}" in BY_KEY else ""
        raise ParameterError(f"--vary {spec!r}: unknown key '{key}'{hint}; any CONTRACT §1 key or {SPEED}")
    if key != SPEED and BY_KEY[key].kind == "penetrator" and not BY_KEY[key].belongs_to(geometry):
        raise ParameterError(f"--vary {spec!r}: '{key}' is a dimension of a {' or '.join(BY_KEY[key].geometries)}; "
                             f"this penetrator is a {geometry.replace('_', ' ')}")
    if key != SPEED and BY_KEY[key].kind == "energizing" and not BY_KEY[key].belongs_to(drive):
        raise ParameterError(f"--vary {spec!r}: '{key}' is a key of the {' or '.join(BY_KEY[key].geometries)} "
                             f"drive; this launcher is a {drive.replace('_', ' ')}")
    discrete = False
    try:
        if "%" in text:
            deltas = [float(p.strip().rstrip("%")) / 100.0 for p in text.split(",")]
            if len(deltas) != 2:
                raise ValueError
            lo, hi = sorted(base[key] * (1 + dlt) for dlt in deltas)
            values = np.linspace(lo, hi, resolution)
        elif ":" in text:
            lo, hi = (float(p) for p in text.split(":"))
            values = np.linspace(lo, hi, resolution)
        else:
            values = np.array([float(p) for p in text.split(",")])
            discrete = True
    except (ValueError, KeyError):
        raise ParameterError(f"--vary {spec!r}: could not read the values") from None
    if key == SPEED:
        check_contact_speed(values, f"--vary {spec!r}: speed at contact")
    if key != SPEED and BY_KEY[key].dtype is int:
        values, discrete = np.unique(np.round(values)), True
    return Variable(key, np.asarray(values, dtype=float), discrete)


MAX_DESIGNS = 10 ** 9
"""Largest sweep pen starts (about 100 GB of Parquet and hours of work; a sample covers such spaces)."""

FIGURE_COLUMNS = 13
"""Columns a sweep's table holds per design beside its variables (CONTRACT §5 figures and how it ended)."""


def table_bytes(n_designs: int, n_variables: int) -> int:
    """Size of a sweep's table on disk, from above: every column stored plain, 8 bytes a value. [bytes]"""
    return int(n_designs) * 8 * (int(n_variables) + FIGURE_COLUMNS)


class Grid:
    """Every combination of the variables' values (first variable slowest), made a slice at a time: a grid
    is never held whole, whatever its size."""

    def __init__(self, variables: Sequence[Variable], fixed: Mapping[str, float] | None = None):
        self.variables = tuple(variables)
        self.fixed = dict(fixed or {})
        """Columns of one value for every design (a given speed at contact)."""
        self.shape = tuple(int(v.values.size) for v in self.variables)
        self.size = math.prod(self.shape)

    def take(self, start: int, stop: int) -> dict[str, np.ndarray]:
        """Designs ``start`` to ``stop`` (exclusive) of the grid, as columns."""
        index = np.unravel_index(np.arange(start, stop), self.shape)
        out = {v.key: v.values[i] for v, i in zip(self.variables, index)}
        out.update({k: np.full(stop - start, float(value)) for k, value in self.fixed.items() if k not in out})
        return out


class Sample:
    """``n`` designs by Latin hypercube (``lhs``) or uniform random sampling, made a slice at a time (the
    sweep computes its first chunk while the rest are still undrawn, and never holds the whole table).

    Each key's domain is a (low, high) range, sampled continuously, or an array of values (a list given
    to ``--vary``, or a whole-number key), from which each design takes one value: the strata of the
    hypercube map onto the values in equal shares.  Every random number is a function of the seed, the
    key and the design's index (:func:`drawn`: a counter-based generator), so a design does not depend on
    how the sweep is chunked and nothing is drawn up front; the hypercube's strata are one pseudo-random
    permutation of the designs per key (:func:`permuted`).
    """

    def __init__(self, domains: Mapping[str, tuple[float, float] | np.ndarray], n: int, method: str,
                 seed: int = 0, fixed: Mapping[str, float] | None = None):
        if method not in ("lhs", "random"):
            raise ParameterError(f"--sample {method!r}: expected lhs or random")
        self.domains = {k: (v if isinstance(v, tuple) else np.asarray(v, dtype=float)) for k, v in domains.items()}
        self.size, self.method, self.seed = int(n), method, int(seed)
        self.fixed = {k: float(v) for k, v in (fixed or {}).items() if k not in self.domains}
        # per key: the stream of its uniforms, then the permutation's round keys
        self.keys = np.random.default_rng([self.seed, 0]).integers(0, 2 ** 63, (len(self.domains), 1 + _ROUNDS),
                                                                    dtype=np.uint64)

    def take(self, start: int, stop: int) -> dict[str, np.ndarray]:
        """Designs ``start`` to ``stop`` (exclusive) of the sample, as columns."""
        out = {}
        for i, (key, domain) in enumerate(self.domains.items()):
            lo, span = (domain[0], domain[1] - domain[0]) if isinstance(domain, tuple) else (0.0, 1.0)
            value = drawn(start, stop, self.size, self.keys[i], self.method == "lhs", lo, span)
            out[key] = value if isinstance(domain, tuple) else domain[
                np.minimum((value * domain.size).astype(int), domain.size - 1)]
        out.update({key: np.full(stop - start, value) for key, value in self.fixed.items()})
        return out


_ROUNDS = 4
"""Feistel rounds of :func:`permuted` (four make a pseudo-random permutation from a pseudo-random round
function: Luby and Rackoff)."""

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)


@njit(**_JIT)
def _mix(value: np.uint64) -> np.uint64:
    """splitmix64's finaliser: a 64-bit hash whose every output bit depends on every input bit (a single
    multiply, as a Feistel round, left visible structure: lag-1 correlation 0.006 over 10⁶ designs)."""
    value = (value ^ (value >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    value = (value ^ (value >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return value ^ (value >> np.uint64(31))


@njit(**_JIT)
def _feistel(value, keys, low, shift):
    """One pass of the balanced Feistel network over 2·``shift`` bits (``low``: the half's mask)."""
    left, right = value >> shift, value & low
    for r in range(_ROUNDS):
        left, right = right, left ^ (_mix(right ^ keys[r]) & low)
    return (left << shift) | right


@njit(**_JIT)
def permuted(start: int, stop: int, n: int, keys: np.ndarray) -> np.ndarray:
    """Where a pseudo-random permutation of range(n), drawn by ``keys`` (:data:`_ROUNDS` uint64), sends each
    of start … stop − 1: a balanced Feistel network on the smallest even number of bits that holds n,
    walked again while it lands at n or beyond (a bijection of the larger domain restricted to range(n) by
    cycle walking, so every value below n is hit once).  Any chunk can be evaluated alone. [–]"""
    half = 1
    while (1 << (2 * half)) < n:
        half += 1
    low = np.uint64((1 << half) - 1)
    shift = np.uint64(half)
    out = np.empty(stop - start, dtype=np.uint64)
    for i in range(out.size):  # no branch: the compiler runs several indices side by side
        out[i] = _feistel(np.uint64(start + i), keys, low, shift)
    for i in range(out.size):  # the few that landed outside range(n) (under 3 in 4 at worst) walk on
        while out[i] >= np.uint64(n):
            out[i] = _feistel(out[i], keys, low, shift)
    return out


@njit(**_JIT)
def drawn(start: int, stop: int, n: int, keys: np.ndarray, latin: bool, low: float, span: float) -> np.ndarray:
    """One key's values of designs start … stop − 1 of n, in [low, low + span): uniform (``latin`` false), or
    a Latin hypercube, where design i takes stratum :func:`permuted` (i) of n at a uniform place within it.
    The uniforms are SplitMix64 (the hash :func:`_mix` of ``keys[0]`` + (i + 1)·golden ratio, its top 53
    bits), so each is a function of the design's index alone. [unit of the key]"""
    strata = permuted(start, stop, n, keys[1:]) if latin else np.zeros(0, dtype=np.uint64)
    out = np.empty(stop - start)
    for i in range(out.size):
        u = (_mix(keys[0] + np.uint64(start + i + 1) * _GOLDEN) >> np.uint64(11)) * (1.0 / 9007199254740992.0)
        out[i] = low + ((strata[i] + u) / n if latin else u) * span
    return out


def sample(domains: Mapping[str, tuple[float, float] | np.ndarray], n: int, method: str, seed: int = 0
           ) -> dict[str, np.ndarray]:
    """All ``n`` designs of a :class:`Sample` at once, as columns."""
    return Sample(domains, n, method, seed).take(0, n)


def si_designs(base: Mapping[str, float], columns: Mapping[str, np.ndarray]) -> tuple[dict, np.ndarray | None]:
    """Batch input (SI) from the base mapping and the varied columns (file units); plus speeds at contact.

    A field no column varies stays one 0-d value, which :func:`~pencli.predict.batch.simulate_batch`
    broadcasts without copying it for every design."""
    n = len(next(iter(columns.values()))) if columns else 1
    fields: dict[str, np.ndarray | float] = {}
    for key, param in BY_KEY.items():
        value = columns[key] if key in columns else base.get(key, param.absent)  # a drop's springs: absent, 0
        value = np.asarray(value, dtype=float)
        fields[param.si_name] = value * param.si_scale if param.dtype is not int else value
    for key, param in BY_KEY.items():
        if key in columns:
            _check(param, columns[key])
    speed = columns.get(SPEED)
    if speed is not None:
        speed = np.broadcast_to(np.asarray(speed, dtype=float), (n,))
    elif not any(np.ndim(v) for v in fields.values()):
        fields[next(iter(fields))] = np.broadcast_to(next(iter(fields.values())), (n,))  # n designs, all alike
    return designs_from(fields, equal_length=False), speed


def _check(param, values: np.ndarray) -> None:
    values = np.atleast_1d(np.asarray(values, dtype=float))
    # the allowed values form an interval: when the smallest and the largest pass, all do (a nan makes
    # both nan, which fails); only then is every value looked at, to name the first that fails
    if not (param.hard_violation(float(np.min(values))) or param.hard_violation(float(np.max(values)))):
        return
    bad = param.hard_violation(values)
    if bad.any():
        raise ParameterError(f"sweep: {param.key} takes {values[np.argmax(bad)]:g} {param.unit}; it must be "
                             f"{param.hard_text}")


SENSITIVITY_KEYS = ("blade_width_mm", "blade_thickness_mm", "tip_angle_deg", "spring_mass_kg", "spring_stiffness_kn_m",
                    "spring_nominal_length_mm", "spring_compressed_length_mm", "surface_offset_mm",
                    "penetration_depth_mm")
"""The design variables of the paper's Appendix C study."""


def one_at_a_time(base: Mapping[str, float], keys: Sequence[str], steps: Sequence[float]) -> tuple[list, dict]:
    """Rows (key, relative step) and columns for a one-at-a-time study around ``base``."""
    rows, columns = [], {k: [] for k in keys}
    for key in keys:
        for step in steps:
            rows.append((key, step))
            for k in keys:
                columns[k].append(base[k] * (1 + step) if k == key else base[k])
    return rows, {k: np.array(v) for k, v in columns.items()}


CONDITIONS: dict[str, Callable[[dict, float], np.ndarray]] = {
    "full_penetration": lambda f, x: f["full_penetration"],
    "depth_mm": lambda f, x: f["final_depth_mm"] >= x,
    "peak_n": lambda f, x: f["peak_resistance_n"] <= x,
}
"""Conditions an inverse solve can ask for: reach full depth, reach a depth [mm], stay under a peak [N]."""


def parse_condition(text: str) -> tuple[str, float]:
    """``full_penetration``, ``depth_mm>=100`` or ``peak_n<=2000``."""
    if text == "full_penetration":
        return text, math.nan
    match = re.fullmatch(r"(depth_mm)\s*>=\s*([0-9.eE+-]+)|(peak_n)\s*<=\s*([0-9.eE+-]+)", text.strip())
    if not match:
        raise ParameterError(f"--until {text!r}: expected full_penetration, depth_mm>=VALUE or peak_n<=VALUE")
    name = match.group(1) or match.group(3)
    return name, float(match.group(2) or match.group(4))


def solve_boundary(evaluate: Callable[[np.ndarray], np.ndarray], lo: float, hi: float, want: str,
                   points: int = 64, rounds: int = 4) -> tuple[float | None, float]:
    """The largest (``want='max'``) or smallest (``'min'``) value in [lo, hi] where ``evaluate`` holds.

    ``evaluate`` maps an array of candidate values to a boolean array (the batch simulator does the
    work). Each round evaluates ``points`` values and narrows to the cell where the condition flips,
    assuming it flips once.  Returns (value or None if it never holds, cell width).
    """
    for _ in range(rounds):
        values = np.linspace(lo, hi, points)
        ok = np.asarray(evaluate(values), dtype=bool)
        if not ok.any():
            return None, hi - lo
        if want == "max":
            i = int(np.flatnonzero(ok)[-1])
            if i == points - 1:
                return float(values[i]), 0.0
            lo, hi = values[i], values[i + 1]
        else:
            i = int(np.flatnonzero(ok)[0])
            if i == 0:
                return float(values[0]), 0.0
            lo, hi = values[i - 1], values[i]
    return float(lo if want == "max" else hi), float(hi - lo)


BOUNDARY_HALVINGS = 24
"""Halvings of a grid step each full-penetration crossing is bisected by: it is placed to 2⁻²⁴ (6e-8) of the
step. [–]"""


def boundary_roots(base: Mapping[str, float], x: str, y: str, xs: np.ndarray, ys: np.ndarray, full: np.ndarray,
                   held: Mapping[str, float] | None = None, halvings: int = BOUNDARY_HALVINGS,
                   simulated: np.ndarray | None = None) -> np.ndarray:
    """Where the full-penetration boundary crosses each line of a grid, as (k, 2) points (x, y) in file units.

    ``full`` (len(ys), len(xs)) says which nodes reach full depth (``base`` with ``x``, ``y`` and ``held`` set);
    between two neighbouring nodes that differ, along a row or a column, the crossing is bisected on the batch
    simulator (all crossings in one batch per halving), assuming the design crosses once between them.
    ``simulated`` (same shape; default all) marks the nodes the simulator ran: a node that was not (an invalid
    design) reaches no depth, and the edge of the valid designs is no full-penetration boundary.
    """
    from pencli.predict.chunks import run_chunk

    full = np.asarray(full, dtype=bool)
    ran = np.ones(full.shape, dtype=bool) if simulated is None else np.asarray(simulated, dtype=bool)
    moving, fixed, low, high, low_full = [], [], [], [], []
    for j in range(ys.size):  # along each row: x moves, y is fixed
        for i in np.flatnonzero((full[j, :-1] != full[j, 1:]) & ran[j, :-1] & ran[j, 1:]):
            moving.append(0), fixed.append(ys[j]), low.append(xs[i]), high.append(xs[i + 1]), low_full.append(full[j, i])
    for i in range(xs.size):  # along each column
        for j in np.flatnonzero((full[:-1, i] != full[1:, i]) & ran[:-1, i] & ran[1:, i]):
            moving.append(1), fixed.append(xs[i]), low.append(ys[j]), high.append(ys[j + 1]), low_full.append(full[j, i])
    if not moving:
        return np.empty((0, 2))
    moving, fixed = np.array(moving), np.array(fixed, dtype=float)
    low, high, low_full = np.array(low, dtype=float), np.array(high, dtype=float), np.array(low_full)
    extra = {k: np.full(moving.size, float(v)) for k, v in (held or {}).items()}
    for _ in range(halvings):
        middle = 0.5 * (low + high)
        columns = {x: np.where(moving == 0, middle, fixed), y: np.where(moving == 1, middle, fixed), **extra}
        same = np.asarray(run_chunk(dict(base), columns)["full_penetration"], dtype=bool) == low_full
        low, high = np.where(same, middle, low), np.where(same, high, middle)
    root = 0.5 * (low + high)
    return np.column_stack([np.where(moving == 0, root, fixed), np.where(moving == 1, root, fixed)])
