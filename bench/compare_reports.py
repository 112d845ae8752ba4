"""How far two sets of diagnosis reports moved: ``bench_diagnose_identity --reports DIR`` before and after a change.

Run: python -m bench.compare_reports BEFORE_DIR AFTER_DIR [--rtol R]

For each campaign in both folders: whether the verdict and its effects are the same, how many numbers moved by more
than R (relative to the larger of the two; default 1e-9), the largest such move and where in the report, and any
value that is not a number and differs (a key, a name, a note).  A refactoring leaves every report as it was; a
change to the solver's arithmetic moves the last digits of near-collinear fits (z values, thresholds), which this
sizes, and a verdict that differs is a change of behaviour.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

from pencli.testing.options import check_options


def differences(before, after, rtol: float, path: str = "") -> tuple[list[tuple[float, str]], list[str]]:
    """(numbers that moved by more than ``rtol``: (relative move, where); other values that differ: where)."""
    moved: list[tuple[float, str]] = []
    other: list[str] = []
    if isinstance(before, dict) and isinstance(after, dict):
        for key in sorted(set(before) | set(after)):
            if key not in before or key not in after:
                other.append(f"{path}/{key} (only {'after' if key in after else 'before'})")
                continue
            m, o = differences(before[key], after[key], rtol, f"{path}/{key}")
            moved += m
            other += o
    elif isinstance(before, list) and isinstance(after, list) and len(before) == len(after):
        for i, (b, a) in enumerate(zip(before, after)):
            m, o = differences(b, a, rtol, f"{path}[{i}]")
            moved += m
            other += o
    elif (isinstance(before, (int, float)) and isinstance(after, (int, float))
          and not isinstance(before, bool) and not isinstance(after, bool)):
        if math.isnan(before) and math.isnan(after):
            return moved, other
        scale = max(abs(before), abs(after))
        move = abs(before - after) / scale if scale > 0 else 0.0
        if not move <= rtol:
            moved.append((move, path))
    elif before != after:
        other.append(f"{path}: {before!r} → {after!r}"[:200])
    return moved, other


def main() -> None:
    check_options(__doc__, ("--rtol",))
    args = [a for a in sys.argv[1:]]
    rtol = 1e-9
    if "--rtol" in args:
        i = args.index("--rtol")
        rtol = float(args[i + 1])
        del args[i:i + 2]
    if len(args) != 2:
        raise SystemExit("compare_reports: expected two folders of reports (BEFORE_DIR AFTER_DIR); --help for usage")
    first, second = (Path(a) for a in args)
    for folder in (first, second):
        if not folder.is_dir():
            raise SystemExit(f"compare_reports: {folder}: no such folder of reports")
    names = sorted({p.name for p in first.glob("*.json")} & {p.name for p in second.glob("*.json")})
    if not names:
        raise SystemExit(f"compare_reports: {first} and {second} hold no report of the same campaign")
    same_verdicts = 0
    for name in names:
        before, after = (json.loads((folder / name).read_text()) for folder in (first, second))
        same = (before.get("verdict"), before.get("verdict_effects")) == (after.get("verdict"),
                                                                          after.get("verdict_effects"))
        same_verdicts += same
        moved, other = differences(before, after, rtol)
        largest = max(moved, default=(0.0, "-"))
        print(f"{name[:-5]:22s} verdict {'same' if same else 'DIFFERS'}  {len(moved):4d} numbers moved > {rtol:g}"
              f"  largest {largest[0]:.2e} at {largest[1]}" + (f"  other: {other[0]}" if other else ""))
    print(f"same verdict and effects on {same_verdicts}/{len(names)} campaigns")


if __name__ == "__main__":
    main()
