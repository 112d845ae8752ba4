"""``--set KEY=VALUE`` overrides of CONTRACT §1 keys.

Any key of the three kinds may be overridden (``blade_width_mm=150``,
``coefficients.inertia_coefficient=40``); the key says which file it
belongs to.  Pure.
"""

from __future__ import annotations

from typing import Iterable

from pencli.errors import ParameterError
from pencli.params.definitions import BY_KEY, Kind


def parse_overrides(items: Iterable[str]) -> dict[Kind, dict[str, float]]:
    """Parse ``KEY=VALUE`` strings into per-kind updates (file units).

    Raises
    ------
    ParameterError
        Malformed item, unknown key, or a value that is not a number.
    """
    updates: dict[Kind, dict[str, float]] = {}
    for item in items:
        if "=" not in item:
            raise ParameterError(f"--set {item!r}: expected KEY=VALUE, e.g. blade_width_mm=150")
        key, _, text = item.partition("=")
        key, text = key.strip(), text.strip()
        param = BY_KEY.get(key)
        if param is None:
            raise ParameterError(f"--set {item!r}: unknown key '{key}'; valid keys: {', '.join(BY_KEY)}")
        try:
            value: float = float(text)
        except ValueError:
            raise ParameterError(f"--set {item!r}: '{text}' is not a number ({param.unit})") from None
        if param.dtype is int:
            if not value.is_integer():
                raise ParameterError(f"--set {item!r}: {key} must be a whole number")
            value = int(value)
        updates.setdefault(param.kind, {})[key] = value
    return updates
