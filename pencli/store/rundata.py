"""Hashes of run data, and a raw :class:`~pencli.run.Run` as an Arrow table.

The content hash is taken over the data only (column names and float64
bytes), so the same recording ingested twice is recognised as one run
whatever folder it came from.
"""

from __future__ import annotations

import hashlib
from typing import Mapping

import numpy as np
import pyarrow as pa

from pencli.run import RAW_COLUMNS, Run


def content_hash(columns: Mapping[str, np.ndarray]) -> str:
    """SHA-256 over the raw columns (names, then little-endian float64 bytes)."""
    digest = hashlib.sha256()
    for name in RAW_COLUMNS:
        digest.update(name.encode())
        digest.update(np.ascontiguousarray(columns[name], dtype="<f8").tobytes())
    return digest.hexdigest()


def table_hash(table: pa.Table) -> str:
    """SHA-256 over every column of a stage table (names and buffers), order-sensitive."""
    digest = hashlib.sha256()
    for name in table.column_names:
        digest.update(name.encode())
        column = table.column(name)
        try:
            digest.update(np.ascontiguousarray(column.to_numpy()).tobytes())
        except (pa.ArrowException, ValueError):
            digest.update(str(column.to_pylist()).encode())
    return digest.hexdigest()


def raw_table(run: Run) -> pa.Table:
    """A raw run's columns as an Arrow table (float64 columns, contract names)."""
    return pa.table({name: pa.array(np.asarray(run.columns[name], dtype=np.float64)) for name in RAW_COLUMNS})
