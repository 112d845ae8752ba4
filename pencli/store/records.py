"""Field records in the workspace: ``records/<record_id>.parquet`` and a row of the ``records`` table each.

A record (a sounding, a snow profile, a free-fall drop; :mod:`pencli.io.field`) is stored once and never
changed: its columns as a Parquet table, its header and the rest of what its file said in the table's
metadata, and a catalog row with its kind, instrument, source and content hash.  The write is atomic like a
run's stage (file under a temporary name, row in a transaction, rename, commit); the same data ingested twice
is the same record.  The table is documented in ``schema/catalog.md``.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path

import duckdb
import pyarrow as pa
import pyarrow.parquet as pq

from pencli import __version__
from pencli.errors import StoreError
from pencli.io.field import FieldRecord, json_safe, suffix_of

RECORDS_DIR = "records"
COLUMNS = ("record_id", "content_sha256", "kind", "geometry", "drive", "sensors", "name", "source", "source_sha256",
           "source_format", "n_rows", "depth_max_m", "channels", "header", "path", "ingested_at", "command",
           "pen_version")
"""The ``records`` table's columns, in order."""


@dataclass(frozen=True)
class AddedRecord:
    """Outcome of adding a record: its id, whether it was new, and a line when it was stored under another id than
    its file's name."""

    record_id: str
    created: bool
    renamed: str | None = None


def file_sha256(path: str | Path) -> str:
    """SHA-256 of a file's bytes (the source a record was read from)."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def wanted_id(record: FieldRecord, several: bool) -> str:
    """The id a record asks for: its file's name without format suffixes, and its own name when the file holds
    several records."""
    from pencli.store.workspace import safe_id

    stem = Path(str(record.source).removesuffix(".gz").removesuffix(".GZ")).name
    suffix = suffix_of(record.source)
    if suffix and stem.lower().endswith(suffix):
        stem = stem[: -len(suffix)]
    return safe_id(f"{stem}-{safe_id(record.name)}" if several else stem)


def id_taken(con, record_id: str) -> bool:
    """Whether a run or a record has the id (the two share one name space: a command resolves either)."""
    return any(con.execute(sql, [record_id]).fetchone() is not None
               for sql in ("SELECT 1 FROM records WHERE record_id = ?", "SELECT 1 FROM runs WHERE run_id = ?"))


def add_record(ws, record: FieldRecord, *, several: bool, source_sha256: str, command: str) -> AddedRecord:
    """Store ``record`` in workspace ``ws`` (atomic).  The same data added again returns the stored record."""
    from pencli.store.workspace import _atomically, _now, write_parquet

    digest = record.digest
    wanted = wanted_id(record, several)
    with ws.connect(write=True) as con:
        row = con.execute("SELECT record_id FROM records WHERE content_sha256 = ?", [digest]).fetchone()
        if row is not None:
            return AddedRecord(row[0], False)
        record_id = wanted if not id_taken(con, wanted) else f"{wanted}-{digest[:8]}"
        folder = ws.db_path.parent / RECORDS_DIR
        folder.mkdir(parents=True, exist_ok=True)
        final = folder / f"{record_id}.parquet"
        if final.exists():
            raise StoreError(f"{final}: exists but is not in the catalog; pen runs check --repair adopts or "
                             f"quarantines it")
        tmp = folder / f".{final.name}.{os.getpid()}.tmp"
        instrument = record.instrument
        row = dict(zip(COLUMNS, (
            record_id, digest, record.kind, instrument.geometry, instrument.drive, instrument.sensors, record.name,
            str(record.source), source_sha256, record.format, record.rows, record.depth_max_m, sorted(record.columns),
            json.dumps(json_safe(record.header)), str(final.relative_to(ws.db_path.parent)), _now(), command,
            __version__)))
        stored = {"format": record.format, "kind": record.kind, "name": record.name, "source": str(record.source),
                  "header": json_safe(record.header), "extras": json_safe(record.extras)}
        meta = {b"pen:record": json.dumps(stored).encode(), b"pen:content_sha256": digest.encode(),
                b"pen:record_row": json.dumps(row, default=str).encode()}
        table = pa.table({name: pa.array(values, type=pa.float64()) for name, values in record.columns.items()})
        with _atomically(con, tmp, final):
            write_parquet(table.replace_schema_metadata(meta), tmp)
            con.execute(f"INSERT INTO records VALUES ({', '.join('?' * len(COLUMNS))})", list(row.values()))
    renamed = None
    if record_id != wanted:
        renamed = f"{record.source}: record {record.name!r} stored as {record_id!r} ('{wanted}' is taken)"
    return AddedRecord(record_id, True, renamed)


def _record_from(table: pa.Table) -> tuple[FieldRecord, str]:
    """The record a stored table holds, and the content hash its metadata says it has."""
    meta = {k.decode(): v.decode() for k, v in (table.schema.metadata or {}).items()}
    stored = json.loads(meta["pen:record"])
    columns = {name: table.column(name).to_numpy() for name in table.column_names}
    record = FieldRecord(stored["format"], stored["kind"], stored["name"], columns, stored["header"],
                         stored["extras"], stored["source"])
    return record, meta["pen:content_sha256"]


def read_record_file(path: Path, record_id: str, expected_sha256: str) -> FieldRecord:
    """A stored record, its content checked against the catalog's hash (else one line naming the file)."""
    try:
        table = pq.read_table(path)
    except FileNotFoundError:
        raise StoreError(f"{path}: record '{record_id}' is missing from the workspace; restore the file, or let "
                         f"pen runs check --repair drop it and ingest its source again") from None
    except (OSError, pa.ArrowException) as exc:
        raise StoreError(f"{path}: cannot read record '{record_id}': {str(exc).splitlines()[0]}") from None
    try:
        record, _ = _record_from(table)
        same = record.digest == expected_sha256
    except (KeyError, ValueError, TypeError):
        same = False
    if not same:
        raise StoreError(f"{path}: record '{record_id}' has changed since it was written (its content no longer "
                         f"matches the catalog's hash); restore it, or let pen runs check --repair drop it")
    return record


