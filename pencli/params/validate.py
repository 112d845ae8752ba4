"""Validation of parameter mappings against :mod:`pencli.params.definitions`.

Pure: takes the mapping a YAML reader produced and the name of where it came
from (used in messages), returns a :class:`ParameterSet` or raises
:class:`~pencli.errors.ParameterError` with one line naming the source, the
key, the value received and what is valid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Mapping

from pencli.errors import ParameterError
from pencli.params.definitions import (
    CHOICE_BY_KEY,
    COEFFICIENT_NAMES,
    COVARIANCE_KEY,
    EITHER_OR,
    BY_KEY,
    KINDS,
    OPTIONAL_TOP_KEYS,
    RANGE_KEYS,
    DEFAULT_DRIVE,
    DEFAULT_GEOMETRY,
    VARIANTS,
    RULES,
    Kind,
    Param,
    choices_of,
    params_of,
)


@dataclass(frozen=True)
class ParameterSet:
    """A validated parameter file: values in the file's units, by dotted key.

    Attributes
    ----------
    kind
        ``penetrator``, ``material`` or ``energizing``.
    name
        The ``name:`` of the file.
    values
        Validated values by key (``coefficients.*`` flattened), file units.
    source
        Where it came from: a path, ``preset:NAME``, or a description.
    notes
        The optional ``notes:`` text.
    """

    kind: Kind
    name: str
    values: Mapping[str, float]
    source: str = "<memory>"
    notes: str = ""
    overrides: Mapping[str, float] = field(default_factory=dict)
    fitted_ranges: Mapping[str, tuple[float, float]] | None = None
    """Material files from ``pen fit``: what the fit saw, for ``predict`` to warn outside it."""
    coefficient_covariance: Mapping[str, Mapping[str, float]] | None = None
    """Material files from ``pen fit``: the fitted coefficients' covariance (file units), for ``predict``'s band."""
    choices: Mapping[str, str] = field(default_factory=dict)
    """The named choices the file gives (``geometry:``, ``cone_area:``), as written; absent ones take their
    defaults (:meth:`choice`)."""

    @property
    def geometry(self) -> str:
        """The penetrator's geometry (:data:`~pencli.params.definitions.GEOMETRY_NAMES`; ``blade`` unless the file
        names another)."""
        return self.choices.get("geometry", DEFAULT_GEOMETRY)

    @property
    def drive(self) -> str:
        """The launcher's drive (:data:`~pencli.params.definitions.DRIVE_NAMES`; ``springs`` unless the file names
        another)."""
        return self.choices.get("drive", DEFAULT_DRIVE)

    @property
    def variant(self) -> str | None:
        """The geometry of a penetrator file, the drive of an energizing file, None for a material file."""
        return {"penetrator": self.geometry, "energizing": self.drive}.get(self.kind)

    def choice(self, key: str) -> str:
        """A named choice's value, or its default."""
        return self.choices.get(key, CHOICE_BY_KEY[key].default)

    def get(self, key: str, default: float | None = None) -> float | None:
        """Value of ``key`` in file units, or ``default`` when absent."""
        return self.values.get(key, default)

    def to_mapping(self) -> dict[str, Any]:
        """The nested mapping of CONTRACT §1, ready to dump as YAML."""
        out: dict[str, Any] = {"kind": self.kind, "name": self.name}
        if self.notes:
            out["notes"] = self.notes
        out.update(self.choices)
        derived = {primary for primary, (alternative, _) in EITHER_OR.items() if alternative in self.values}
        for param in params_of(self.kind):
            if param.key not in self.values or param.key in derived:
                continue
            value = self.values[param.key]
            if "." in param.key:
                group, sub = param.key.split(".", 1)
                out.setdefault(group, {})[sub] = value
            else:
                out[param.key] = value
        if self.fitted_ranges:
            out["fitted_ranges"] = {k: list(v) for k, v in self.fitted_ranges.items()}
        if self.coefficient_covariance:
            out[COVARIANCE_KEY] = {k: dict(row) for k, row in self.coefficient_covariance.items()}
        return out

    def with_values(self, updates: Mapping[str, float], *, allow_out_of_range: bool = False,
                    source_note: str = "--set") -> "ParameterSet":
        """A new set with ``updates`` applied and the whole set re-validated."""
        merged = dict(self.values)
        for primary, (alternative, _) in EITHER_OR.items():  # setting one of a pair replaces the other
            if primary in updates:
                merged.pop(alternative, None)
            if alternative in updates:
                merged.pop(primary, None)
        merged.update(updates)
        mapping = replace(self, values=merged).to_mapping()
        checked = validate_mapping(mapping, f"{self.source} ({source_note})", expected_kind=self.kind,
                                   allow_out_of_range=allow_out_of_range)
        all_overrides = dict(self.overrides)
        all_overrides.update(updates)
        return replace(checked, source=self.source, overrides=all_overrides)


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def check_value(param: Param, value: Any, where: str, *, allow_out_of_range: bool = False) -> float:
    """Check one value against its definition; return it as ``float`` (or ``int``).

    Raises
    ------
    ParameterError
        Wrong type, NaN/inf, a hard bound broken, or outside the documented
        range without ``allow_out_of_range``.
    """
    if not _is_number(value):
        raise ParameterError(
            f"{where}: key '{param.key}': got {value!r} ({type(value).__name__}); "
            f"expected a {'whole number' if param.dtype is int else 'number'} in {param.unit}")
    if param.dtype is int and (isinstance(value, float) and not value.is_integer()):
        raise ParameterError(f"{where}: key '{param.key}': got {value!r}; expected a whole number")
    number = int(value) if param.dtype is int else float(value)
    if isinstance(number, float) and not math.isfinite(number):
        raise ParameterError(f"{where}: key '{param.key}': got {value!r}; expected a finite number")
    if param.hard_violation(number):
        raise ParameterError(
            f"{where}: key '{param.key}': got {value!r} {param.unit}; must be {param.hard_text}")
    if not allow_out_of_range and param.outside_range(number):
        raise ParameterError(
            f"{where}: key '{param.key}': got {value!r} {param.unit}; outside the documented range "
            f"{param.range_text} (pass --allow-out-of-range to accept it)")
    return number


