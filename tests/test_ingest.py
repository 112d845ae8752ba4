"""Ingest, export, the catalog and its guarantees."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pencli import api
from pencli.errors import StoreError
from tests.conftest import REPO, SPEC, invoke
from pencli.testing.helpers import COLUMNS, snapshot, synthetic_columns, write_folder, write_bam_workbook

EXAMPLE = SPEC / "examples" / "run_grill_brick_1.5mm"


def test_contract_example_ingests_without_edits_and_round_trips(workspace, runner):
    r = invoke(runner, "ingest", EXAMPLE, "--json")
    assert r.exit_code == 0, r.output
    (entry,) = json.loads(r.stdout)
    assert entry["id"] == "example-001" and entry["source"] == str(EXAMPLE.resolve())
    out = workspace / "exported"
    assert invoke(runner, "export", "example-001", "--to", out).exit_code == 0
    original = np.genfromtxt(EXAMPLE / "data.csv", delimiter=",", names=True)
    exported = np.genfromtxt(out / "data.csv", delimiter=",", names=True)
    for name in COLUMNS:
        assert np.array_equal(original[name], exported[name]), name
    again = json.loads(invoke(runner, "ingest", out, "--json").stdout)
    assert again[0]["id"] == "example-001" and again[0]["status"] == "existing"
    assert len(api.list_runs(workspace / "runs.duckdb")) == 1


def _roundtrip(tmp: Path, columns, fmt: str):
    db = tmp / "runs.duckdb"
    src = write_folder(tmp / "src", columns)
    (first,) = api.ingest([src], db)
    assert first.status == "added", first.message
    api.export_run(db, first.id, tmp / "out", data_format=fmt)
    db2 = tmp / "second" / "runs.duckdb"
    (second,) = api.ingest([tmp / "out"], db2)
    assert second.status == "added", second.message
    a, _ = api.workspace(db).read_stage(first.id, "raw")
    b, _ = api.workspace(db2).read_stage(second.id, "raw")
    for name in COLUMNS:
        assert np.array_equal(a.column(name).to_numpy(), b.column(name).to_numpy()), name
    assert api.workspace(db).run_row(first.id)["content_sha256"] == api.workspace(db2).run_row(second.id)["content_sha256"]
    assert api.workspace(db).run_parameters(first.id) == api.workspace(db2).run_parameters(second.id)


floats = st.floats(-5000, 5000, allow_nan=False, allow_infinity=False, width=64)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(values=st.lists(floats, min_size=6, max_size=6), rate=st.sampled_from([1000.0, 30000.0, 60000.0]),
       n=st.integers(16, 400), seed=st.integers(0, 10_000))
def test_ingest_export_ingest_is_lossless(tmp_path_factory, values, rate, n, seed):
    tmp = tmp_path_factory.mktemp("rt")
    cols = synthetic_columns(n=n, rate=rate, seed=seed)
    for name, value in zip(COLUMNS[2:], values):
        cols[name] = cols[name] + value / 7.0  # arbitrary float64 bits
    cols["position_mm"] = cols["position_mm"] + np.linspace(0, 40.0, n)
    _roundtrip(tmp, cols, "csv")


def test_xlsx_round_trip_is_lossless(tmp_path):
    cols = synthetic_columns(n=500)
    _roundtrip(tmp_path, cols, "xlsx")


# --- one deliberately broken file per case, named for what is wrong --------------------------
def _text(cols=None):
    cols = cols or synthetic_columns(n=600)
    lines = [",".join(COLUMNS)] + [",".join(repr(float(v)) for v in row)
                                   for row in np.column_stack([cols[c] for c in COLUMNS])]
    return lines


def _broken(name: str, folder: Path) -> tuple[Path, str]:
    lines = _text()
    if name == "time_not_monotonic":
        lines[300], lines[301] = lines[301], lines[300]
        return write_folder(folder, text="\n".join(lines) + "\n"), "row 302"
    if name == "time_not_uniform":
        del lines[300]
        return write_folder(folder, text="\n".join(lines) + "\n"), "uniform"
    if name == "nan_value":
        fields = lines[100].split(",")
        fields[4] = "nan"
        lines[100] = ",".join(fields)
        return write_folder(folder, text="\n".join(lines) + "\n"), "row 101"
    if name == "inf_value":
        fields = lines[50].split(",")
        fields[2] = "inf"
        lines[50] = ",".join(fields)
        return write_folder(folder, text="\n".join(lines) + "\n"), "fx_n"
    if name == "missing_column":
        text = "\n".join(",".join(line.split(",")[:7]) for line in lines) + "\n"
        return write_folder(folder, text=text), "missing column 'tz_nm'"
    if name == "empty_file":
        return write_folder(folder, text=""), "empty"
    if name == "header_only":
        return write_folder(folder, text=lines[0] + "\n"), "no data rows"
    if name == "truncated_last_row":
        text = "\n".join(lines[:-1]) + "\n" + ",".join(lines[-1].split(",")[:3])
        return write_folder(folder, text=text), "fields"
    if name == "text_in_number_column":
        fields = lines[20].split(",")
        fields[4] = "error"
        lines[20] = ",".join(fields)
        return write_folder(folder, text="\n".join(lines) + "\n"), "row 21: column fz_n is 'error'"
    if name == "position_in_metres":
        cols = synthetic_columns(n=600)
        cols["position_mm"] = cols["position_mm"] / 1000.0
        return write_folder(folder, text="\n".join(_text(cols)) + "\n"), "metres"
    if name == "force_beyond_sensor_range":
        cols = synthetic_columns(n=600)
        cols["fz_n"][400] = 25000.0
        return write_folder(folder, text="\n".join(_text(cols)) + "\n"), "sensor's range"
    if name == "missing_parameter_file":
        return write_folder(folder, synthetic_columns(), material=None), "material.yaml"
    if name == "bad_parameter_file":
        path = write_folder(folder, synthetic_columns())
        (path / "penetrator.yaml").write_text((path / "penetrator.yaml").read_text() + "blade_colour_mm: 3\n")
        return path, "blade_colour_mm"
    if name == "damaged_xlsx":
        path = write_folder(folder, text="placeholder", data_name="data.xlsx")
        (path / "data.xlsx").write_bytes(b"PK\x03\x04 this is not a workbook")
        return path, "workbook"
    if name == "time_in_milliseconds":
        cols = synthetic_columns(n=600)
        cols["time_s"] = cols["time_s"] * 1000
        return write_folder(folder, text="\n".join(_text(cols)) + "\n"), "ms"
    raise AssertionError(name)


BROKEN = ["time_not_monotonic", "time_not_uniform", "nan_value", "inf_value", "missing_column", "empty_file",
          "header_only", "truncated_last_row", "text_in_number_column", "position_in_metres",
          "force_beyond_sensor_range", "missing_parameter_file", "bad_parameter_file", "damaged_xlsx",
          "time_in_milliseconds"]


@pytest.mark.parametrize("name", BROKEN)
def test_broken_run_is_rejected_alone_and_workspace_unchanged(workspace, runner, name):
    good = write_folder(workspace / "good", synthetic_columns(seed=1))
    assert invoke(runner, "ingest", good).exit_code == 0
    before = snapshot(workspace)
    bad, words = _broken(name, workspace / f"bad_{name}")
    other = write_folder(workspace / "other", synthetic_columns(seed=2))
    r = invoke(runner, "ingest", bad, other, "--json")
    assert r.exit_code == 1
    records = {Path(rec["source"]).name: rec for rec in json.loads(r.stdout)}
    assert records[bad.name]["status"] == "rejected"
    message = records[bad.name]["error"]
    assert words in message and "\n" not in message, message
    assert records["other"]["status"] == "added"  # the rest of the batch went on
    # the bad run left nothing behind: only "other" was added
    shutil.rmtree(workspace / "runs" / records["other"]["id"])
    after_rows, after_files = snapshot(workspace)
    before_rows, before_files = before
    assert after_files == before_files
    assert sum(len(t) for t in after_rows) == sum(len(t) for t in before_rows) + 1 + 3 + 1


def test_rejection_is_one_line_on_stderr_without_traceback(workspace, runner):
    bad, _ = _broken("time_not_uniform", workspace / "bad")
    r = invoke(runner, "ingest", bad)
    assert r.exit_code == 1 and "Traceback" not in r.output
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("rejected") and "data.csv" in lines[0]


def test_rounded_time_stamps_are_uniform_enough(workspace):
    """Six significant digits (as a text export writes) must pass; the example does this."""
    cols = synthetic_columns(n=20000, rate=60000.0)
    cols["time_s"] = np.array([float(f"{t:.6g}") for t in cols["time_s"] + 1.2])
    (o,) = api.ingest([write_folder(workspace / "rounded", cols)], workspace / "runs.duckdb")
    assert o.status == "added", o.message


def test_bam_workbook_with_other_headers_and_units(workspace, runner):
    cols = synthetic_columns(n=800)
    folder = write_bam_workbook(workspace / "bam", cols, ["Time (ms)", "Pos (m)", "Fx", "Fy", "Fz", "Mx", "My", "Mz"],
                                lambda row: [row[0] * 1000, row[1] / 1000, *[v / 1000 for v in row[2:5]], *row[5:]])
    plain = invoke(runner, "ingest", folder)
    assert plain.exit_code == 1 and "--columns" in plain.stderr
    r = invoke(runner, "ingest", folder, "--json", "--columns",
               "time=Time (ms),position=Pos (m),fx=Fx,fy=Fy,fz=Fz,tx=Mx,ty=My,tz=Mz",
               "--time-unit", "ms", "--position-unit", "m", "--force-unit", "kN")
    assert r.exit_code == 0, r.output
    run_id = json.loads(r.stdout)[0]["id"]
    table, stage = api.workspace(workspace / "runs.duckdb").read_stage(run_id, "raw")
    assert np.allclose(table.column("position_mm").to_numpy(), cols["position_mm"], rtol=1e-12, atol=1e-12)
    assert np.allclose(table.column("fz_n").to_numpy(), cols["fz_n"], rtol=1e-12)
    assert stage.parameters["columns"]["time_s"] == "Time (ms)"


def test_parent_folders_and_globs(workspace, runner):
    for i in range(3):
        write_folder(workspace / "campaign" / f"run{i}", synthetic_columns(seed=10 + i))
    r = invoke(runner, "ingest", workspace / "campaign", "--json")
    assert r.exit_code == 0 and len(json.loads(r.stdout)) == 3
    r2 = invoke(runner, "ingest", str(workspace / "campaign" / "run*"), "--json")
    assert {rec["status"] for rec in json.loads(r2.stdout)} == {"existing"}
    none = invoke(runner, "ingest", str(workspace / "nothing*"))
    assert none.exit_code == 1 and "matches no file" in none.stderr


def test_same_data_with_other_parameters_is_refused(workspace):
    cols = synthetic_columns(seed=5)
    db = workspace / "runs.duckdb"
    assert api.ingest([write_folder(workspace / "a", cols)], db)[0].status == "added"
    (o,) = api.ingest([write_folder(workspace / "b", cols, penetrator="al6061_2mm")], db)
    assert o.status == "rejected" and "blade_thickness_mm" in o.message and "immutable" in o.message


def test_interrupted_write_leaves_nothing(workspace, monkeypatch):
    db = workspace / "runs.duckdb"
    api.ingest([write_folder(workspace / "first", synthetic_columns(seed=1))], db)
    before = snapshot(workspace)
    real_replace = os.replace

    def interrupted(src, dst):
        if str(dst).endswith(".parquet"):
            raise KeyboardInterrupt
        return real_replace(src, dst)

    monkeypatch.setattr(os, "replace", interrupted)
    with pytest.raises(KeyboardInterrupt):
        api.ingest([write_folder(workspace / "second", synthetic_columns(seed=2))], db)
    monkeypatch.setattr(os, "replace", real_replace)
    assert snapshot(workspace) == before


def test_locked_workspace_waits_then_fails_clearly(workspace, runner, monkeypatch):
    db = workspace / "runs.duckdb"
    api.ingest([write_folder(workspace / "first", synthetic_columns(seed=1))], db)
    second = write_folder(workspace / "second", synthetic_columns(seed=2))
    before = snapshot(workspace)
    holder = subprocess.Popen([sys.executable, "-c", textwrap.dedent(f"""
        import duckdb, sys, time
        con = duckdb.connect({str(db)!r})
        print("locked", flush=True)
        time.sleep(30)
    """)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        monkeypatch.setenv("PEN_LOCK_TIMEOUT_S", "0.5")
        r = invoke(runner, "ingest", second, "--json")
        assert r.exit_code == 1
        message = json.loads(r.stdout)[0]["error"]
        assert "locked by another pen process" in message and "PEN_LOCK_TIMEOUT_S" in message
    finally:
        holder.kill()
        holder.wait()
        holder.stdout.close()
    assert snapshot(workspace) == before


def test_two_concurrent_ingests_never_corrupt(workspace):
    db = workspace / "runs.duckdb"
    for b, batch in enumerate(("a", "b")):
        for i in range(6):  # distinct seeds: ingest rightly merges identical recordings under one id
            write_folder(workspace / batch / f"{batch}{i}", synthetic_columns(seed=100 * b + i))
    procs = [subprocess.Popen([sys.executable, "-m", "pencli", "ingest", str(workspace / batch), "--json",
                               "--db", str(db)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for batch in ("a", "b")]
    outs = [p.communicate(timeout=120) for p in procs]
    assert all(p.returncode == 0 for p in procs), outs
    ids = [rec["id"] for out, _ in outs for rec in json.loads(out)]
    assert len(set(ids)) == 12
    ws = api.workspace(db)
    assert sorted(ids) == ws.run_ids()
    for run_id in ids:  # every catalog row has its file and every file its row
        (stage,) = ws.stages(run_id)
        assert stage.path.is_file()
    files = sorted(p for p in (workspace / "runs").rglob("*") if p.is_file())
    assert len(files) == 12 and not any(p.name.endswith(".tmp") for p in files)


def test_a_new_catalog_never_shows_under_its_name_half_made(tmp_path, monkeypatch):
    """Two processes making the same new catalog race unless it appears whole: DuckDB opens a file another
    process has created but not yet written as "not a valid DuckDB database file"."""
    from pencli.store.workspace import Workspace

    db = tmp_path / "runs.duckdb"
    seen = []
    migrate = Workspace._migrate

    def watched(self, con):
        seen.append(db.exists())
        migrate(self, con)

    monkeypatch.setattr(Workspace, "_migrate", watched)
    with Workspace(db).connect(write=True) as con:
        assert con.execute("SELECT count(*) FROM runs").fetchone() == (0,)
    assert seen[0] is False  # the first migration wrote a file under another name
    assert sorted(p.name for p in tmp_path.iterdir()) == ["runs.duckdb"]  # and nothing else is left


def test_runs_list_filters_show_and_query(workspace, runner):
    write_folder(workspace / "g1", synthetic_columns(seed=1), info={"id": "g1", "date": "2026-01-05", "tags": ["x"]})
    write_folder(workspace / "m1", synthetic_columns(seed=2), material="mpacs_c", energizing="springs_2",
                 penetrator="al6061_2mm", info={"id": "m1", "date": "2026-02-05"})
    assert invoke(runner, "ingest", workspace / "g1", workspace / "m1").exit_code == 0

    def ids(*args):
        r = invoke(runner, "runs", *args, "--json")
        assert r.exit_code == 0, r.output
        return sorted(row["run_id"] for row in json.loads(r.stdout))

    assert ids() == ["g1", "m1"]
    assert ids("--material", "mpacs_c") == ["m1"]
    assert ids("--blade", "2") == ["m1"]
    assert ids("--springs", "4") == ["g1"]
    assert ids("--tag", "x") == ["g1"]
    assert ids("--since", "2026-02-01") == ["m1"]
    assert ids("--until", "2026-01-31") == ["g1"]
    show = invoke(runner, "runs", "show", "m1", "--json")
    detail = json.loads(show.stdout)
    assert detail["parameters"]["penetrator"]["blade_thickness_mm"] == 2.0
    assert detail["stages"][0]["stage"] == "raw" and detail["stages"][0]["command"] == "pen ingest"
    by_folder = invoke(runner, "runs", "show", str(workspace / "runs" / "m1"), "--json")
    assert json.loads(by_folder.stdout)["run"]["run_id"] == "m1"
    q = invoke(runner, "runs", "query", "SELECT material, count(*) AS n FROM runs GROUP BY material ORDER BY 1",
               "--json")
    assert json.loads(q.stdout) == [{"material": "grill_brick", "n": 1}, {"material": "mpacs_c", "n": 1}]
    bad = invoke(runner, "runs", "query", "SELEKT 1")
    assert bad.exit_code == 1 and "query failed" in bad.stderr
    missing = invoke(runner, "runs", "show", "nope")
    assert missing.exit_code == 1 and "no run 'nope'" in missing.stderr


def test_parquet_stage_is_self_describing(workspace):
    import pyarrow.parquet as pq

    (o,) = api.ingest([EXAMPLE], workspace / "runs.duckdb")
    (stage,) = api.workspace(workspace / "runs.duckdb").stages(o.id)
    meta = pq.read_schema(stage.path).metadata
    assert meta[b"pen:stage"] == b"raw" and meta[b"pen:command"] == b"pen ingest"
    params = json.loads(meta[b"pen:run_parameters"])
    assert params["material"]["microstructure_strength_kpa"] == 1630
    assert json.loads(meta[b"pen:parameters"])["source"] == str(EXAMPLE.resolve())
    assert meta[b"pen:version"]


def test_export_refuses_a_non_empty_folder(workspace, runner):
    invoke(runner, "ingest", EXAMPLE)
    target = workspace / "t"
    target.mkdir()
    (target / "keep.txt").write_text("mine")
    r = invoke(runner, "export", "example-001", "--to", target)
    assert r.exit_code == 1 and "not empty" in r.stderr
    assert (target / "keep.txt").read_text() == "mine"


def test_reading_without_a_workspace_says_how_to_make_one(workspace, runner):
    r = invoke(runner, "runs")
    assert r.exit_code == 1 and "pen ingest" in r.stderr
    assert not (workspace / "runs.duckdb").exists()


def test_store_error_is_an_oserror():
    assert issubclass(StoreError, OSError)


def test_runs_list_never_cuts_an_id(workspace, runner, tmp_path):
    """Ids were cut ("mc-1…") at 80–100 columns and when piped; piped output is plain text."""
    import shutil

    long_id = "mpacs-c-block-7-blade-1.5mm-springs-4-repeat-12"
    folder = tmp_path / "long"
    shutil.copytree(EXAMPLE, folder)
    (folder / "run.yaml").write_text(f"id: {long_id}\n")
    assert invoke(runner, "ingest", folder).exit_code == 0
    listing = invoke(runner, "runs")
    assert listing.exit_code == 0, listing.output
    lines = listing.stdout.splitlines()
    assert lines[0].split("\t")[0] == "run"  # not a terminal here: tab-separated, one run a line
    assert any(line.split("\t")[0] == long_id for line in lines[1:]), listing.stdout


def test_a_dropped_sample_is_named_at_its_own_row(tmp_path, workspace, runner):
    """A row missing at file row 8002 was reported at row 3684 (where the drift crossed tolerance)."""
    import shutil

    folder = tmp_path / "dropped"
    shutil.copytree(EXAMPLE, folder)
    lines = (folder / "data.csv").read_text().splitlines(keepends=True)
    del lines[8001]  # file row 8002 (the header is row 1)
    (folder / "data.csv").write_text("".join(lines))
    r = invoke(runner, "ingest", folder)
    assert r.exit_code == 1
    assert "row 8002" in r.stderr and "uniform" in r.stderr, r.stderr


def test_any_failure_is_one_line_for_that_run_and_the_batch_goes_on(tmp_path, workspace, runner, monkeypatch):
    """A full disk, a reader's unexpected error, a 'billion laughs' run.yaml and a repeated header
    each become one line for their run; the other runs are stored and the summary is printed."""
    import shutil

    from pencli.store import workspace as store

    folders = {}
    for name in ("good", "laughs", "dup", "full", "crash"):
        folders[name] = tmp_path / name
        shutil.copytree(EXAMPLE, folders[name])
        (folders[name] / "run.yaml").write_text(f"id: {name}\n")
    lol = '["lol","lol","lol","lol","lol","lol","lol","lol","lol"]'
    (folders["laughs"] / "run.yaml").write_text(
        f"a: &a {lol}\nb: &b [*a,*a,*a,*a,*a,*a,*a,*a,*a]\nc: &c [*b,*b,*b,*b,*b,*b,*b,*b,*b]\n"
        "d: &d [*c,*c,*c,*c,*c,*c,*c,*c,*c]\ne: &e [*d,*d,*d,*d,*d,*d,*d,*d,*d]\nid: laughs\n")
    lines = (folders["dup"] / "data.csv").read_text().splitlines(keepends=True)
    lines[0] = lines[0].replace("fx_n", "fz_n", 1)
    (folders["dup"] / "data.csv").write_text("".join(lines))
    real_add = store.Workspace.add_run

    def add_run(self, run, **kwargs):
        if run.info.get("id") == "full":
            raise OSError(28, "No space left on device")
        return real_add(self, run, **kwargs)

    import pencli.io.runfolder as runfolder

    real_read = runfolder.read_run_folder

    def read(folder, *args, **kwargs):
        if Path(folder).name == "crash":
            raise RuntimeError("the reader tripped\nover something")
        return real_read(folder, *args, **kwargs)

    monkeypatch.setattr(store.Workspace, "add_run", add_run)
    monkeypatch.setattr(runfolder, "read_run_folder", read)
    r = invoke(runner, "ingest", *folders.values())
    assert r.exit_code == 1, r.output
    assert "1 added" in r.stdout + r.stderr and "4 rejected" in r.stdout + r.stderr
    errors = [line for line in r.stderr.splitlines() if line.startswith("rejected")]
    assert len(errors) == 4, r.stderr
    assert any("alias" in e for e in errors) and any("'fz_n' twice" in e for e in errors)
    assert any("no space left" in e.lower() for e in errors) and any("RuntimeError: the reader tripped" in e for e in errors)
    assert "Traceback" not in r.output
    assert [row["run_id"] for row in api.list_runs(workspace / "runs.duckdb")] == ["good"]


def test_runs_query_cannot_write_and_a_tampered_stage_is_detected(workspace, runner, tmp_path):
    """`COPY ... TO` overwrote a raw stage, ATTACH modified another database; stage hashes were never
    re-checked."""
    import pyarrow.parquet as pq

    assert invoke(runner, "ingest", EXAMPLE).exit_code == 0
    raw = next((workspace / "runs").rglob("00-raw.parquet"))
    before = raw.read_bytes()
    for sql in (f"COPY (SELECT 1 AS x) TO '{raw}'", f"COPY (SELECT 1) TO '{tmp_path / 'out.csv'}'",
                f"ATTACH '{tmp_path / 'other.duckdb'}' (READ_WRITE)", "CREATE TABLE t (x INTEGER)",
                f"SELECT * FROM read_csv('{EXAMPLE / 'data.csv'}')"):
        r = invoke(runner, "runs", "query", sql)
        assert r.exit_code == 1 and "query failed" in r.stderr and len(r.stderr.strip().splitlines()) == 1, sql
    assert raw.read_bytes() == before
    assert not (tmp_path / "out.csv").exists() and not (tmp_path / "other.duckdb").exists()
    assert invoke(runner, "runs", "query", "SELECT count(*) AS n FROM runs", "--json").exit_code == 0
    # tamper with the raw stage behind pen's back: the next read refuses it, naming the file
    table = pq.read_table(raw)
    fz = table.column("fz_n").to_numpy().copy()
    fz[100] += 1.0
    pq.write_table(table.set_column(table.column_names.index("fz_n"), "fz_n", [fz]), raw)
    r = invoke(runner, "tare", "all")
    assert r.exit_code == 1 and "has changed since it was written" in r.stderr and str(raw) in r.stderr


def test_export_never_touches_the_workspace_and_force_replaces_only_its_own_files(workspace, runner):
    """`export ID --to runs/ID --force` destroyed the run's stages; --force deleted unrelated files."""
    invoke(runner, "ingest", EXAMPLE)
    run_folder = next((workspace / "runs").iterdir())
    before = {p: p.read_bytes() for p in run_folder.rglob("*") if p.is_file()}
    for inside in (run_folder, workspace / "runs" / "new", workspace / "fits" / "x"):
        r = invoke(runner, "export", "example-001", "--to", inside, "--force")
        assert r.exit_code == 1 and "inside the workspace" in r.stderr, inside
    assert {p: p.read_bytes() for p in run_folder.rglob("*") if p.is_file()} == before
    assert invoke(runner, "tare", "example-001").exit_code == 0  # the run is intact
    target = workspace / "t"
    target.mkdir()
    (target / "keep.txt").write_text("mine")
    (target / "data.xlsx").write_bytes(b"stale")
    r = invoke(runner, "export", "example-001", "--to", target, "--force")
    assert r.exit_code == 0, r.output
    assert (target / "keep.txt").read_text() == "mine"
    assert (target / "data.csv").is_file() and not (target / "data.xlsx").exists()
    assert invoke(runner, "ingest", target, "--json").exit_code == 0  # the exported folder reads back


