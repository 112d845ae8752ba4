"""Reading and writing CONTRACT §3 run folders.

A run folder holds ``data.csv`` or ``data.xlsx`` and the three parameter
files (``run.yaml`` optional).  Data readers are registered by file suffix
in :data:`READERS`.

Why these readers: CSV goes through ``pyarrow.csv`` (multi-threaded C++,
about 6 ms for 15,000 × 8 values).  xlsx goes through ``python-calamine``
(a Rust reader): 0.16 s for 30,000 × 8 cells on this machine where
``pandas.read_excel`` with openpyxl takes 1.3 s (``bench/bench_ingest.py``
measures both in the same run).
"""

from __future__ import annotations

import os
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from pencli.errors import DataError, ParameterError
from pencli.io.checks import SensorRange, UnitScales, check_run_columns, check_units
from pencli.io.atomic import honour_umask
from pencli.params.load import read_yaml, resolve
from pencli.params.validate import ParameterSet
from pencli.run import RAW_COLUMNS, Run

DATA_NAMES = ("data.csv", "data.xlsx")
PARAMETER_FILES = {"penetrator": "penetrator.yaml", "material": "material.yaml", "energizing": "energizing.yaml"}

SHORT_NAMES = {"time": "time_s", "position": "position_mm", "fx": "fx_n", "fy": "fy_n", "fz": "fz_n",
               "tx": "tx_nm", "ty": "ty_nm", "tz": "tz_nm"}

UNITS: dict[str, dict[str, float]] = {
    "time": {"s": 1.0, "ms": 1e-3},
    "position": {"mm": 1.0, "m": 1e3, "cm": 10.0, "in": 25.4},
    "force": {"N": 1.0, "kN": 1e3, "lbf": 4.4482216152605},
    "torque": {"Nm": 1.0, "N·m": 1.0, "N-m": 1.0, "Nmm": 1e-3, "lbf-in": 0.1129848290276167},
}
"""Factors from a file's unit to the contract's (s, mm, N, N·m)."""


@dataclass(frozen=True)
class ReadOptions:
    """How to read a data file: column map (contract name → header) and units."""

    columns: Mapping[str, str] = field(default_factory=dict)
    time_unit: str = "s"
    position_unit: str = "mm"
    force_unit: str = "N"
    torque_unit: str = "Nm"
    sensor: SensorRange = SensorRange()
    allow_out_of_range: bool = False
    """Accept parameter values outside their documented range (hard bounds still hold)."""
    allow_implausible_units: bool = False
    """Accept a run whose travel or force is far off its parameter files' scale (recorded in provenance)."""

    def as_record(self) -> dict[str, Any]:
        """For provenance."""
        return {"columns": dict(self.columns), "time_unit": self.time_unit, "position_unit": self.position_unit,
                "force_unit": self.force_unit, "torque_unit": self.torque_unit,
                **({"allow_out_of_range": True} if self.allow_out_of_range else {}),
                **({"allow_implausible_units": True} if self.allow_implausible_units else {})}


def parse_column_map(text: str | None) -> dict[str, str]:
    """``time=Time (s),position=Pos [mm],fz=Fz`` → {contract name: header}."""
    if not text:
        return {}
    out: dict[str, str] = {}
    for item in text.split(","):
        if "=" not in item:
            raise ParameterError(f"--columns {item!r}: expected NAME=HEADER, e.g. time=Time,fz=Force Z")
        key, _, header = item.partition("=")
        key = key.strip()
        name = SHORT_NAMES.get(key, key)
        if name not in RAW_COLUMNS:
            raise ParameterError(f"--columns {item!r}: unknown column '{key}'; expected one of "
                                 f"{', '.join(SHORT_NAMES)}")
        out[name] = header.strip()
    return out


def unit_factor(quantity: str, unit: str) -> float:
    """Factor from ``unit`` to the contract unit of ``quantity``."""
    table = UNITS[quantity]
    if unit not in table:
        raise ParameterError(f"--{quantity}-unit {unit!r}: expected one of {', '.join(table)}")
    return table[unit]


