"""Time to write one HTML report of the twelve example runs, beside a baseline measured in the same run.

Run: python -m bench.bench_report
Prints the time of the HTML alone and of the HTML with its PDF (each figure an inline SVG and a vector PDF page).
Baseline: the same number of figures (one line plot each) drawn and saved as PNG by matplotlib alone,
so the ratio says what pen's reading, analysis and layout add to plotting.
"""

from __future__ import annotations

import io
import shutil
import tempfile
import time
from pathlib import Path


def main() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from pencli import api
    from pencli.report.build import write_report

    repo = Path(__file__).resolve().parents[1]
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        example = repo / "examples" / "workspace"
        shutil.copy(example / "runs.duckdb", work / "runs.duckdb")
        for folder in ("runs", "fits", "sweeps"):
            if (example / folder).is_dir():
                shutil.copytree(example / folder, work / folder)
        started = time.perf_counter()
        sections = api.report_runs(work / "runs.duckdb", ["all"])
        write_report("twelve runs", sections, work / "all.html", pdf=False)
        html_s = time.perf_counter() - started
        started = time.perf_counter()
        sections = api.report_runs(work / "runs.duckdb", ["all"])
        write_report("twelve runs", sections, work / "all.html")
        pen_s = time.perf_counter() - started
        figures = sum(len(s.figures) for s in sections)
        started = time.perf_counter()
        x = np.linspace(0, 1, 20000)
        for _ in range(figures):
            fig, ax = plt.subplots(figsize=(8, 4))
            ax.plot(x, np.sin(40 * x))
            fig.savefig(io.BytesIO(), format="png", dpi=110)
            plt.close(fig)
        base_s = time.perf_counter() - started
    print(f"report of 12 runs ({figures} figures): HTML {html_s:.1f} s, HTML and PDF {pen_s:.1f} s; matplotlib "
          f"alone drawing {figures} line plots: {base_s:.1f} s; ratios {html_s / base_s:.1f}x and "
          f"{pen_s / base_s:.1f}x (target: 5 s for HTML and PDF)")


if __name__ == "__main__":
    main()
