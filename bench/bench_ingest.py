"""Ingest throughput: 30 kHz CSV runs of 0.5 s, and a 30,000-row xlsx, each beside a baseline run here.

Run: python -m bench.bench_ingest
- CSV: `pen ingest` of N run folders (read, check, content-hash, Parquet, catalog) in runs/s,
  beside plain `pandas.read_csv` of the same files (read only).  Target ≥ 20 runs/s.
- xlsx: pen's reader (python-calamine) on a 30,000 × 8 workbook beside `pandas.read_excel(engine="openpyxl")`.
  Target: well under a second.
"""

from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from pencli import api
from pencli.io.runfolder import read_xlsx_data
from pencli.io.xlsx import write_xlsx
from pencli.testing.helpers import COLUMNS, synthetic_columns, write_folder

N_RUNS = 40
N_XLSX = 10


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        folders = [write_folder(root / "src" / f"run{i:03d}", synthetic_columns(n=15000, rate=30000.0, seed=i))
                   for i in range(N_RUNS)]
        t0 = time.perf_counter()
        outcomes = api.ingest([root / "src"], root / "ws" / "runs.duckdb")
        pen_s = time.perf_counter() - t0
        assert all(o.status == "added" for o in outcomes), [o.message for o in outcomes if o.message][:1]
        t0 = time.perf_counter()
        for folder in folders:
            pd.read_csv(folder / "data.csv")
        pandas_s = time.perf_counter() - t0
        print(f"CSV, {N_RUNS} runs of 0.5 s at 30 kHz (15,000 rows x 8):")
        print(f"  pen ingest (read+check+hash+Parquet+catalog): {N_RUNS / pen_s:7.1f} runs/s   (target >= 20)")
        print(f"  pandas.read_csv alone (read only):            {N_RUNS / pandas_s:7.1f} runs/s")

        xfolders = []
        for i in range(N_XLSX):
            folder = write_folder(root / "xsrc" / f"run{i:03d}", synthetic_columns(n=15000, rate=30000.0, seed=500 + i))
            cols = synthetic_columns(n=15000, rate=30000.0, seed=500 + i)
            write_xlsx(folder / "data.xlsx", COLUMNS, np.column_stack([cols[c] for c in COLUMNS]))
            (folder / "data.csv").unlink()
            xfolders.append(folder)
        t0 = time.perf_counter()
        outcomes = api.ingest([root / "xsrc"], root / "wsx" / "runs.duckdb")
        pen_xs = time.perf_counter() - t0
        assert all(o.status == "added" for o in outcomes)
        t0 = time.perf_counter()
        for folder in xfolders:
            pd.read_excel(folder / "data.xlsx", engine="openpyxl")
        base_xs = time.perf_counter() - t0
        print(f"xlsx, {N_XLSX} runs of 0.5 s at 30 kHz:")
        print(f"  pen ingest:                                   {N_XLSX / pen_xs:7.1f} runs/s")
        print(f"  pandas.read_excel(engine=openpyxl) alone:     {N_XLSX / base_xs:7.1f} runs/s   "
              f"ratio {base_xs / pen_xs:.1f}x")

        values = np.column_stack([c for c in synthetic_columns(n=30000, rate=30000.0, seed=7).values()])
        path = root / "big.xlsx"
        write_xlsx(path, COLUMNS, values)
        pen_times, base_times = [], []
        for _ in range(3):
            t0 = time.perf_counter()
            read_xlsx_data(path)
            pen_times.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            pd.read_excel(path, engine="openpyxl")
            base_times.append(time.perf_counter() - t0)
        pen_x, base_x = statistics.median(pen_times), statistics.median(base_times)
        print("xlsx, 30,000 rows x 8 columns (median of 3):")
        print(f"  pen reader (python-calamine):        {pen_x:6.3f} s   (target well under 1 s)")
        print(f"  pandas.read_excel(engine=openpyxl):  {base_x:6.3f} s   ratio {base_x / pen_x:.1f}x")


if __name__ == "__main__":
    main()
