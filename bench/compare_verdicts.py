"""Outputs of ``bench.bench_diagnose`` on the same sets, before and after a change, compared campaign by campaign.

Run: python -m bench.compare_verdicts BEFORE.txt AFTER.txt [BEFORE2.txt AFTER2.txt ...]

A rule for keeping a change of the diagnosis asks for counts of this kind: how many campaigns each method names right,
which campaigns changed their verdict, how many went from right to wrong, and the ratio of the median times.
Each pair of files is one set (the same ``--varied``/``--nulls``/``--pairs`` command at the two commits); only
campaigns present in both are compared, so a set still running can be read.  Prints, per set, the campaigns in
both, those right at each, and every changed verdict; then the totals over all sets.
"""

from __future__ import annotations

import re
import statistics
import sys
from dataclasses import dataclass
from pathlib import Path

from pencli.testing.options import check_options

_ROW = re.compile(r"^(?P<label>\S+)\s+truth=(?P<truth>\S+)\s+verdict=(?P<verdict>\S+)\s+(?P<mark>OK|MISS)\b")
_SECONDS = re.compile(r"\s(?P<s>\d+(?:\.\d+)?)s\s*$")


@dataclass(frozen=True)
class Row:
    truth: str
    verdict: str
    right: bool
    seconds: float | None


def read_rows(path: Path) -> dict[str, Row]:
    """The campaign rows of one ``bench_diagnose`` output, by label (the bench's own OK/MISS judgement)."""
    rows = {}
    for line in path.read_text().splitlines():
        m = _ROW.match(line)
        if m:
            t = _SECONDS.search(line)
            rows[m["label"]] = Row(m["truth"], m["verdict"], m["mark"] == "OK", float(t["s"]) if t else None)
    return rows


def compare(before: dict[str, Row], after: dict[str, Row]) -> dict:
    """Counts over the campaigns in both: right before and after, right→wrong, wrong→right, the changed labels,
    and the seconds of each side."""
    common = [k for k in before if k in after]
    changed = [k for k in common if (before[k].verdict, before[k].right) != (after[k].verdict, after[k].right)]
    return {"common": common, "changed": changed,
            "right_before": sum(before[k].right for k in common), "right_after": sum(after[k].right for k in common),
            "lost": sum(before[k].right and not after[k].right for k in common),
            "gained": sum(after[k].right and not before[k].right for k in common),
            "seconds_before": [before[k].seconds for k in common if before[k].seconds is not None],
            "seconds_after": [after[k].seconds for k in common if after[k].seconds is not None]}


def main(argv: list[str]) -> int:
    files = [Path(a) for a in argv]
    if not files or len(files) % 2:
        print("compare_verdicts: expected pairs of files, BEFORE AFTER [BEFORE2 AFTER2 ...] (--help for usage)",
              file=sys.stderr)
        return 2
    sets = []
    for path in files:
        if not path.is_file():
            print(f"compare_verdicts: {path}: no such file", file=sys.stderr)
            return 2
        try:
            rows = read_rows(path)
        except (OSError, UnicodeDecodeError) as e:
            print(f"compare_verdicts: {path}: cannot be read as text ({e.__class__.__name__}); expected the output "
                  f"of python -m bench.bench_diagnose", file=sys.stderr)
            return 2
        if not rows:
            print(f"compare_verdicts: {path}: no campaign rows (lines 'LABEL truth=... verdict=... OK|MISS'); "
                  f"expected the output of python -m bench.bench_diagnose", file=sys.stderr)
            return 2
        sets.append(rows)
    totals = {"common": 0, "right_before": 0, "right_after": 0, "lost": 0, "gained": 0}
    seconds_before, seconds_after = [], []
    for path, before, after in zip(files[::2], sets[::2], sets[1::2]):
        c = compare(before, after)
        print(f"{path.name}: {len(c['common'])} campaigns in both; right {c['right_before']} before, "
              f"{c['right_after']} after (lost {c['lost']}, gained {c['gained']})")
        for k in c["changed"]:
            b, a = before[k], after[k]
            print(f"    {k:28s} truth={b.truth:40s} {b.verdict:25s} {'OK' if b.right else 'MISS':5s} → "
                  f"{a.verdict:25s} {'OK' if a.right else 'MISS'}")
        totals["common"] += len(c["common"])
        for key in ("right_before", "right_after", "lost", "gained"):
            totals[key] += c[key]
        seconds_before += c["seconds_before"]
        seconds_after += c["seconds_after"]
    print(f"all sets: {totals['common']} campaigns; right {totals['right_before']} before, {totals['right_after']} "
          f"after; right → wrong {totals['lost']}, wrong → right {totals['gained']}")
    if seconds_before and seconds_after:
        mb, ma = statistics.median(seconds_before), statistics.median(seconds_after)
        print(f"median diagnosis time: {mb:.1f} s before, {ma:.1f} s after ({ma / mb:.2f} ×; both as the benches "
              f"printed them, under whatever ran beside them)")
    return 0


if __name__ == "__main__":
    check_options(__doc__, ())
    raise SystemExit(main(sys.argv[1:]))
