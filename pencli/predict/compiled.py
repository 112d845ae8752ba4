"""The model core's plain-arithmetic functions, compiled once for the batch kernels (numba), and the options
every kernel is compiled with: cached on disk, releasing the GIL, numpy's float semantics (inf and nan, not
exceptions)."""

from __future__ import annotations

from numba import njit

from pencli.model.design import static_work as _static_work
from pencli.model.flight import reach as _reach
from pencli.model.resistance import reduced as _reduced

JIT = dict(cache=True, nogil=True, error_model="numpy")

reduced = njit(**JIT)(_reduced)
"""Eq. 9 from its four coefficients (:func:`pencli.model.resistance.reduced`)."""
static_work = njit(**JIT)(_static_work)
"""Work of the speed-independent force over depth (:func:`pencli.model.design.static_work`)."""
reach = njit(**JIT)(_reach)
"""The flight's closed form (:func:`pencli.model.flight.reach`)."""

__all__ = ["JIT", "reach", "reduced", "static_work"]
