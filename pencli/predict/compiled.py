"""The model core's plain-arithmetic functions, compiled once for the batch kernels (numba), and the options
every kernel is compiled with: cached on disk, releasing the GIL, numpy's float semantics (inf and nan, not
exceptions)."""

from __future__ import annotations

import hashlib
from pathlib import Path

from numba import njit

from pencli.model.design import beyond_limit as _beyond_limit
from pencli.model.design import creep_point as _creep_point
from pencli.model.design import force_sizes as _force_sizes
from pencli.model.design import static_work as _static_work
from pencli.model.flight import reach as _reach
from pencli.model.resistance import reduced as _reduced


def drop_stale_kernels(source_dirs, stamp: Path) -> bool:
    """Delete numba's cached kernels (``*.nbi``, ``*.nbc`` in each source folder's ``__pycache__``) when the
    sources there changed since ``stamp`` was written; True if it deleted.

    numba checks a cached function against its own file only, so a kernel that calls a function from
    another module (the batch driver calls the closed form, which calls the model core) ran the old callee
    after an edit or a ``git pull`` of an editable install: found when the batch kept giving bit-identical
    results after the closed form changed.  A read-only install is left alone (its files are never changed
    in place; a reinstall rewrites them all, which numba does notice).
    """
    sources = sorted(p for d in source_dirs for p in Path(d).glob("*.py"))
    digest = hashlib.sha256(b"".join(p.name.encode() + p.read_bytes() for p in sources)).hexdigest()
    try:
        if stamp.read_text() == digest:
            return False
    except OSError:
        pass
    try:
        for folder in source_dirs:
            for cached in (Path(folder) / "__pycache__").glob("*.nb[ic]"):
                cached.unlink()
        stamp.parent.mkdir(parents=True, exist_ok=True)
        stamp.write_text(digest)
    except OSError:
        return False
    return True


_HERE = Path(__file__).resolve().parent
drop_stale_kernels([_HERE, _HERE.parent / "model"], _HERE / "__pycache__" / "kernels.sha256")  # before any njit


JIT = dict(cache=True, nogil=True, error_model="numpy")

reduced = njit(**JIT)(_reduced)
"""Eq. 9 from its four coefficients (:func:`pencli.model.resistance.reduced`)."""
static_work = njit(**JIT)(_static_work)
"""Work of the speed-independent force over depth (:func:`pencli.model.design.static_work`)."""
reach = njit(**JIT)(_reach)
"""The flight's closed form (:func:`pencli.model.flight.reach`)."""
force_sizes = njit(**JIT)(_force_sizes)
"""The model's force scales (:func:`pencli.model.design.force_sizes`)."""
creep_point = njit(**JIT)(_creep_point)
"""Where a heavily damped run is said to creep (:func:`pencli.model.design.creep_point`)."""
beyond_limit = njit(**JIT)(_beyond_limit)
"""A force beyond float64's useful range (:func:`pencli.model.design.beyond_limit`)."""

__all__ = ["JIT", "beyond_limit", "creep_point", "drop_stale_kernels", "force_sizes", "reach", "reduced",
           "static_work"]