def test_conditioning_again_with_the_same_options_gives_the_same_stage(workspace, runner):
    """Each `pen tare` stacked a new stage (one run reached 8)."""
    invoke(runner, "ingest", EXAMPLE)
    for _ in range(3):
        assert invoke(runner, "tare", "all").exit_code == 0
        assert invoke(runner, "subtract-inertia", "all").exit_code == 0
    stages = api.run_detail(workspace / "runs.duckdb", "example-001").stages
    assert [s.stage for s in stages] == ["raw", "tare", "inertia"]
    assert invoke(runner, "tare", "all", "--window", "1,20").exit_code == 0  # other options: a new stage
    assert [s.stage for s in api.run_detail(workspace / "runs.duckdb", "example-001").stages][-1] == "tare"


def test_stage_parameters_that_differ_by_round_off_are_the_same_stage(tmp_path):
    """The bundled example, made by another numpy, stacked a tare stage: its stored contact speed differed from
    today's in the 16th digit.  Derived numbers equal to round-off are the same stage; options that differ are not."""
    from pencli.store.workspace import Workspace

    work = tmp_path / "ws"
    shutil.copytree(REPO / "examples" / "workspace", work)
    ws = Workspace(work / "runs.duckdb")
    run = "gb-2.0-4"
    table, tare_stage = ws.read_stage(run, "tare")
    nudged = json.loads(json.dumps(tare_stage.parameters))
    nudged["events"]["contact_speed_m_s"] = float(np.nextafter(nudged["events"]["contact_speed_m_s"], 99.0))
    again = ws.add_stage(run, "tare", table, parent_no=0, command="pen tare", parameters=nudged)
    assert again.stage_no == tare_stage.stage_no
    nudged["window_ms"] = [1.0, 20.0]
    other = ws.add_stage(run, "tare", table, parent_no=0, command="pen tare", parameters=nudged)
    assert other.stage_no == 3


