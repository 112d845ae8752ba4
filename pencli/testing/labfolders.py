"""What the truth worlds share: writing a campaign's runs as a lab would, and the campaign record.

Only I/O lives here; each world's physics, sensor chain and effect forms stay its own.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

import numpy as np
import yaml

ORDER = ("time_s", "position_mm", "fx_n", "fy_n", "fz_n", "tx_nm", "ty_nm", "tz_nm")
"""CONTRACT §3's data columns, in the order a lab's export writes them."""


def write_lab_folder(folder: Path, columns: Mapping[str, np.ndarray], files: Mapping[str, Mapping],
                     time_digits: int = 6) -> Path:
    """A CONTRACT §3 run folder: ``data.csv`` as a text export rounds it (time to ``time_digits`` significant
    digits, the rest to six) and one YAML file per entry of ``files`` (``penetrator``, ``material``,
    ``energizing``, ``run``)."""
    folder.mkdir(parents=True, exist_ok=True)
    data = np.column_stack([columns[c] for c in ORDER])
    fmt = [f"%.{time_digits}g"] + ["%.6g"] * (len(ORDER) - 1)
    np.savetxt(folder / "data.csv", data, delimiter=",", header=",".join(ORDER), comments="", fmt=fmt)
    for kind, mapping in files.items():
        (folder / f"{kind}.yaml").write_text(yaml.safe_dump(dict(mapping), sort_keys=False))
    return folder


@dataclass
class Campaign:
    """A campaign's run folders and its truth (for the bench only; never shown to pen)."""

    folders: list
    effects: list
    nuisances: dict
