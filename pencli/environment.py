"""Settings read from the environment (``PEN_*``), each checked as a parameter file's value is: a bad one is
one line naming the variable, what it holds and what was expected."""

from __future__ import annotations

import math
import os
from typing import Callable, TypeVar

Number = TypeVar("Number", int, float)


def number_from_environment(name: str, kind: Callable[[str], Number], low: Number, high: Number, default: Number,
                            expected: str, error: type[Exception]) -> Number:
    """The number in the environment variable ``name`` (``kind``: int or float), ``default`` when it is unset
    or blank; ``error`` with one line when it is not a number from ``low`` to ``high`` (``expected`` says
    what it means, e.g. "seconds to wait for a locked workspace")."""
    text = os.environ.get(name)
    if text is None or not text.strip():
        return default
    try:
        value = kind(text)
    except ValueError:
        value = math.nan
    if not low <= value <= high:
        whole = "a whole number" if kind is int else "a number"
        raise error(f"{name}={text!r}: expected {expected}, {whole} from {low:g} to {high:g} (default {default:g})")
    return value
