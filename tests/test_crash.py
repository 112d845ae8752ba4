"""kill -9 at five points of ingest, tare and fit: the next command repairs the workspace, and no data is lost.

The points are injected with ``PEN_TEST_CRASH_AT`` (``pencli.store.workspace.crash_point``): the process
sends itself SIGKILL there, as a power cut or ``kill -9`` would; nothing of Python's clean-up runs.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import duckdb
import pyarrow.parquet as pq
import pytest

from tests.conftest import REPO

EXAMPLE = REPO / "examples" / "workspace"
RUNS = ("mc-1.0-4", "mc-1.0-6", "mc-1.5-2")


def pen(db: Path, *args: str, crash: str | None = None) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("PEN_DB", "PEN_TEST_CRASH_AT")}
    if crash is not None:
        env["PEN_TEST_CRASH_AT"] = crash
    return subprocess.run([sys.executable, "-m", "pencli", *args, "--db", str(db)], capture_output=True, text=True,
                          env=env, cwd=db.parent, timeout=300)


@pytest.fixture(scope="module")
def lab(tmp_path_factory) -> Path:
    """Three of the example's runs as CONTRACT §3 folders (the lab's originals)."""
    root = tmp_path_factory.mktemp("lab")
    source = root / "example"
    shutil.copytree(EXAMPLE, source)
    for run in RUNS:
        done = pen(source / "runs.duckdb", "export", run, "--to", str(root / "lab" / run))
        assert done.returncode == 0, done.stderr
    return root / "lab"


def catalog(db: Path) -> dict[str, list]:
    con = duckdb.connect(str(db), read_only=True)
    try:
        return {"runs": con.execute("SELECT run_id, content_sha256 FROM runs ORDER BY 1").fetchall(),
                "stages": con.execute("SELECT run_id, stage_no, stage, path FROM stages ORDER BY 1, 2").fetchall(),
                "materials": con.execute("SELECT material, version, model_data_path FROM materials").fetchall()}
    finally:
        con.close()


def assert_consistent(db: Path) -> None:
    """`pen runs check` finds nothing, and no temporary or stray file is left."""
    done = pen(db, "runs", "check")
    assert done.returncode == 0, done.stderr
    leftovers = [p for p in db.parent.rglob(".*") if p.is_file() and p.name != ".gitkeep" and "quarantine" not in
                 p.parts]
    assert leftovers == []


def ingested(db: Path, lab: Path) -> Path:
    done = pen(db, "ingest", *(str(lab / r) for r in RUNS))
    assert done.returncode == 0, done.stderr
    return db


def test_ingest_killed_before_the_rename_leaves_a_temporary_the_next_ingest_removes(tmp_path, lab):
    db = tmp_path / "runs.duckdb"
    crashed = pen(db, "ingest", str(lab / RUNS[0]), crash="before-rename")
    assert crashed.returncode == -9
    assert list((tmp_path / "runs").rglob(".*.tmp")), "the crash point was not reached"
    assert pen(db, "runs", "check").returncode == 1  # reported before repair
    again = pen(db, "ingest", str(lab / RUNS[0]))
    assert again.returncode == 0, again.stderr
    assert "temporary file" in again.stderr and "note:" in again.stderr
    assert [r[0] for r in catalog(db)["runs"]] == [RUNS[0]]
    assert_consistent(db)


def test_ingest_killed_between_rename_and_commit_is_adopted_with_its_hash_checked(tmp_path, lab):
    db = tmp_path / "runs.duckdb"
    crashed = pen(db, "ingest", str(lab / RUNS[0]), crash="before-commit")
    assert crashed.returncode == -9
    orphan = tmp_path / "runs" / RUNS[0] / "00-raw.parquet"
    assert orphan.is_file() and catalog(db)["runs"] == []
    # the next writing command (here: ingest of another run) repairs first
    again = pen(db, "ingest", str(lab / RUNS[1]))
    assert again.returncode == 0, again.stderr
    assert "adopted" in again.stderr
    assert [r[0] for r in catalog(db)["runs"]] == list(RUNS[:2])
    # the adopted run is the lab's data: ingesting the original finds it already there
    same = pen(db, "ingest", str(lab / RUNS[0]), "--json")
    assert same.returncode == 0 and '"existing"' in same.stdout, same.stdout
    assert_consistent(db)


def test_an_ingest_batch_killed_after_its_first_commit_is_finished_by_the_next_ingest(tmp_path, lab):
    db = tmp_path / "runs.duckdb"
    crashed = pen(db, "ingest", *(str(lab / r) for r in RUNS), crash="after-commit")
    assert crashed.returncode == -9
    assert len(catalog(db)["runs"]) == 1
    again = pen(db, "ingest", *(str(lab / r) for r in RUNS), "--json")
    assert again.returncode == 0, again.stderr
    assert again.stdout.count('"added"') == 2 and again.stdout.count('"existing"') == 1
    assert_consistent(db)


def test_tare_killed_between_rename_and_commit_is_adopted_not_stacked(tmp_path, lab):
    db = ingested(tmp_path / "runs.duckdb", lab)
    crashed = pen(db, "tare", RUNS[0], crash="before-commit")
    assert crashed.returncode == -9
    assert (tmp_path / "runs" / RUNS[0] / "01-tare.parquet").is_file()
    assert [s[2] for s in catalog(db)["stages"] if s[0] == RUNS[0]] == ["raw"]
    again = pen(db, "tare", RUNS[0])
    assert again.returncode == 0, again.stderr
    assert "adopted" in again.stderr
    # the adopted stage is the one tare makes: tare again returns it instead of writing stage 2
    assert [s[2] for s in catalog(db)["stages"] if s[0] == RUNS[0]] == ["raw", "tare"]
    assert_consistent(db)


def test_fit_killed_between_rename_and_commit_keeps_its_version(tmp_path):
    work = tmp_path / "ws"
    shutil.copytree(EXAMPLE, work)
    db = work / "runs.duckdb"
    before = catalog(db)["materials"]
    crashed = pen(db, "fit", "--material", "mpacs_c", "mc-*", crash="before-commit")
    assert crashed.returncode == -9
    orphans = [p for p in (work / "fits").glob("*.parquet") if str(p.relative_to(work)) not in
               {m[2] for m in before}]
    assert len(orphans) == 1
    fit_meta = pq.read_schema(orphans[0]).metadata
    again = pen(db, "runs", "check", "--repair")
    assert again.returncode == 0, again.stderr
    after = catalog(db)["materials"]
    assert len(after) == len(before) + 1
    new = [m for m in after if m not in before][0]
    assert new[2] == str(orphans[0].relative_to(work))
    assert fit_meta[b"pen:version"].decode() == str(new[1])
    assert_consistent(db)


def test_a_file_the_catalog_cannot_account_for_is_quarantined_never_deleted(tmp_path, lab):
    db = ingested(tmp_path / "runs.duckdb", lab)
    stray = tmp_path / "runs" / RUNS[0] / "07-tare.parquet"
    shutil.copy(tmp_path / "runs" / RUNS[0] / "00-raw.parquet", stray)  # wrong name for what it holds
    assert pen(db, "runs", "check").returncode == 1
    repaired = pen(db, "runs", "check", "--repair")
    assert repaired.returncode == 0, repaired.stderr
    assert "quarantine" in repaired.stderr
    kept = list((tmp_path / "quarantine").rglob("07-tare.parquet"))
    assert len(kept) == 1 and not stray.exists()


def test_a_tampered_stage_is_reported_by_check(tmp_path, lab):
    db = ingested(tmp_path / "runs.duckdb", lab)
    raw = tmp_path / "runs" / RUNS[1] / "00-raw.parquet"
    table = pq.read_table(raw)
    column = table.column("fz_n").to_numpy().copy()
    column[100] += 1.0
    pq.write_table(table.set_column(table.schema.get_field_index("fz_n"), "fz_n", [column]).replace_schema_metadata(
        table.schema.metadata), raw)
    done = pen(db, "runs", "check")
    assert done.returncode == 1
    assert str(raw) in done.stderr and "changed since it was written" in done.stderr
