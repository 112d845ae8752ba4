"""Field records in the workspace: `pen ingest` of every field format, the stored record read back as its file
reads, the same guarantees as a run (content hash, one line per bad file, nothing half written, crash recovery),
and the field commands taking record ids."""

from __future__ import annotations

import gzip
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import duckdb
import numpy as np
import pytest

from tests.conftest import REPO, invoke

FIELD = REPO / "examples" / "field"
FILES = {
    "sgf": FIELD / "ntnu-cptu-rate" / "soundings" / "HALS01.cpt.gz",
    "sgf_total": FIELD / "ntnu-tot-rate" / "soundings" / "KJTS01-Tot.std.gz",
    "gef": FIELD / "gef" / "cpt2.gef",
    "ags": FIELD / "ags" / "HKZ_20161114_FEBV_HKZ1-CPT02_AGS4.0_V03_F.ags.gz",
    "pnt": FIELD / "snowex-smp" / "SNEX20_SMP_S19M1256_2S7_20200208.pnt.gz",
}


def catalog_rows(db: Path) -> list[tuple]:
    con = duckdb.connect(str(db), read_only=True)
    try:
        return con.execute("SELECT record_id, kind, geometry, drive, source_format, n_rows, content_sha256 "
                           "FROM records ORDER BY record_id").fetchall()
    finally:
        con.close()