def test_ingest_accepts_out_of_range_parameters_when_asked(workspace, runner, tmp_path):
    """Ingest advised --allow-out-of-range, which it did not have."""
    import shutil

    folder = tmp_path / "thick"
    shutil.copytree(EXAMPLE, folder)
    text = (folder / "penetrator.yaml").read_text().replace("blade_thickness_mm: 1.5", "blade_thickness_mm: 60")
    (folder / "penetrator.yaml").write_text(text)
    refused = invoke(runner, "ingest", folder)
    assert refused.exit_code == 1 and "--allow-out-of-range" in refused.stderr
    accepted = invoke(runner, "ingest", folder, "--allow-out-of-range")
    assert accepted.exit_code == 0, accepted.output


def test_written_files_and_folders_honour_the_umask(workspace, runner, tmp_path):
    """Outputs were 0600 and folders 0700 whatever the umask (tempfile's modes)."""
    import stat

    from pencli.io.atomic import write_atomic

    old = os.umask(0o022)
    try:
        out = write_atomic(tmp_path / "a.txt", lambda p: p.write_text("x"))
        assert stat.S_IMODE(out.stat().st_mode) == 0o644
        invoke(runner, "ingest", EXAMPLE)
        assert invoke(runner, "export", "example-001", "--to", tmp_path / "exported").exit_code == 0
        assert stat.S_IMODE((tmp_path / "exported").stat().st_mode) == 0o755
        assert stat.S_IMODE((tmp_path / "exported" / "data.csv").stat().st_mode) == 0o644
    finally:
        os.umask(old)