def validate_mapping(data: Any, source: str, *, expected_kind: Kind | None = None,
                     allow_out_of_range: bool = False) -> ParameterSet:
    """Validate the mapping of one parameter file (CONTRACT §1).

    Parameters
    ----------
    data
        What the YAML reader returned.
    source
        Name for messages (file path or preset name).
    expected_kind
        When given, a file of another kind is an error.
    allow_out_of_range
        Accept values outside the documented range (hard bounds still hold).

    Returns
    -------
    ParameterSet
    """
    if not isinstance(data, Mapping):
        raise ParameterError(
            f"{source}: expected a mapping of keys (kind:, name:, ...), got {type(data).__name__}")
    kind = data.get("kind")
    if kind not in KINDS:
        raise ParameterError(f"{source}: key 'kind': got {kind!r}; expected one of {', '.join(KINDS)}")
    if expected_kind is not None and kind != expected_kind:
        raise ParameterError(f"{source}: key 'kind': got {kind!r}; expected {expected_kind!r} here")
    name = data.get("name")
    if not isinstance(name, str) or not name.strip():
        raise ParameterError(f"{source}: key 'name': got {name!r}; expected a non-empty string")
    notes = data.get("notes", "")
    if not isinstance(notes, str):
        raise ParameterError(f"{source}: key 'notes': got {notes!r}; expected a string")

    geometry, choices = _choices(data, kind, source)
    fitted_ranges = covariance = None
    if "fitted_ranges" in data and kind == "material":
        fitted_ranges = _fitted_ranges(data["fitted_ranges"], source)
    if COVARIANCE_KEY in data and kind == "material":
        covariance = _covariance(data[COVARIANCE_KEY], source)
    flat: dict[str, Any] = {}
    for key, value in data.items():
        if key in ("kind", "name") or key in OPTIONAL_TOP_KEYS or key in choices or (
                key in ("fitted_ranges", COVARIANCE_KEY) and kind == "material"):
            continue
        if key == "coefficients" and kind == "material":
            if value is None:
                continue
            if not isinstance(value, Mapping):
                raise ParameterError(
                    f"{source}: key 'coefficients': got {value!r}; expected a mapping of coefficients")
            for sub, subvalue in value.items():
                flat[f"coefficients.{sub}"] = subvalue
        else:
            flat[str(key)] = value

    known = {p.key: p for p in params_of(kind, geometry)}
    for key in flat:
        if key not in known:
            raise ParameterError(f"{source}: {_unknown(key, kind, geometry)}; valid {kind} keys"
                                 f"{f' of a {geometry}' if kind in VARIANTS else ''}: "
                                 f"{', '.join([*(c.key for c in choices_of(kind, geometry)), *known])}")

    for primary, (alternative, _) in EITHER_OR.items():
        if primary in known and primary in flat and alternative in flat:
            raise ParameterError(f"{source}: keys '{primary}' and '{alternative}': give one, never both "
                                 f"({known[alternative].meaning})")
    values: dict[str, float] = {}
    for param in known.values():
        if param.key not in flat:
            if param.key in EITHER_OR and EITHER_OR[param.key][0] in flat:
                continue  # derived below from its alternative
            if param.required:
                alternative = f" or '{EITHER_OR[param.key][0]}'" if param.key in EITHER_OR else ""
                raise ParameterError(
                    f"{source}: missing key '{param.key}' ({param.meaning}, {param.unit}){alternative}")
            if param.default is not None:
                values[param.key] = param.default
            continue
        values[param.key] = check_value(param, flat[param.key], source,
                                        allow_out_of_range=allow_out_of_range)

    for primary, (alternative, derive) in EITHER_OR.items():
        if primary in known and primary not in values and alternative in values:
            try:
                values[primary] = check_value(known[primary], derive(values), f"{source} ({alternative})",
                                              allow_out_of_range=allow_out_of_range)
            except ParameterError as exc:
                raise ParameterError(f"{exc} (derived from {alternative})") from None
    for rule in RULES:
        if rule.kind == kind and not rule.holds(values):
            first = rule.keys[0]
            shown = ", ".join(f"{k}={values[k]:g}" for k in rule.keys)
            raise ParameterError(f"{source}: key '{first}': got {shown}; {first} {rule.message}")
    return ParameterSet(kind=kind, name=name, values=values, source=source, notes=notes, fitted_ranges=fitted_ranges,
                        coefficient_covariance=covariance, choices=choices)


