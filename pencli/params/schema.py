"""JSON Schemas of the three parameter kinds, derived from the definitions.

``schema/<kind>.schema.json`` in the repository is this module's output;
a test regenerates it and compares, so the files cannot drift from the
definitions.  Only the hard bounds are in the schema (they are absolute);
the documented range is given as ``x-range`` for tools that care.
"""

from __future__ import annotations

from typing import Any

from pencli.params.definitions import (
    COEFFICIENT_NAMES,
    COVARIANCE_KEY,
    EITHER_OR,
    VARIANTS,
    OPTIONAL_TOP_KEYS,
    RANGE_KEYS,
    Kind,
    Param,
    choices_of,
    params_of,
)


def _property(param: Param) -> dict[str, Any]:
    prop: dict[str, Any] = {
        "type": "integer" if param.dtype is int else "number",
        "description": f"{param.symbol}: {param.meaning} [{param.unit}]",
        "x-unit": param.unit,
        "x-range": [param.range_min, param.range_max],
    }
    if param.hard_min is not None:
        prop["exclusiveMinimum" if param.hard_min_exclusive else "minimum"] = param.hard_min
    if param.hard_max is not None:
        prop["exclusiveMaximum" if param.hard_max_exclusive else "maximum"] = param.hard_max
    if param.default is not None:
        prop["default"] = param.default
    return prop


def json_schema(kind: Kind) -> dict[str, Any]:
    """JSON Schema (draft 2020-12) of one parameter-file kind."""
    properties: dict[str, Any] = {
        "kind": {"const": kind},
        "name": {"type": "string", "minLength": 1},
    }
    for key, meaning in OPTIONAL_TOP_KEYS.items():
        properties[key] = {"type": "string", "description": meaning}
    for choice in choices_of(kind):
        properties[choice.key] = {"enum": list(choice.options), "default": choice.default, "description": choice.help}
    required = ["kind", "name"]
    nested: dict[str, Any] = {}
    for param in params_of(kind):
        if "." in param.key:
            group, sub = param.key.split(".", 1)
            nested.setdefault(group, {})[sub] = _property(param)
            continue
        properties[param.key] = _property(param)
        if param.required and param.key not in EITHER_OR and not param.geometries:
            required.append(param.key)
    for group, props in nested.items():
        properties[group] = {"type": "object", "properties": props, "additionalProperties": False}
    if kind == "material":
        pair = {"type": "array", "items": {"type": "number"}, "minItems": 2, "maxItems": 2}
        properties["fitted_ranges"] = {
            "type": "object", "description": "what `pen fit` saw: [min, max] per quantity (predict warns outside)",
            "properties": {key: {**pair, "x-unit": unit} for key, unit in RANGE_KEYS.items()},
            "additionalProperties": False}
        coefficients = list(COEFFICIENT_NAMES)
        properties[COVARIANCE_KEY] = {
            "type": "object", "description": "the fitted coefficients' covariance, written by `pen fit` (file units; "
                                             "`pen predict --plot` draws a prediction band from it)",
            "propertyNames": {"enum": coefficients},
            "additionalProperties": {"type": "object", "propertyNames": {"enum": coefficients},
                                     "additionalProperties": {"type": "number"}}}
    either = [(primary, alternative) for primary, (alternative, _) in EITHER_OR.items()
              if any(p.key == primary and not p.geometries for p in params_of(kind))]
    rules = [_one_of(a, b) for a, b in either]  # a variant's own pairs are in its rule
    if kind in VARIANTS:
        rules += [_variant_rule(kind, name) for name in VARIANTS[kind][1]]
    extra = {"allOf": rules} if rules else {}
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": f"https://pen.invalid/schema/{kind}.schema.json",
        "title": f"pen {kind} parameter file (CONTRACT §1)",
        "type": "object",
        "properties": properties,
        "required": required,
        "additionalProperties": False,
        **extra,
    }


def _variant_rule(kind: Kind, geometry: str) -> dict[str, Any]:
    """A file of ``geometry`` (or drive: ``geometry:`` or ``drive:`` names it, or, for the default, gives none)
    must give that variant's required keys and none of another's."""
    choice, _, default = VARIANTS[kind]
    named = {"properties": {choice: {"const": geometry}}, "required": [choice]}
    condition = ({"anyOf": [{"not": {"required": [choice]}}, named]} if geometry == default else named)
    own = params_of(kind, geometry)
    foreign = [p.key for p in params_of(kind) if p not in own] + [
        c.key for c in choices_of(kind) if not c.belongs_to(geometry)]
    pairs = [_one_of(p.key, EITHER_OR[p.key][0]) for p in own if p.geometries and p.key in EITHER_OR]
    return {"if": condition,
            "then": {"required": [p.key for p in own if p.geometries and p.required and p.key not in EITHER_OR],
                     "properties": {key: False for key in foreign}, **({"allOf": pairs} if pairs else {})}}


def _one_of(key: str, alternative: str) -> dict[str, Any]:
    """Exactly one of a required key and its alternative (:data:`EITHER_OR`)."""
    return {"oneOf": [{"required": [key]}, {"required": [alternative]}]}
