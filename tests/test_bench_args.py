"""The benches' command lines refuse what they do not know before a long run starts (bench/args.py)."""

import subprocess
import sys
from pathlib import Path

import pytest

from bench.args import check_options

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