def test_an_extra_column_is_named_not_dropped_in_silence(workspace, runner, tmp_path):
    """An extra column was dropped silently, so export looked lossless and was not."""
    columns = synthetic_columns()
    columns_with_extra = {**columns, "temp_c": np.full(len(columns["time_s"]), 21.5)}
    header = [*COLUMNS[:3], "temp_c", *COLUMNS[3:]]
    lines = [",".join(header)] + [",".join(repr(float(columns_with_extra[c][i])) for c in header)
                                  for i in range(len(columns["time_s"]))]
    folder = write_folder(tmp_path / "thermo", text="\n".join(lines) + "\n")
    r = invoke(runner, "ingest", folder, "--json")
    assert r.exit_code == 0, r.output
    (entry,) = json.loads(r.stdout)
    assert entry["status"] == "added" and "'temp_c'" in entry["warnings"][0]
    raw = api.run_detail(workspace / "runs.duckdb", entry["id"]).stages[0]
    assert raw.parameters["ignored_columns"] == ["temp_c"]
    plain = invoke(runner, "ingest", write_folder(tmp_path / "thermo2", text="\n".join(
        lines[:1] + [line.replace(",21.5,", ",22.5,") for line in lines[1:]]) + "\n"))
    # the same contract data again: the existing run, and nothing more to say
    assert plain.exit_code == 0 and "existing" in plain.stdout and "temp_c" not in plain.stderr
