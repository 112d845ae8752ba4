"""Shared fixtures: a CLI runner and a temporary workspace."""

from __future__ import annotations

import os
from pathlib import Path

# One BLAS thread per test worker: the workers already fill the cores, and a diagnosis's small solves gain little
# from a second thread that competes with the other worker (six diagnosis tests on two workers: 135 -> 123 s of
# CPU, 80 -> 75 s).  Set here, before anything imports numpy, so xdist's workers inherit it; a user's own kept.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
# For the same reason one process per diagnosis (PEN_WORKERS, docs/guide/diagnosis.md): its replicate pool and
# compiled threads would only compete with the other test worker.  Tests of the pool pass workers themselves.
os.environ.setdefault("PEN_WORKERS", "1")

import pytest
from typer.testing import CliRunner

REPO = Path(__file__).resolve().parents[1]
SPEC = REPO / "tests" / "contract"
"""The interchange contract's examples, copied into the repository so a fresh clone tests without them."""
OUTSIDE_SPEC = REPO.parent / "shared" / "spec"
"""Where the binding contract lives beside a development checkout (absent in a user's clone)."""


def pytest_collection_modifyitems(config, items):
    """Tests marked ``slow`` (15 s to 2 min each) first, so that none of them starts last and holds one worker
    while the other idles."""
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)


@pytest.fixture
def runner() -> CliRunner:
    return CliRunner()


@pytest.fixture
def workspace(tmp_path, monkeypatch) -> Path:
    """An empty workspace folder; PEN_DB points into it."""
    monkeypatch.setenv("PEN_DB", str(tmp_path / "runs.duckdb"))
    monkeypatch.chdir(tmp_path)
    return tmp_path


def invoke(runner: CliRunner, *args: str, input: str | None = None):
    from pencli.cli import app

    return runner.invoke(app, [str(a) for a in args], input=input)
