"""Writing simulated trajectories as Parquet, self-describing.

The file's key-value metadata carries ``pen:*`` keys: pen version, model,
terms, the three parameter sets and the summary, so a Parquet file alone
says how it was made.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Mapping

import pyarrow as pa
import pyarrow.parquet as pq

from pencli import __version__
from pencli.io.atomic import write_atomic
from pencli.model.dynamics import PHASES, SimulationResult


def trajectory_table(result: SimulationResult, metadata: Mapping[str, object] | None = None) -> pa.Table:
    """The trajectory as an Arrow table, phase as a dictionary-encoded string."""
    columns = result.trajectory.columns()
    phase_codes = columns.pop("phase")
    arrays = {name: pa.array(values, type=pa.float64()) for name, values in columns.items()}
    arrays["phase"] = pa.DictionaryArray.from_arrays(pa.array(phase_codes, type=pa.int8()), pa.array(PHASES))
    meta = {
        "pen:version": __version__,
        "pen:model": result.model,
        "pen:terms": json.dumps(list(result.terms)),
        "pen:summary": json.dumps(result.summary.to_dict()),
    }
    for key, value in (metadata or {}).items():
        meta[f"pen:{key}"] = value if isinstance(value, str) else json.dumps(value)
    return pa.table(arrays).replace_schema_metadata(meta)


def write_trajectory(result: SimulationResult, path: str | Path,
                     metadata: Mapping[str, object] | None = None) -> Path:
    """Write the trajectory to ``path`` (Parquet, zstd), atomically."""
    table = trajectory_table(result, metadata)
    return write_atomic(path, lambda tmp: pq.write_table(table, tmp, compression="zstd"))