# ---------------------------------------------------------------------------- data readers
def read_csv_data(path: Path) -> tuple[list[str], dict[str, np.ndarray]]:
    """Header and float64 columns of a CSV file."""
    import pyarrow as pa
    import pyarrow.csv as pacsv

    try:
        table = pacsv.read_csv(path, read_options=pacsv.ReadOptions(block_size=1 << 24),
                               convert_options=pacsv.ConvertOptions(strings_can_be_null=False))
    except UnicodeDecodeError:
        raise DataError(f"{path}: {_first_non_utf8(path)}") from None
    except pa.ArrowInvalid as exc:
        text = str(exc)
        if "invalid UTF8" in text or "invalid utf8" in text.lower():
            raise DataError(f"{path}: {_first_non_utf8(path)}") from None
        if "Empty CSV file" in text:
            raise DataError(f"{path}: empty file; expected a header row and data rows") from None
        raise DataError(f"{path}: {_locate_csv_problem(path) or text.splitlines()[0]}") from None
    try:
        names = table.column_names
    except UnicodeDecodeError:
        raise DataError(f"{path}: {_first_non_utf8(path)}") from None
    if table.num_rows == 0:
        raise DataError(f"{path}: no data rows (header only); expected a header row and data rows")
    _refuse_repeated_headers(path, names)
    columns: dict[str, np.ndarray] = {}
    for name in names:
        column = table.column(name)
        if not (pa.types.is_floating(column.type) or pa.types.is_integer(column.type)):
            bad = _first_non_numeric(column.to_pylist())
            raise DataError(f"{path}: row {bad[0] + 2}: column {name} is {bad[1]!r}; expected a number")
        if column.null_count:
            i = int(np.argmax(np.asarray(column.is_null())))
            raise DataError(f"{path}: row {i + 2}: column {name} is empty; expected a number")
        columns[name] = column.to_numpy().astype(np.float64)
    return names, columns


def _refuse_repeated_headers(path: Path, names: list[str]) -> None:
    """A header naming a column twice is ambiguous: say which, and where."""
    seen: dict[str, int] = {}
    for i, name in enumerate(names):
        if name in seen:
            raise DataError(f"{path}: row 1: header names {name!r} twice (columns {seen[name] + 1} and {i + 1}); "
                            f"expected each column once")
        seen[name] = i


def _first_non_numeric(values: list) -> tuple[int, Any]:
    for i, value in enumerate(values):
        try:
            float(value)
        except (TypeError, ValueError):
            return i, value
    return 0, values[0] if values else None


def _first_non_utf8(path: Path) -> str:
    """Slow path, only on error: where the first byte that is not UTF-8 lies (a Latin-1 or Windows export)."""
    with open(path, "rb") as handle:
        for number, line in enumerate(handle, start=1):
            try:
                line.decode("utf-8")
            except UnicodeDecodeError as exc:
                return (f"row {number}: byte 0x{line[exc.start]:02x} at column {exc.start + 1} is not UTF-8 text "
                        f"(a Latin-1 or Windows export?); save the file as UTF-8")
    return "not UTF-8 text; save the file as UTF-8"


def _locate_csv_problem(path: Path) -> str | None:
    """Slow path, only on error: the first row whose field count differs from the header's."""
    with open(path, encoding="utf-8", errors="replace") as handle:
        header = handle.readline()
        expected = header.count(",") + 1
        for number, line in enumerate(handle, start=2):
            if not line.strip():
                continue
            fields = line.count(",") + 1
            if fields != expected:
                return (f"row {number}: {fields} fields, expected {expected} like the header "
                        f"(truncated or damaged file?)")
    return None


def read_xlsx_data(path: Path) -> tuple[list[str], dict[str, np.ndarray]]:
    """Header and float64 columns of the first sheet of an xlsx workbook."""
    from python_calamine import CalamineWorkbook

    try:
        workbook = CalamineWorkbook.from_path(str(path))
        rows = workbook.get_sheet_by_index(0).to_python(skip_empty_area=False)
    except Exception as exc:  # calamine raises its own error types for damaged files
        raise DataError(f"{path}: cannot read the workbook: {str(exc).splitlines()[0]}") from None
    while rows and all(cell in ("", None) for cell in rows[-1]):
        rows.pop()
    if not rows:
        raise DataError(f"{path}: empty first sheet; expected a header row and data rows")
    header = [str(cell).strip() for cell in rows[0]]
    _refuse_repeated_headers(path, header)
    while header and header[-1] == "":
        header.pop()
    body = rows[1:]
    width = len(header)
    try:
        values = np.array([row[:width] for row in body], dtype=np.float64)
    except (ValueError, TypeError):
        for r, row in enumerate(body):
            for c in range(width):
                cell = row[c] if c < len(row) else ""
                if isinstance(cell, bool) or not isinstance(cell, (int, float)):
                    raise DataError(f"{path}: row {r + 2}: column {header[c]} is {cell!r}; expected a number") from None
        raise
    values = values.reshape(len(body), width)
    return header, {name: values[:, i] for i, name in enumerate(header)}


READERS: dict[str, Callable[[Path], tuple[list[str], dict[str, np.ndarray]]]] = {
    ".csv": read_csv_data,
    ".xlsx": read_xlsx_data,
}
"""Data-file readers by suffix."""


