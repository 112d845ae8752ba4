"""A raw run in memory: the CONTRACT §3 columns plus its parameter sets.

The content hash is taken over the data only (column names and float64
bytes), so the same recording ingested twice is recognised as one run
whatever folder it came from.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np
import pyarrow as pa

from pencli.params.validate import ParameterSet

RAW_COLUMNS: tuple[str, ...] = ("time_s", "position_mm", "fx_n", "fy_n", "fz_n", "tx_nm", "ty_nm", "tz_nm")
"""The data columns of CONTRACT §3, in order."""


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


@dataclass(frozen=True)
class RunData:
    """One recorded run as read from a file or the rig.

    Attributes
    ----------
    columns
        ``RAW_COLUMNS`` → float64 arrays, calibrated and untared, file units
        (s, mm, N, N·m).
    penetrator, material, energizing
        The run's validated parameter sets.
    info
        ``run.yaml`` content (id, date, operator, notes, tags, and anything else).
    source
        Where it came from (folder path, or ``acquire:<driver>``).
    source_format
        ``csv``, ``xlsx`` or ``acquire``.
    reader_options
        Options the reader used (column map, units), kept for provenance.
    """

    columns: Mapping[str, np.ndarray]
    penetrator: ParameterSet
    material: ParameterSet
    energizing: ParameterSet
    info: Mapping[str, Any]
    source: str
    source_format: str
    reader_options: Mapping[str, Any] = field(default_factory=dict)

    @property
    def n_samples(self) -> int:
        """Number of rows."""
        return int(len(self.columns["time_s"]))

    @property
    def sampling_rate_hz(self) -> float:
        """(n − 1)/(t_last − t_first), robust to rounded time stamps (CONTRACT §3). [Hz]"""
        t = self.columns["time_s"]
        return float((t.size - 1) / (t[-1] - t[0]))

    @property
    def duration_s(self) -> float:
        """t_last − t_first. [s]"""
        t = self.columns["time_s"]
        return float(t[-1] - t[0])

    def parameter_sets(self) -> tuple[ParameterSet, ParameterSet, ParameterSet]:
        """(penetrator, material, energizing)."""
        return self.penetrator, self.material, self.energizing

    def to_table(self) -> pa.Table:
        """The raw stage as an Arrow table (float64 columns, contract names)."""
        return pa.table({name: pa.array(np.asarray(self.columns[name], dtype=np.float64)) for name in RAW_COLUMNS})
