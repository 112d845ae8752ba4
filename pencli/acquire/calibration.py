"""Calibration files of the rig: encoder counts per mm, and the load cell's 6×6 matrix.

The force calibration reads ATI-style ``.cal`` XML (six ``Axis``/``UserAxis``
rows of ``values``) or a YAML file with ``matrix:`` (6 rows of 6).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from pencli.errors import ParameterError
from pencli.params.load import read_yaml

AXES = ("Fx", "Fy", "Fz", "Tx", "Ty", "Tz")


@dataclass(frozen=True)
class PositionCalibration:
    """Encoder counts per millimetre of travel (down positive)."""

    counts_per_mm: float
    source: str

    def to_mm(self, counts: np.ndarray) -> np.ndarray:
        """Counts → position from the first sample's count. [mm]"""
        return (np.asarray(counts, dtype=float) - float(counts[0])) / self.counts_per_mm


@dataclass(frozen=True)
class ForceCalibration:
    """6×6 matrix from gauge volts to (Fx, Fy, Fz [N], Tx, Ty, Tz [N·m])."""

    matrix: np.ndarray
    source: str

    def apply(self, volts: np.ndarray) -> np.ndarray:
        """(n, 6) volts → (n, 6) forces and torques."""
        return np.asarray(volts, dtype=float) @ self.matrix.T


def _default(name: str) -> Path:
    return Path(str(resources.files("pencli.acquire.data").joinpath(name)))


def provenance(path: Path) -> str:
    """How a file is named in a run's record: ``bundled:<name>`` for pen's own data files (the same on every
    machine; no install path in a catalog), else the path as given."""
    return f"bundled:{path.name}" if path == _default(path.name) else str(path)


def load_position_calibration(path: str | Path | None = None) -> PositionCalibration:
    """Read a position calibration (YAML with ``counts_per_mm``); default: the bundled encoder."""
    path = Path(path) if path is not None else _default("encoder_default.yaml")
    data = read_yaml(path)
    if not isinstance(data, dict) or "counts_per_mm" not in data:
        raise ParameterError(f"{path}: expected a mapping with counts_per_mm")
    value = data["counts_per_mm"]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
        raise ParameterError(f"{path}: key 'counts_per_mm': got {value!r}; expected a number > 0")
    return PositionCalibration(float(value), provenance(path))


def load_force_calibration(path: str | Path | None = None) -> ForceCalibration:
    """Read an ATI-style ``.cal`` (XML) or a YAML ``matrix:`` file; default: the bundled one."""
    path = Path(path) if path is not None else _default("ft_default.cal")
    if not path.is_file():
        raise ParameterError(f"{path}: no such calibration file")
    if path.suffix.lower() in (".yaml", ".yml"):
        data = read_yaml(path)
        rows = data.get("matrix") if isinstance(data, dict) else None
    else:
        try:
            root = ET.parse(path).getroot()
        except ET.ParseError as exc:
            raise ParameterError(f"{path}: not a valid calibration XML: {exc}") from None
        found = {el.get("Name"): el.get("values") for el in root.iter() if el.tag in ("Axis", "UserAxis")}
        missing = [a for a in AXES if a not in found]
        if missing:
            raise ParameterError(f"{path}: missing calibration axis {missing[0]}; expected rows {', '.join(AXES)}")
        try:
            rows = [[float(v) for v in found[a].split()] for a in AXES]
        except (AttributeError, ValueError):
            raise ParameterError(f"{path}: calibration values must be numbers") from None
    try:
        matrix = np.array(rows, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError(f"{path}: calibration matrix must be numbers") from None
    if matrix.shape != (6, 6):
        raise ParameterError(f"{path}: calibration matrix is {matrix.shape}; expected 6 rows of 6 values")
    if not np.all(np.isfinite(matrix)) or abs(np.linalg.det(matrix)) < 1e-12:
        raise ParameterError(f"{path}: calibration matrix is singular or not finite")
    return ForceCalibration(matrix, provenance(path))