def find_data_file(folder: Path) -> Path:
    """``data.csv`` or ``data.xlsx``; else the folder's only csv/xlsx file."""
    if all((folder / name).is_file() for name in DATA_NAMES):
        raise DataError(f"{folder}: holds both {' and '.join(DATA_NAMES)}, so which is the run is ambiguous; keep "
                        f"one (move the other out of the folder)")
    for name in DATA_NAMES:
        if (folder / name).is_file():
            return folder / name
    candidates = [p for p in sorted(folder.iterdir()) if p.suffix.lower() in READERS and p.is_file()]
    if len(candidates) == 1:
        return candidates[0]
    if not candidates:
        raise DataError(f"{folder}: no data.csv or data.xlsx")
    raise DataError(f"{folder}: no data.csv or data.xlsx, and several candidates "
                    f"({', '.join(p.name for p in candidates)})")


def is_run_folder(folder: Path) -> bool:
    """A folder that holds a data file."""
    return folder.is_dir() and any((folder / name).is_file() for name in DATA_NAMES)


def map_columns(header: list[str], columns: dict[str, np.ndarray], path: Path, options: ReadOptions
                ) -> dict[str, np.ndarray]:
    """Pick the contract columns (through the column map) and convert units."""
    out: dict[str, np.ndarray] = {}
    for name in RAW_COLUMNS:
        source = options.columns.get(name, name)
        if source not in columns:
            hint = "" if options.columns else " (a BAM-era workbook? map its headers with --columns)"
            raise DataError(f"{path}: missing column '{source}'" + (f" (for {name})" if source != name else "")
                            + f"; found: {', '.join(header)}{hint}")
        out[name] = columns[source]
    factors = {"time_s": unit_factor("time", options.time_unit),
               "position_mm": unit_factor("position", options.position_unit)}
    for name in ("fx_n", "fy_n", "fz_n"):
        factors[name] = unit_factor("force", options.force_unit)
    for name in ("tx_nm", "ty_nm", "tz_nm"):
        factors[name] = unit_factor("torque", options.torque_unit)
    return {name: (values * factors[name] if factors[name] != 1.0 else values) for name, values in out.items()}


def read_run_folder(folder: str | Path, options: ReadOptions = ReadOptions(),
                    parameter_refs: Mapping[str, str] | None = None) -> Run:
    """Read and check one run folder (CONTRACT §3).

    ``parameter_refs`` gives presets or files for parameter files the folder
    lacks (BAM-era folders).
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise DataError(f"{folder}: not a folder")
    data_path = find_data_file(folder)
    sets: dict[str, ParameterSet] = {}
    for kind, name in PARAMETER_FILES.items():
        path = folder / name
        if path.is_file():
            sets[kind] = resolve(path, kind, allow_out_of_range=options.allow_out_of_range)  # type: ignore[arg-type]
        elif parameter_refs and parameter_refs.get(kind):
            sets[kind] = resolve(parameter_refs[kind], kind,  # type: ignore[arg-type]
                                 allow_out_of_range=options.allow_out_of_range)
        else:
            raise ParameterError(f"{folder}: missing {name} (or give --{kind} PRESET_OR_FILE)")
    info: dict[str, Any] = {}
    if (folder / "run.yaml").is_file():
        loaded = read_yaml(folder / "run.yaml")
        if loaded is not None and not isinstance(loaded, dict):
            raise ParameterError(f"{folder / 'run.yaml'}: expected a mapping (id, date, operator, notes, tags)")
        info = dict(loaded or {})
        _check_run_info(info, folder / "run.yaml")
    reader = READERS.get(data_path.suffix.lower())
    if reader is None:
        raise DataError(f"{data_path}: no reader for '{data_path.suffix}'; supported: {', '.join(READERS)}")
    header, raw = reader(data_path)
    columns = map_columns(header, raw, data_path, options)
    check_run_columns(columns, str(data_path), surface_offset_mm=float(sets["energizing"].get("surface_offset_mm")),
                      sensor=options.sensor)
    if not options.allow_implausible_units:
        check_units(columns, str(data_path), unit_scales(sets["penetrator"], sets["material"], sets["energizing"]))
    used = {options.columns.get(name, name) for name in RAW_COLUMNS}
    ignored = [name for name in header if name and name not in used]
    record = options.as_record()
    if ignored:
        record["ignored_columns"] = ignored  # kept in the raw stage's provenance; the data are not stored
    return Run(columns, sets["penetrator"], sets["material"], sets["energizing"], info,
               str(folder.resolve()), data_path.suffix.lower().lstrip("."), record)


def unit_scales(penetrator: ParameterSet, material: ParameterSet, energizing: ParameterSet) -> UnitScales:
    """The scales a run's parameter files set for its travel and force (for :func:`check_units`)."""
    from pencli.model.design import design_from_sets
    from pencli.model.geometry import geometry_of

    depth_mm = float(penetrator.get("penetration_depth_mm"))
    frontal = geometry_of(penetrator).frontal_area_m2(design_from_sets(penetrator, material, energizing),
                                                      depth_mm * 1e-3)  # the blade's w·T; a cone's base
    return UnitScales(float(energizing.get("surface_offset_mm")), depth_mm,
                      float(material.get("microstructure_strength_kpa")) * 1e3 * frontal)


