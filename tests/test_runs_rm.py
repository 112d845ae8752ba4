"""Runs in and out of a workspace without silent changes: ``pen runs rm``, ``--repair`` after a lost stage, a
renamed run id said and still found, implausible units refused unless overridden (and the override recorded)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import duckdb
import pytest
import yaml

from tests.conftest import REPO, invoke
from pencli.testing.helpers import synthetic_columns, write_folder

EXAMPLE = REPO / "examples" / "workspace"


@pytest.fixture
def example(tmp_path, monkeypatch) -> Path:
    ws = tmp_path / "ws"
    shutil.copytree(EXAMPLE, ws)
    monkeypatch.setenv("PEN_DB", str(ws / "runs.duckdb"))
    monkeypatch.chdir(tmp_path)
    return ws


def _rows(ws: Path, sql: str, args=()) -> list:
    con = duckdb.connect(str(ws / "runs.duckdb"), read_only=True)
    try:
        return con.execute(sql, list(args)).fetchall()
    finally:
        con.close()


def test_rm_moves_a_run_to_quarantine_and_it_can_be_ingested_again(example, runner, tmp_path):
    lab = tmp_path / "lab" / "mc-1.5-2"
    assert invoke(runner, "export", "mc-1.5-2", "--to", lab).exit_code == 0
    raw = (example / "runs" / "mc-1.5-2" / "00-raw.parquet").read_bytes()
    r = invoke(runner, "runs", "rm", "mc-1.5-2", "--json")
    assert r.exit_code == 0, r.stderr
    record = json.loads(r.stdout)[0]
    assert record["whole_run"] and record["stages"] == ["0:raw", "1:tare", "2:inertia"]
    assert _rows(example, "SELECT count(*) FROM runs WHERE run_id = 'mc-1.5-2'") == [(0,)]
    assert _rows(example, "SELECT count(*) FROM stages WHERE run_id = 'mc-1.5-2'") == [(0,)]
    assert not (example / "runs" / "mc-1.5-2").exists()
    kept = Path(record["quarantine"]) / "runs" / "mc-1.5-2" / "00-raw.parquet"
    assert kept.read_bytes() == raw  # nothing deleted without --purge
    assert invoke(runner, "runs", "check").exit_code == 0
    again = invoke(runner, "ingest", lab, "--json")
    assert again.exit_code == 0 and json.loads(again.stdout)[0]["status"] == "added"


def test_rm_of_a_stage_takes_the_stages_made_from_it_and_purge_deletes(example, runner):
    r = invoke(runner, "runs", "rm", "gb-1.0-2", "--stage", "tare", "--purge", "--json")
    assert r.exit_code == 0, r.stderr
    record = json.loads(r.stdout)[0]
    assert record == {"run_id": "gb-1.0-2", "stages": ["1:tare", "2:inertia"], "whole_run": False,
                      "quarantine": None}
    assert _rows(example, "SELECT stage FROM stages WHERE run_id = 'gb-1.0-2' ORDER BY stage_no") == [("raw",)]
    assert sorted(p.name for p in (example / "runs" / "gb-1.0-2").iterdir()) == ["00-raw.parquet"]
    assert not (example / "quarantine").exists()
    assert invoke(runner, "runs", "check").exit_code == 0
    assert invoke(runner, "tare", "gb-1.0-2").exit_code == 0  # the step can be taken again


def test_repair_recovers_from_a_deleted_stage(example, runner):
    (example / "runs" / "mc-2.0-2" / "01-tare.parquet").unlink()
    broken = invoke(runner, "runs", "check")
    assert broken.exit_code == 1 and "01-tare.parquet" in broken.stderr and "--repair" in broken.stderr
    repaired = invoke(runner, "runs", "check", "--repair")
    assert repaired.exit_code == 0, repaired.stderr
    notes = [line for line in repaired.stderr.splitlines() if line.startswith("note:")]
    assert len(notes) == 1 and "stage 1 (tare) and 1 stage(s) made from it" in notes[0], repaired.stderr
    assert _rows(example, "SELECT stage FROM stages WHERE run_id = 'mc-2.0-2'") == [("raw",)]
    assert invoke(runner, "runs", "check").exit_code == 0
    assert invoke(runner, "tare", "mc-2.0-2").exit_code == 0


def test_repair_recovers_from_a_deleted_raw_stage_and_a_lost_sweep(example, runner):
    (example / "runs" / "gb-2.0-4" / "00-raw.parquet").unlink()
    (example / "sweeps" / "sweep-1.parquet").unlink()
    assert invoke(runner, "runs", "check").exit_code == 1
    repaired = invoke(runner, "runs", "check", "--repair")
    assert repaired.exit_code == 0, repaired.stderr
    assert "run 'gb-2.0-4' left the catalog" in repaired.stderr and "sweep 1 left" in repaired.stderr
    assert _rows(example, "SELECT count(*) FROM runs WHERE run_id = 'gb-2.0-4'") == [(0,)]
    assert _rows(example, "SELECT count(*) FROM sweeps") == [(0,)]
    assert invoke(runner, "runs", "check").exit_code == 0


def test_an_interrupted_removal_is_finished_by_repair(example, runner):
    """A run row left without stages (the removal stopped between its tables) is reported and finished."""
    con = duckdb.connect(str(example / "runs.duckdb"))
    try:
        con.execute("DELETE FROM stages WHERE run_id = 'gb-1.5-4'")
    finally:
        con.close()
    shutil.rmtree(example / "runs" / "gb-1.5-4")
    check = invoke(runner, "runs", "check")
    assert check.exit_code == 1 and "gb-1.5-4" in check.stderr
    assert invoke(runner, "runs", "check", "--repair").exit_code == 0
    assert _rows(example, "SELECT count(*) FROM runs WHERE run_id = 'gb-1.5-4'") == [(0,)]


def test_a_run_id_pen_cannot_keep_is_said_and_still_found(workspace, runner):
    folder = write_folder(workspace / "lab" / "x", synthetic_columns(seed=3), info={"id": "münchen-∂-🚀"})
    r = invoke(runner, "ingest", folder)
    assert r.exit_code == 0, r.stderr
    notes = [line for line in r.stderr.splitlines() if "stored as" in line]
    assert len(notes) == 1 and "'münchen-∂-🚀'" in notes[0] and "'m-nchen'" in notes[0], r.stderr
    shown = invoke(runner, "runs", "show", "münchen-∂-🚀", "--json")
    assert shown.exit_code == 0 and json.loads(shown.stdout)["run"]["run_id"] == "m-nchen"


def test_a_taken_run_id_is_said(workspace, runner):
    a = write_folder(workspace / "lab" / "a", synthetic_columns(seed=4), info={"id": "same"})
    b = write_folder(workspace / "lab" / "b", synthetic_columns(seed=5), info={"id": "same"})
    assert invoke(runner, "ingest", a).exit_code == 0
    r = invoke(runner, "ingest", b)
    assert r.exit_code == 0 and "run id 'same' stored as 'same-" in r.stderr and "another run's id" in r.stderr


def test_implausible_units_are_refused_and_the_override_is_recorded(workspace, runner):
    columns = synthetic_columns(seed=6)
    for name in ("fx_n", "fy_n", "fz_n"):
        columns[name] = columns[name] / 1000.0  # recorded in kN, labelled N
    folder = write_folder(workspace / "lab" / "kn", columns)
    refused = invoke(runner, "ingest", folder)
    assert refused.exit_code == 1 and "fz_n" in refused.stderr and "kN" in refused.stderr
    assert not (workspace / "runs").exists() or not any((workspace / "runs").iterdir())
    taken = invoke(runner, "ingest", folder, "--allow-implausible-units", "--json")
    assert taken.exit_code == 0, taken.stderr
    run_id = json.loads(taken.stdout)[0]["id"]
    shown = json.loads(invoke(runner, "runs", "show", run_id, "--json").stdout)
    assert shown["stages"][0]["parameters"]["allow_implausible_units"] is True
    converted = invoke(runner, "ingest", write_folder(workspace / "lab" / "kn2", columns), "--force-unit", "kN",
                       "--json")
    assert converted.exit_code == 0 and json.loads(converted.stdout)[0]["status"] == "added"  # the right unit


def test_unit_checks_pass_every_bundled_run(tmp_path, runner, monkeypatch):
    """The bands are wide enough for every run the example holds, exported and ingested again."""
    ws = tmp_path / "ws"
    shutil.copytree(EXAMPLE, ws)
    monkeypatch.setenv("PEN_DB", str(ws / "runs.duckdb"))
    ids = [row[0] for row in _rows(ws, "SELECT run_id FROM runs")]
    for run_id in ids:
        assert invoke(runner, "export", run_id, "--to", tmp_path / "lab" / run_id).exit_code == 0
    r = invoke(runner, "ingest", tmp_path / "lab", "--db", tmp_path / "fresh" / "runs.duckdb", "--json")
    assert r.exit_code == 0, r.stdout
    assert sorted(rec["id"] for rec in json.loads(r.stdout)) == sorted(ids)


def test_run_yaml_date_survives_as_a_date(workspace, runner):
    folder = write_folder(workspace / "lab" / "d", synthetic_columns(seed=7), info={"date": "2026-11-30"})
    assert yaml.safe_load((folder / "run.yaml").read_text())["date"] == "2026-11-30"
    r = invoke(runner, "ingest", folder, "--json")
    assert r.exit_code == 0
    rows = invoke(runner, "runs", "--json")
    assert json.loads(rows.stdout)[0]["run_date"] == "2026-11-30"