def same_arrays(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(np.array_equal(a[k], b[k], equal_nan=True) for k in a)


@pytest.fixture
def drop_files(tmp_path):
    """A simulated BlueDrop record and its calibration sheet (the instrument's own writer, not pen's reader)."""
    from pencli.acquire.freefall import Bed, Probe, Sensors, simulate_drop
    from pencli.io.bluedrop import bluedrop_bytes

    sensors = Sensors()
    truth = simulate_drop(Probe(), Bed(strength_kpa=20.0, gradient_kpa_m=50.0, damping_kpa_s_m=5.0), 1.0,
                          sensors=sensors, seed=3)
    record = tmp_path / "drop-01.bin"
    record.write_bytes(bluedrop_bytes(truth.raw))
    sheet = tmp_path / "calibration.csv"
    sheet.write_text("channel,offset,scale,unit\n" + "".join(
        f"{name},{c.offset!r},{c.scale!r},{c.unit}\n" for name, c in sensors.calibration.items()))
    return record, sheet


def test_every_field_format_is_stored_as_its_file_reads(tmp_path, runner, drop_files):
    from pencli import api
    from pencli.io.bluedrop import read_bluedrop, read_calibration
    from pencli.io.pnt import read_pnt
    from pencli.store.records import load_record

    db = tmp_path / "ws" / "runs.duckdb"
    record, sheet = drop_files
    r = invoke(runner, "ingest", *FILES.values(), record, "--calibration", sheet, "--json", "--db", db)
    assert r.exit_code == 0, r.output + r.stderr
    outcomes = json.loads(r.stdout)
    assert [o["status"] for o in outcomes] == ["added"] * 6
    ids = {Path(o["source"]).name: o["id"] for o in outcomes}
    assert ids["HALS01.cpt.gz"] == "HALS01" and ids["cpt2.gef"] == "cpt2" and ids["drop-01.bin"] == "drop-01"
    kinds = {row[0]: row[1:5] for row in catalog_rows(db)}
    assert kinds["HALS01"] == ("cptu", "cone", "constant_rate", "sgf")
    assert kinds["KJTS01-Tot"] == ("total_sounding", "drill_bit", "constant_rate", "sgf")
    assert kinds["SNEX20_SMP_S19M1256_2S7_20200208"] == ("smp", "cone", "constant_rate", "pnt")
    assert kinds["drop-01"] == ("free_fall", "cone", "free_fall", "bluedrop")

    ws = api.workspace(db)
    for key in ("sgf", "sgf_total", "gef", "ags"):
        direct = api.read_soundings([FILES[key]])[0]
        stored = load_record(ws, ids[FILES[key].name]).to_object()
        assert stored.name == direct.name and stored.method == direct.method and stored.kind == direct.kind
        assert same_arrays(stored.columns, direct.columns), key
        assert stored.header == direct.header and stored.events == direct.events
        assert (stored.row_events, stored.row_comments, stored.row_text) == (
            direct.row_events, direct.row_comments, direct.row_text)
    profile, stored = read_pnt(FILES["pnt"]), load_record(ws, ids[FILES["pnt"].name]).to_object()
    assert np.array_equal(stored.force_n, profile.force_n) and stored.raw_header == profile.raw_header
    assert stored.header == profile.header
    drop, stored = read_bluedrop(record, read_calibration(sheet)), load_record(ws, "drop-01").to_object()
    assert np.array_equal(stored.raw, drop.raw) and same_arrays(stored.channels, drop.channels)
    assert stored.units == drop.units


def test_the_same_data_is_the_same_record_wherever_its_file_lies(tmp_path, runner):
    db = tmp_path / "runs.duckdb"
    copy = tmp_path / "elsewhere" / "renamed.cpt.gz"
    copy.parent.mkdir()
    shutil.copy(FILES["sgf"], copy)
    assert invoke(runner, "ingest", FILES["sgf"], "--db", db).exit_code == 0
    r = invoke(runner, "ingest", FILES["sgf"], copy, "--json", "--db", db)
    assert r.exit_code == 0 and [o["status"] for o in json.loads(r.stdout)] == ["existing", "existing"]
    assert [o["id"] for o in json.loads(r.stdout)] == ["HALS01", "HALS01"]
    assert len(catalog_rows(db)) == 1


def _broken(tmp_path: Path, case: str) -> tuple[Path, tuple[str, ...]]:
    if case == "truncated gzip":
        path = tmp_path / "HALS01.cpt.gz"
        path.write_bytes(FILES["sgf"].read_bytes()[:4000])
        return path, ("HALS01.cpt.gz",)
    if case == "sgf row":
        text = gzip.decompress(FILES["sgf"].read_bytes()).decode("cp1252").splitlines()
        row = next(k for k, line in enumerate(text) if line.startswith("D=")) + 5
        text[row] = text[row].replace("D=", "D=x", 1)
        path = tmp_path / "HALS01.cpt"
        path.write_text("\n".join(text), encoding="cp1252")
        return path, ("HALS01.cpt", "line")
    if case == "pnt short":
        path = tmp_path / "cut.pnt"
        path.write_bytes(gzip.decompress(FILES["pnt"].read_bytes())[:5000])
        return path, ("cut.pnt", "force samples")
    if case == "bluedrop without calibration":
        path = tmp_path / "drop.bin"
        path.write_bytes(bytes(60))
        return path, ("drop.bin", "--calibration")
    path = tmp_path / "notes.txt"
    path.write_text("a field note")
    return path, ("notes.txt", ".gef")


@pytest.mark.parametrize("case", ["truncated gzip", "sgf row", "pnt short", "bluedrop without calibration",
                                  "unknown suffix"])
def test_a_broken_field_file_is_one_line_and_writes_nothing(tmp_path, runner, case):
    db = tmp_path / "ws" / "runs.duckdb"
    assert invoke(runner, "ingest", FILES["gef"], "--db", db).exit_code == 0
    before = {p: p.read_bytes() for p in db.parent.rglob("*") if p.is_file()}
    path, words = _broken(tmp_path, case)
    r = invoke(runner, "ingest", path, "--db", db)
    assert r.exit_code == 1 and "Traceback" not in r.output + r.stderr
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and all(w in lines[0] for w in words), (lines, words)
    after = {p: p.read_bytes() for p in db.parent.rglob("*") if p.is_file()}
    assert after.keys() == before.keys()
    assert [row[0] for row in catalog_rows(db)] == ["cpt2"]


def test_field_commands_give_the_same_answer_from_a_record_as_from_its_file(tmp_path, runner):
    db = tmp_path / "runs.duckdb"
    assert invoke(runner, "ingest", FILES["ags"], FILES["pnt"], "--db", db).exit_code == 0
    by_file = invoke(runner, "soundings", "layers", FILES["ags"], "--json")
    by_id = invoke(runner, "soundings", "layers", "HKZ_*CPT02*", "--json", "--db", db)
    assert by_file.exit_code == 0 and by_id.exit_code == 0, by_id.stderr
    assert json.loads(by_id.stdout) == json.loads(by_file.stdout) and json.loads(by_id.stdout)[0]["layers"]
    by_file = invoke(runner, "snow", "estimate", FILES["pnt"], "--layer", "0:150", "--json")
    by_id = invoke(runner, "snow", "estimate", "SNEX20_SMP_S19M1256_2S7_20200208", "--layer", "0:150", "--json",
                   "--db", db)
    assert by_id.exit_code == 0, by_id.stderr
    assert json.loads(by_id.stdout) == json.loads(by_file.stdout)
    wrong = invoke(runner, "snow", "show", "HKZ_*CPT02*", "--db", db)
    assert wrong.exit_code == 1 and "expected a SnowMicroPen profile" in wrong.stderr
    missing = invoke(runner, "soundings", "show", "HALS99", "--db", db)
    assert missing.exit_code == 1 and "HALS99" in missing.stderr and "Traceback" not in missing.output
    listed = invoke(runner, "records", "--kind", "cptu", "--json", "--db", db)
    assert [r["record_id"] for r in json.loads(listed.stdout)] == ["HKZ_20161114_FEBV_HKZ1-CPT02_AGS4.0_V03_F"]


def test_a_file_of_several_soundings_gives_one_record_each(tmp_path, runner):
    text = gzip.decompress(FILES["sgf"].read_bytes()).decode("cp1252")
    second = text.replace("HK=#1", "HK=#2", 1)
    path = tmp_path / "two.cpt"
    path.write_text(text.rstrip("\n") + "\n" + second, encoding="cp1252")
    db = tmp_path / "runs.duckdb"
    r = invoke(runner, "ingest", path, "--json", "--db", db)
    assert r.exit_code == 0, r.stderr
    assert [o["id"] for o in json.loads(r.stdout)] == ["two-1", "two-2"]
    assert [o["source"] for o in json.loads(r.stdout)] == [f"{path}##1", f"{path}##2"]


def test_a_record_never_takes_a_run_id(tmp_path, runner):
    db = tmp_path / "runs.duckdb"
    shutil.copytree(REPO / "examples" / "workspace", tmp_path, dirs_exist_ok=True)
    path = tmp_path / "mc-1.0-4.gef"
    shutil.copy(FILES["gef"], path)
    r = invoke(runner, "ingest", path, "--json", "--db", db)
    assert r.exit_code == 0, r.stderr
    (outcome,) = json.loads(r.stdout)
    assert outcome["id"].startswith("mc-1.0-4-") and "taken" in outcome["warnings"][0]


def pen(db: Path, *args: str, crash: str | None = None) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("PEN_DB", "PEN_TEST_CRASH_AT")}
    if crash is not None:
        env["PEN_TEST_CRASH_AT"] = crash
    return subprocess.run([sys.executable, "-m", "pencli", *map(str, args), "--db", str(db)], capture_output=True,
                          text=True, env=env, cwd=db.parent, timeout=300)