def _choices(data: Mapping, kind: Kind, source: str) -> tuple[str, dict[str, str]]:
    """(the file's geometry or drive, :data:`VARIANTS`, or "" for a kind without variants; the named choices the
    file gives), each checked against its options."""
    given: dict[str, str] = {}
    for choice in choices_of(kind):
        if choice.key not in data:
            continue
        value = data[choice.key]
        if value not in choice.options:
            raise ParameterError(f"{source}: key '{choice.key}': got {value!r}; expected one of "
                                 f"{', '.join(choice.options)} ({choice.meaning})")
        given[choice.key] = str(value)
    choice, _, default = VARIANTS.get(kind, ("", (), ""))
    variant = given.get(choice, default)
    for key in given:
        if not CHOICE_BY_KEY[key].belongs_to(variant):
            raise ParameterError(f"{source}: {_unknown(key, kind, variant)}")
    return variant, given


def _unknown(key: str, kind: Kind, geometry: str) -> str:
    """Why ``key`` is not a key of this file: unknown, another kind's, or another geometry's."""
    other = BY_KEY.get(key) or CHOICE_BY_KEY.get(key)
    if other is None:
        return f"unknown key '{key}'"
    if other.kind != kind:
        return f"unknown key '{key}' (it belongs in a {other.kind} file)"
    choice = VARIANTS[kind][0]
    return (f"key '{key}' is not a {geometry}'s (a key of {' or '.join(other.geometries)}: set {choice}: "
            f"{other.geometries[0]})")


def _covariance(value: Any, source: str) -> dict[str, dict[str, float]]:
    """``coefficient_covariance:`` checked: coefficient names, every pair given, finite numbers, symmetric,
    variances ≥ 0."""
    names = COEFFICIENT_NAMES

    def where(*parts: str) -> str:
        return f"{source}: key '{'.'.join((COVARIANCE_KEY, *parts))}'"

    if not isinstance(value, Mapping) or not value:
        raise ParameterError(f"{where()}: expected a mapping of coefficient → coefficient → covariance")
    keys = [str(k) for k in value]
    for key in keys:
        if key not in names:
            raise ParameterError(f"{where(key)}: unknown coefficient; coefficients: {', '.join(names)}")
    out: dict[str, dict[str, float]] = {}
    for a in keys:
        row = value[a]
        if not isinstance(row, Mapping) or sorted(str(k) for k in row) != sorted(keys):
            raise ParameterError(f"{where(a)}: expected a value for each of {', '.join(keys)}")
        out[a] = {}
        for b in keys:
            v = row[b]
            if not _is_number(v) or not math.isfinite(v):
                raise ParameterError(f"{where(a, b)}: got {v!r}; expected a finite number")
            out[a][b] = float(v)
    for i, a in enumerate(keys):
        if out[a][a] < 0:
            raise ParameterError(f"{where(a, a)}: got {out[a][a]!r}; a variance is ≥ 0")
        for b in keys[i + 1:]:
            if not math.isclose(out[a][b], out[b][a], rel_tol=1e-9, abs_tol=1e-300):
                raise ParameterError(f"{where(a, b)}: got {out[a][b]!r} but {b}.{a} is {out[b][a]!r}; a "
                                     f"covariance is symmetric")
    return out


def _fitted_ranges(value: Any, source: str) -> dict[str, tuple[float, float]]:
    if not isinstance(value, Mapping):
        raise ParameterError(f"{source}: key 'fitted_ranges': expected a mapping of [min, max] pairs")
    out = {}
    for key, pair in value.items():
        if key not in RANGE_KEYS:
            raise ParameterError(f"{source}: key 'fitted_ranges.{key}': unknown; valid: {', '.join(RANGE_KEYS)}")
        if (not isinstance(pair, (list, tuple)) or len(pair) != 2
                or not all(_is_number(v) and math.isfinite(v) for v in pair) or pair[0] > pair[1]):
            raise ParameterError(f"{source}: key 'fitted_ranges.{key}': got {pair!r}; expected [min, max]")
        out[key] = (float(pair[0]), float(pair[1]))
    return out


def sets_from_mappings(params: Mapping[str, dict], run_id: str) -> tuple[ParameterSet, ParameterSet, ParameterSet]:
    """The (penetrator, material, energizing) sets a run's catalogue row stores, validated as files are but
    allowed outside the documented ranges (the run happened)."""
    return tuple(validate_mapping(params[kind], f"run {run_id} ({kind})", expected_kind=kind,
                                  allow_out_of_range=True) for kind in ("penetrator", "material", "energizing"))