def _check_run_info(info: dict, path: Path) -> None:
    """run.yaml's keys that the catalog indexes must hold what it can store: nothing is dropped silently."""
    import datetime as dt

    date = info.get("date")
    if isinstance(date, str):
        try:
            dt.date.fromisoformat(date)
        except ValueError:
            raise ParameterError(f"{path}: date {date!r} is not a date; expected YYYY-MM-DD") from None
    elif date is not None and not isinstance(date, dt.date):
        raise ParameterError(f"{path}: date {date!r} is not a date; expected YYYY-MM-DD")
    tags = info.get("tags")
    if tags is not None and not isinstance(tags, (str, list)):
        raise ParameterError(f"{path}: tags {tags!r}: expected a word or a list of words")


def ignored_columns_warning(run: Run) -> str | None:
    """One line saying which columns of the data file pen did not store (None: none)."""
    ignored = run.reader_options.get("ignored_columns")
    if not ignored:
        return None
    return (f"{run.source}: column(s) {', '.join(repr(c) for c in ignored)} are not CONTRACT §3 columns and were "
            f"not stored (pen export writes the eight contract columns; keep the original file for the rest)")


def write_run_folder(target: str | Path, columns: Mapping[str, np.ndarray], parameters: Mapping[str, dict],
                     info: Mapping[str, Any], *, data_format: str = "csv", overwrite: bool = False) -> Path:
    """Write a CONTRACT §3 folder (every file written first, then renamed into place).

    CSV values are written in the shortest form that reads back to the same
    float64, so export → ingest is lossless.  Into an existing folder
    (``overwrite``) only the files of a run folder are replaced (the data file,
    the parameter files, run.yaml; a data file of the other format goes, since
    a folder with both is ambiguous); anything else in the folder is kept.
    """
    import yaml

    target = Path(target)
    if target.exists() and any(target.iterdir()) and not overwrite:
        raise DataError(f"{target}: exists and is not empty; choose another --to or pass --force")
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", dir=target.parent))
    honour_umask(tmp, folder=True)
    try:
        if data_format == "csv":
            _write_csv(tmp / "data.csv", columns)
        elif data_format == "xlsx":
            _write_xlsx(tmp / "data.xlsx", columns)
        else:
            raise DataError(f"unknown data format {data_format!r}; expected csv or xlsx")
        for kind, name in PARAMETER_FILES.items():
            (tmp / name).write_text(yaml.safe_dump(dict(parameters[kind]), sort_keys=False, allow_unicode=True),
                                    encoding="utf-8")
        if info:
            (tmp / "run.yaml").write_text(yaml.safe_dump(dict(info), sort_keys=False, allow_unicode=True,
                                                         default_flow_style=None), encoding="utf-8")
        if target.exists():
            for written in sorted(tmp.iterdir()):
                os.replace(written, target / written.name)
            if not info and (target / "run.yaml").exists():
                (target / "run.yaml").unlink()
            other = "data.xlsx" if data_format == "csv" else "data.csv"
            if (target / other).exists():
                (target / other).unlink()
        else:
            os.replace(tmp, target)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return target


def _write_csv(path: Path, columns: Mapping[str, np.ndarray]) -> None:
    import pyarrow as pa
    import pyarrow.csv as pacsv

    table = pa.table({name: pa.array(np.asarray(columns[name], dtype=np.float64)) for name in RAW_COLUMNS})
    with open(path, "wb") as handle:
        handle.write((",".join(RAW_COLUMNS) + "\n").encode())
        pacsv.write_csv(table, handle, write_options=pacsv.WriteOptions(include_header=False))


def _write_xlsx(path: Path, columns: Mapping[str, np.ndarray]) -> None:
    from pencli.io.xlsx import write_xlsx

    write_xlsx(path, RAW_COLUMNS, np.column_stack([np.asarray(columns[name], dtype=np.float64) for name in RAW_COLUMNS]))