@pytest.mark.parametrize("point", ["before-rename", "before-commit"])
def test_an_ingest_killed_mid_write_is_finished_or_undone_by_the_next_command(tmp_path, point):
    db = tmp_path / "runs.duckdb"
    assert pen(db, "ingest", FILES["gef"]).returncode == 0
    killed = pen(db, "ingest", FILES["sgf"], crash=point)
    assert killed.returncode != 0
    assert [row[0] for row in catalog_rows(db)] == ["cpt2"]
    again = pen(db, "ingest", FILES["sgf"])
    assert again.returncode == 0, again.stderr
    assert [row[0] for row in catalog_rows(db)] == ["HALS01", "cpt2"]
    if point == "before-commit":  # the file was in place: adopted, after its content hash was checked
        assert "adopted as record 'HALS01'" in again.stderr
    check = pen(db, "runs", "check")
    assert check.returncode == 0, check.stdout + check.stderr
    assert not [p for p in tmp_path.rglob(".*") if p.is_file()]


def test_a_changed_record_is_found_by_check_and_dropped_by_repair(tmp_path):
    db = tmp_path / "runs.duckdb"
    assert pen(db, "ingest", FILES["gef"], FILES["sgf"]).returncode == 0
    import pyarrow as pa
    import pyarrow.parquet as pq

    path = tmp_path / "records" / "HALS01.parquet"
    table = pq.read_table(path)
    depth = table.column("depth_m").to_numpy().copy()
    depth[10] += 0.01
    pq.write_table(table.set_column(table.column_names.index("depth_m"), "depth_m", pa.array(depth)), path)
    check = pen(db, "runs", "check")
    assert check.returncode == 1 and "HALS01" in check.stdout + check.stderr
    assert pen(db, "soundings", "show", "HALS01").returncode == 1
    assert pen(db, "runs", "check", "--repair").returncode == 0
    assert [row[0] for row in catalog_rows(db)] == ["cpt2"]
    assert pen(db, "ingest", FILES["sgf"]).returncode == 0 and pen(db, "soundings", "show", "HALS01").returncode == 0


def test_a_catalog_from_before_field_records_is_read_and_then_upgraded(tmp_path, runner):
    from pencli.store.migrations import MIGRATIONS
    from pencli.testing.helpers import older_catalog

    db = older_catalog(tmp_path, 4)
    listed = invoke(runner, "records", "--json", "--db", db)
    assert listed.exit_code == 0 and json.loads(listed.stdout) == []  # read as it is
    assert invoke(runner, "ingest", FILES["gef"], "--db", db).exit_code == 0  # writes: upgrades the catalog
    con = duckdb.connect(str(db), read_only=True)
    try:
        assert con.execute("SELECT count(*) FROM runs").fetchone()[0] == 12
        assert con.execute("SELECT max(version) FROM schema_migrations").fetchone()[0] == MIGRATIONS[-1][0]
    finally:
        con.close()
    assert invoke(runner, "runs", "check", "--db", db).exit_code == 0
