"""Test helpers: run folders on disk, workspace snapshots."""

from __future__ import annotations

from pathlib import Path
from typing import Callable, Sequence

import numpy as np
import yaml

from pencli.params.load import load_preset

COLUMNS = ("time_s", "position_mm", "fx_n", "fy_n", "fz_n", "tx_nm", "ty_nm", "tz_nm")


def synthetic_columns(n: int = 3000, rate: float = 30000.0, seed: int = 0) -> dict[str, np.ndarray]:
    """Plausible raw columns (not physics, just a valid recording)."""
    rng = np.random.default_rng(seed)
    t = (np.arange(n) - n // 4) / rate  # a quarter of the rows before the release
    travel = np.clip(t / (0.5 * n / rate), 0.0, 1.0) * 200.0  # 200 mm over half the recording
    pos = np.round(travel / 0.16) * 0.16
    cols = {"time_s": t, "position_mm": pos}
    for name in COLUMNS[2:]:
        scale = 2.0 if name.endswith("_n") else 0.01
        cols[name] = rng.normal(0, scale, n) + (np.where(travel > 150.0, 500.0, 0.0) if name == "fz_n" else 0.0)
    return cols


def write_folder(folder: Path, columns: dict[str, np.ndarray] | None = None, *, text: str | None = None,
                 penetrator="al6061_1mm", material="grill_brick", energizing="springs_4", info=None,
                 data_name="data.csv") -> Path:
    """A CONTRACT §3 folder, written by hand (not by pen's writer)."""
    folder.mkdir(parents=True, exist_ok=True)
    if text is None:
        columns = columns if columns is not None else synthetic_columns()
        lines = [",".join(COLUMNS)]
        stacked = np.column_stack([columns[c] for c in COLUMNS])
        lines += [",".join(repr(float(v)) for v in row) for row in stacked]
        text = "\n".join(lines) + "\n"
    (folder / data_name).write_text(text)
    for kind, name in (("penetrator", penetrator), ("material", material), ("energizing", energizing)):
        if name is None:
            continue
        mapping = load_preset(name, kind).to_mapping()
        mapping.pop("notes", None)
        (folder / f"{kind}.yaml").write_text(yaml.safe_dump(mapping, sort_keys=False))
    if info is not None:
        (folder / "run.yaml").write_text(yaml.safe_dump(info))
    return folder


def snapshot(workspace: Path) -> tuple:
    """Catalog rows and files of a workspace, to prove nothing changed."""
    import duckdb

    db = workspace / "runs.duckdb"
    rows: tuple = ()
    if db.exists():
        con = duckdb.connect(str(db), read_only=True)
        try:
            rows = tuple(tuple(con.execute(f"SELECT * FROM {t} ORDER BY ALL").fetchall())
                         for t in ("runs", "run_parameters", "stages"))
        finally:
            con.close()
    runs = workspace / "runs"
    files = tuple(sorted(str(p.relative_to(workspace)) for p in runs.rglob("*"))) if runs.exists() else ()
    return rows, files


def write_bam_workbook(folder: Path, columns: dict[str, np.ndarray], headers: Sequence[str],
                       convert: Callable[[np.ndarray], list]) -> Path:
    """A run folder whose data is a BAM-era workbook (``experiment_12.xlsx``) with other headers and units:
    ``convert`` maps a row of the CONTRACT §3 columns to the workbook's row."""
    from openpyxl import Workbook

    write_folder(folder, columns)
    (folder / "data.csv").unlink()
    wb = Workbook()
    sheet = wb.active
    sheet.append(list(headers))
    for row in np.column_stack([columns[c] for c in COLUMNS]):
        sheet.append(convert(row))
    wb.save(folder / "experiment_12.xlsx")
    return folder


def older_catalog(folder: Path, version: int) -> Path:
    """The example workspace's runs, fits and sweeps copied into ``folder`` under a catalog built by the migrations
    up to ``version`` only (a workspace an older pen wrote); returns the catalog."""
    import shutil

    import duckdb

    from pencli.store.migrations import MIGRATIONS

    example = Path(__file__).resolve().parents[2] / "examples" / "workspace"
    for sub in ("runs", "fits", "sweeps"):
        shutil.copytree(example / sub, folder / sub)
    db = folder / "runs.duckdb"
    con = duckdb.connect(str(db))
    try:
        con.execute("CREATE TABLE schema_migrations (version INTEGER PRIMARY KEY, name VARCHAR, applied_at "
                    "TIMESTAMP, pen_version VARCHAR)")
        for number, name, sql in (m for m in MIGRATIONS if m[0] <= version):
            con.execute(sql)
            con.execute("INSERT INTO schema_migrations VALUES (?, ?, now(), 'old')", [number, name])
        con.execute(f"ATTACH '{example / 'runs.duckdb'}' AS example (READ_ONLY)")
        for table in ("runs", "run_parameters", "stages", "materials", "sweeps"):
            columns = [row[0] for row in con.execute(f"DESCRIBE {table}").fetchall()]  # the older schema's
            con.execute(f"INSERT INTO {table} SELECT {', '.join(columns)} FROM example.{table}")
    finally:
        con.close()
    return db
