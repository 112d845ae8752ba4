"""Time to write one HTML and PDF report of the twelve example runs, beside two baselines measured in the same run.

Run: python -m bench.bench_report
Prints the time of the HTML alone and of the HTML with its PDF (each figure an inline SVG and a vector PDF page).
Baselines: the same twelve runs reported one by one (each run drawn alone, four figures each: what a report of
several runs drew before they were drawn together), and as many one-line plots as the report has figures drawn
and saved as PNG by matplotlib alone, so the ratio says what pen's reading, analysis and layout add to plotting.
"""

from __future__ import annotations

import io
import shutil
import tempfile
import time
from pathlib import Path


def _timed(fn) -> float:
    started = time.perf_counter()
    fn()
    return time.perf_counter() - started


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
        db = work / "runs.duckdb"
        runs = api.run_ids(db, ["all"])
        figures = []

        def together(pdf: bool) -> None:
            sections = api.report_runs(db, runs)
            figures[:] = [f for s in sections for f in s.figures]
            write_report("twelve runs", sections, work / "all.html", pdf=pdf)

        def one_by_one() -> None:
            for run in runs:
                write_report(run, api.report_runs(db, [run]), work / f"{run}.html")

        def plots_alone() -> None:
            x = np.linspace(0, 1, 20000)
            for _ in figures:
                fig, ax = plt.subplots(figsize=(8, 4))
                ax.plot(x, np.sin(40 * x))
                fig.savefig(io.BytesIO(), format="png", dpi=110)
                plt.close(fig)

        together(False)  # warm: imports, fonts, compiled kernels
        html_s = _timed(lambda: together(False))
        pen_s = _timed(lambda: together(True))
        alone_s = _timed(one_by_one)
        base_s = _timed(plots_alone)
    print(f"report of {len(runs)} runs drawn together ({len(figures)} figures): HTML {html_s:.1f} s, HTML and PDF "
          f"{pen_s:.1f} s (target: 5 s)")
    print(f"the same runs reported one by one (each drawn alone, HTML and PDF): {alone_s:.1f} s, "
          f"{alone_s / pen_s:.1f}x the report's time")
    print(f"matplotlib alone drawing {len(figures)} line plots: {base_s:.1f} s; the report takes "
          f"{pen_s / base_s:.1f}x that")


if __name__ == "__main__":
    main()