def record_rows(ws, *, kind: str | None = None, family: str | None = None) -> list[dict]:
    """The catalog rows of the workspace's records (a kind's or a family's only, when given), by id; none on a
    catalog from before records."""
    from pencli.io.field import FORMATS

    formats = [name for name, f in FORMATS.items() if f.family == family] if family else None
    with ws.connect() as con:
        try:
            cursor = con.execute("SELECT * FROM records ORDER BY record_id")
        except duckdb.CatalogException:
            return []
        names = [d[0] for d in cursor.description]
        rows = [dict(zip(names, r)) for r in cursor.fetchall()]
    return [r for r in rows if (kind is None or r["kind"] == kind)
            and (formats is None or r["source_format"] in formats)]


def load_record(ws, ref: str, rows: list[dict] | None = None) -> FieldRecord:
    """A stored record by id (as asked or as stored), or by the file it was ingested from; ``rows``: the
    catalog's (:func:`record_rows`), when the caller has them already."""
    from pencli.store.workspace import safe_id

    rows = record_rows(ws) if rows is None else rows
    by_id = {r["record_id"]: r for r in rows}
    chosen = next((by_id[c] for c in (ref, safe_id(ref)) if c in by_id), None)
    if chosen is None:
        sources = [r for r in rows if r["source"] == ref or Path(r["source"]).name == Path(ref).name]
        if len(sources) == 1:
            chosen = sources[0]
    if chosen is None:
        raise StoreError(f"no field record '{ref}' in {ws.db_path} (give a record id from `pen records`, or a "
                         f"file)")
    return read_record_file(ws.db_path.parent / chosen["path"], chosen["record_id"], chosen["content_sha256"])


def record_problems(ws, con) -> list[tuple[str, Path, str]]:
    """(record id, its file, one line) for each stored record whose file is missing or changed."""
    try:
        rows = con.execute("SELECT record_id, path, content_sha256 FROM records ORDER BY record_id").fetchall()
    except duckdb.CatalogException:
        return []
    problems = []
    for record_id, relative, digest in rows:
        path = ws.db_path.parent / relative
        try:
            read_record_file(path, record_id, digest)
        except StoreError as exc:
            problems.append((record_id, path, str(exc)))
    return problems


def check_records(ws, con) -> list[str]:
    """One line per stored record whose file is missing or changed."""
    return [line for _, _, line in record_problems(ws, con)]


def repair_records(ws, con) -> list[str]:
    """Drop the catalog row of each record whose file is missing or changed (a changed file goes to quarantine);
    returns one line per record dropped."""
    from pencli.store.workspace import QUARANTINE, _now

    notes = []
    for record_id, path, _ in record_problems(ws, con):
        con.execute("DELETE FROM records WHERE record_id = ?", [record_id])
        if path.is_file():
            target = ws.db_path.parent / QUARANTINE / _now().strftime("%Y%m%dT%H%M%S") / RECORDS_DIR / path.name
            target.parent.mkdir(parents=True, exist_ok=True)
            os.replace(path, target)
        notes.append(f"{path}: missing or changed, so record '{record_id}' left the catalog; ingest its source "
                     f"again")
    return notes


def catalogued_paths(con) -> set[str]:
    """The record files the catalog names (relative to the workspace)."""
    try:
        return {r[0] for r in con.execute("SELECT path FROM records").fetchall()}
    except duckdb.CatalogException:
        return set()


def adopt_record(ws, con, path: Path) -> str | None:
    """Catalog a record file an interrupted ingest left behind, when its own metadata and content hash say exactly
    what it is; None otherwise."""
    table = pq.read_table(path)
    record, digest = _record_from(table)
    meta = {k.decode(): v.decode() for k, v in (table.schema.metadata or {}).items()}
    row = json.loads(meta["pen:record_row"])
    if (record.digest != digest or row["content_sha256"] != digest or path.name != f"{row['record_id']}.parquet"
            or id_taken(con, row["record_id"])
            or con.execute("SELECT 1 FROM records WHERE content_sha256 = ?", [digest]).fetchone() is not None):
        return None
    row["ingested_at"] = dt.datetime.fromisoformat(row["ingested_at"])
    row["path"] = str(path.relative_to(ws.db_path.parent))
    con.execute(f"INSERT INTO records VALUES ({', '.join('?' * len(COLUMNS))})", [row[c] for c in COLUMNS])
    return f"record '{row['record_id']}'"


__all__ = ["AddedRecord", "COLUMNS", "RECORDS_DIR", "add_record", "adopt_record", "catalogued_paths",
           "check_records", "file_sha256", "id_taken", "load_record", "read_record_file", "record_problems", "record_rows",
           "repair_records",
           "wanted_id"]
