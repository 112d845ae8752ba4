"""The benches' command lines refuse what they do not know before a long run starts (pencli/testing/options.py)."""

import subprocess
import sys
from pathlib import Path

import pytest

from pencli.testing.options import check_options

ROOT = Path(__file__).resolve().parents[1]


def test_an_unknown_option_exits_2_naming_it_and_the_known_ones(capsys):
    with pytest.raises(SystemExit) as stop:
        check_options("Run: x", ("--base", "--no-ladder"), ["--base", "5", "--no-lader"])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "--no-lader" in err and "--base, --no-ladder" in err and "\n" == err[-1] and err.count("\n") == 1


def test_help_prints_the_doc_and_exits_0(capsys):
    for flag in ("-h", "--help"):
        with pytest.raises(SystemExit) as stop:
            check_options("Run: python -m bench.x N", ("--base",), ["12", flag])
        assert stop.value.code == 0 and capsys.readouterr().out == "Run: python -m bench.x N\n"


def test_known_options_and_positionals_pass():
    check_options("doc", ("--base", "--no-ladder"), ["--base", "630000", "--no-ladder", "28", "-3"])


def test_the_holdout_bench_refuses_a_typo_without_running():
    done = subprocess.run([sys.executable, "-m", "bench.bench_diagnose_holdout", "--base", "1", "--no-lader"],
                          cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "unknown option --no-lader" in done.stderr and done.stdout == ""


def test_compare_verdicts_counts_what_changed_between_two_runs_of_a_set(tmp_path):
    """bench/compare_verdicts.py reads two bench_diagnose outputs and counts campaign by campaign; the lines here
    are in the bench's printed form, the counts worked out by hand.  Run as the bench is run, in its own process
    (the tests import no bench)."""
    import subprocess
    import sys

    from tests.conftest import REPO

    def compare(*files):
        return subprocess.run([sys.executable, "-m", "bench.compare_verdicts", *files], capture_output=True,
                              text=True, cwd=REPO, timeout=120)

    def out(name, rows):
        path = tmp_path / name
        path.write_text("\n".join(f"{label:28s} truth={truth:45s} verdict={verdict:25s} {mark} first=x z=1.0/3.0 "
                                  f"{seconds}s" for label, truth, verdict, mark, seconds in rows) + "\nsummary line\n")
        return str(path)

    before = out("before.txt", [("a-0", "plug_growth", "plug_growth", "OK ", 10.0),
                                ("b-1", "velocity_friction", "plug_growth", "MISS", 20.0),
                                ("null-2", "none", "none", "OK ", 30.0)])
    after = out("after.txt", [("a-0", "plug_growth", "strength_layer", "MISS", 12.0),
                              ("b-1", "velocity_friction", "velocity_friction", "OK ", 22.0),
                              ("null-2", "none", "none", "OK ", 33.0), ("c-3", "none", "none", "OK ", 1.0)])
    done = compare(before, after)
    assert done.returncode == 0, done.stderr
    text = done.stdout
    assert "3 campaigns in both; right 2 before, 2 after (lost 1, gained 1)" in text
    assert "a-0" in text and "b-1" in text and "null-2" not in text and "c-3" not in text
    assert "20.0 s before, 22.0 s after (1.10 ×" in text
    assert compare(before).returncode == 2
    missing = compare(before, str(tmp_path / "missing.txt"))
    assert missing.returncode == 2 and "missing.txt: no such file" in missing.stderr
