"""Start-up time of the ``pen`` command beside the bare interpreter, measured in one run.

Run: python -m bench.bench_startup [--repeat N]
- pen: ``pen --help`` (the installed entry point), median of N runs (default 15).
- baseline: ``python -c pass`` in the same loop: the floor any Python command pays.
Target: ``pen --help`` under 0.3 s.
"""

from __future__ import annotations

import shutil
import statistics
import subprocess
import sys
import time


def _median(cmd: list[str], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    repeat = int(sys.argv[sys.argv.index("--repeat") + 1]) if "--repeat" in sys.argv else 15
    pen = shutil.which("pen")
    cmd = [pen, "--help"] if pen else [sys.executable, "-m", "pencli", "--help"]
    bare = _median([sys.executable, "-c", "pass"], repeat)
    help_s = _median(cmd, repeat)
    numpy_s = _median([sys.executable, "-c", "import numpy"], repeat)
    print(f"pen --help:          {help_s:.3f} s median of {repeat}   (target < 0.3 s)")
    print(f"python -c pass:      {bare:.3f} s   (the interpreter's floor)")
    print(f"python -c 'import numpy': {numpy_s:.3f} s   (what pen no longer pays at start-up)")


if __name__ == "__main__":
    main()
