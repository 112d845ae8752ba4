"""A workspace: ``runs.duckdb`` (the catalog) and ``runs/`` beside it.

Layout (documented in ``schema/catalog.md``)::

    runs.duckdb
    runs/<run_id>/00-raw.parquet       immutable, content-hashed
    runs/<run_id>/01-tare.parquet      each conditioning stage, numbered
    ...
    records/<record_id>.parquet        a field record (sounding, snow profile, drop), immutable

Every write is atomic: the Parquet file is written under a temporary name,
the catalog rows are inserted in a transaction, the file is renamed into
place, then the transaction commits.  Any failure (or Ctrl-C) rolls the
transaction back and removes the file, so a Parquet file never exists
without its catalog row nor the other way round.

DuckDB lets one process write a database file at a time.  pen opens the
catalog only for the moment it needs it and, when another process holds it,
retries for a bounded time (``PEN_LOCK_TIMEOUT_S``, default 30 s) before
failing with a message naming the file and the process.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import json
import os
import re
import shutil
import signal
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator, Mapping, Sequence

import duckdb
import pyarrow as pa
import pyarrow.parquet as pq

from pencli import __version__
from pencli.errors import PenError, PenNotice, StoreError
from pencli.io.atomic import make_parents, remove_made
from pencli.params.validate import validate_mapping
from pencli.run import RAW_COLUMNS, RAW_STAGE, Run, Stage
from pencli.store import records as field_store
from pencli.store.migrations import LATEST, MIGRATIONS
from pencli.store.records import RECORDS_DIR
from pencli.store.rundata import content_hash, raw_table, table_hash

DEFAULT_LOCK_TIMEOUT_S = 30.0
MAX_LOCK_TIMEOUT_S = 86_400.0
"""A day: longer than any pen command holds the catalog; a larger wait is a typo. [s]"""
_ID_SAFE = re.compile(r"[^A-Za-z0-9._-]+")
_TEMPORARY = re.compile(r"^\.(?:.+\.(?P<pid>\d+)\.tmp"                       # a stage or fit being written
                        r"|pending-(?P<pid2>\d+)-\d+\.parquet"                # a sweep being written
                        r"|.+\.compact-(?P<pid3>\d+)(?:\.wal)?)$")             # a catalog being compacted
_STAGE_FILE = re.compile(r"^(\d{2})-([A-Za-z0-9_-]+)\.parquet$")
QUARANTINE = "quarantine"


def _as_table(columns: pa.Table | Mapping[str, Any]) -> pa.Table:
    """A stage's or fit's columns as an Arrow table: callers hand the store plain arrays, by name."""
    return columns if isinstance(columns, pa.Table) else pa.table({k: columns[k] for k in columns})


def crash_point(name: str) -> None:
    """Die here, as kill -9 would, when ``PEN_TEST_CRASH_AT`` names this point (for the crash tests only)."""
    if os.environ.get("PEN_TEST_CRASH_AT") == name:
        os.kill(os.getpid(), signal.SIGKILL)


MAX_ID_LENGTH = 80
"""Longest run id kept: a folder name on every file system, and a column a table shows whole. [characters]"""


def safe_id(text: str) -> str:
    """The run id pen stores for ``text``: runs of other characters become '-', at most MAX_ID_LENGTH long."""
    return (_ID_SAFE.sub("-", text).strip("-.") or "run")[:MAX_ID_LENGTH]


def lock_timeout_from_environment() -> float:
    """``PEN_LOCK_TIMEOUT_S`` [s] (default 30 s), or one line saying what is wrong with it."""
    from pencli.environment import number_from_environment

    return number_from_environment("PEN_LOCK_TIMEOUT_S", float, 0.0, MAX_LOCK_TIMEOUT_S, DEFAULT_LOCK_TIMEOUT_S,
                                   "seconds to wait for a locked workspace", StoreError)


def _pid_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


@dataclass(frozen=True)
class AddedRun:
    """Outcome of adding a run: its id and whether it was new."""

    run_id: str
    created: bool
    source: str
    renamed: str | None = None
    """When the run is stored under another id than it asked for: one line saying which and why."""


@dataclass(frozen=True)
class StageRecord:
    """One stage of a run, as the catalog records it."""

    run_id: str
    stage_no: int
    stage: str
    parent_no: int | None
    path: Path
    content_sha256: str
    command: str
    parameters: dict
    pen_version: str
    created_at: dt.datetime


def _stage_digest(table: pa.Table, stage_no: int) -> str:
    """The hash the catalog keeps of a stage: the raw columns' content hash for stage 0, else the table's."""
    if stage_no == 0:
        return content_hash({name: table.column(name).to_numpy() for name in RAW_COLUMNS})
    return table_hash(table)


@contextlib.contextmanager
def _atomically(con: duckdb.DuckDBPyConnection, tmp: Path | None, final: Path | None,
                new_folder: Path | None = None) -> Iterator[None]:
    """A transaction whose commit also moves ``tmp`` to ``final``.

    The body writes ``tmp`` and inserts rows; then the file is renamed into
    place and the transaction commits.  Any failure (Ctrl-C included) rolls
    back and removes both files and, when given, the run folder just made.
    """
    committed = False
    con.execute("BEGIN TRANSACTION")
    try:
        yield
        crash_point("before-rename")
        if tmp is not None and final is not None:
            os.replace(tmp, final)
        crash_point("before-commit")
        con.execute("COMMIT")
        committed = True
        crash_point("after-commit")
    finally:
        if not committed:
            with contextlib.suppress(Exception):
                con.execute("ROLLBACK")
            for path in (tmp, final):
                if path is not None:
                    with contextlib.suppress(FileNotFoundError):
                        path.unlink()
            if new_folder is not None:
                with contextlib.suppress(OSError):
                    new_folder.rmdir()


def _now() -> dt.datetime:
    return dt.datetime.now(dt.timezone.utc).replace(tzinfo=None, microsecond=0)


class Workspace:
    """The catalog and run folders of one workspace."""

    def __init__(self, db_path: str | Path, *, lock_timeout_s: float | None = None):
        self.db_path = Path(db_path)
        self.runs_dir = self.db_path.parent / "runs"
        if lock_timeout_s is None:
            lock_timeout_s = lock_timeout_from_environment()
        self.lock_timeout_s = lock_timeout_s
        self._batch: dict | None = None
        self._recovered = False

    # ------------------------------------------------------------------ connection
    def exists(self) -> bool:
        """Whether the catalog file exists."""
        return self.db_path.is_file()

    @contextlib.contextmanager
    def batch(self, hold_s: float = 0.5, pause_s: float = 0.06, *, write: bool = True) -> Iterator["Workspace"]:
        """Reuse one connection for many reads and writes (opening one costs ~15 ms); ``write=False``: for reads
        alone (a read-only workspace can be read so).

        The lock is handed back every ``hold_s`` seconds for ``pause_s``, so a
        concurrent pen process (which polls every ≤ 50 ms) gets its turn.
        """
        if self._batch is not None:  # already in one: it serves
            yield self
            return
        self._batch = {"con": None, "since": 0.0, "hold": hold_s, "pause": pause_s, "write": write}
        try:
            yield self
        finally:
            con = self._batch["con"]
            self._batch = None
            if con is not None:
                con.close()

    @contextlib.contextmanager
    def connect(self, *, write: bool = False) -> Iterator[duckdb.DuckDBPyConnection]:
        """Open the catalog (creating and migrating it when writing), with a bounded wait on a lock."""
        shared = self._batch
        if shared is not None and (shared["write"] or not write):
            if shared["con"] is not None and time.monotonic() - shared["since"] > shared["hold"]:
                shared["con"].close()
                shared["con"] = None
                time.sleep(shared["pause"])  # let a waiting process in
            if shared["con"] is None:
                shared["con"] = self._open(write=shared["write"])
                shared["since"] = time.monotonic()
            with self._catalog_faults():
                yield shared["con"]
            return
        if shared is not None and shared["con"] is not None:  # a write inside a reading batch: hand its lock back
            shared["con"].close()
            shared["con"] = None
        con = self._open(write=write)
        try:
            with self._catalog_faults():
                yield con
        finally:
            con.close()

    @contextlib.contextmanager
    def _catalog_faults(self) -> Iterator[None]:
        """A catalog write that the machine refuses (a full disk, a read-only folder) as one line naming the
        catalog; the transaction it was in is rolled back by DuckDB."""
        try:
            yield
        except (duckdb.IOException, duckdb.FatalException, duckdb.PermissionException,
                duckdb.TransactionException) as exc:  # "Failed to commit: Could not write file ..."
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise StoreError(f"{self.db_path}: the catalog could not be written: {first}") from None

    def _open(self, *, write: bool, config: dict | None = None) -> duckdb.DuckDBPyConnection:
        if not write and not self.exists():
            raise StoreError(f"{self.db_path}: no workspace here; add runs first (pen ingest PATH or pen acquire), "
                             f"or point --db / $PEN_DB at one")
        if write:
            self.db_path.parent.mkdir(parents=True, exist_ok=True)
            if not self.exists():
                self._create()
        deadline = time.monotonic() + self.lock_timeout_s
        delay = 0.02
        while True:
            try:
                con = duckdb.connect(str(self.db_path), read_only=not write, config=config or {})
                break
            except duckdb.IOException as exc:
                text = str(exc)
                if "lock" not in text.lower():
                    raise StoreError(f"{self.db_path}: cannot open the catalog: {text.splitlines()[0]}") from None
                if time.monotonic() >= deadline:
                    holder = re.search(r"PID (\d+)", text)
                    who = f" (process {holder.group(1)})" if holder else ""
                    raise StoreError(
                        f"{self.db_path}: the workspace is locked by another pen process{who} and stayed locked "
                        f"for {self.lock_timeout_s:g} s; wait for it to finish or raise PEN_LOCK_TIMEOUT_S") from None
                time.sleep(delay)
                delay = min(delay * 1.5, 0.05)
            except duckdb.Error as exc:
                raise StoreError(f"{self.db_path}: cannot open the catalog: {str(exc).splitlines()[0]}") from None
        try:
            if write:
                self._migrate(con)
                if not self._recovered:
                    self._recover(con)
                    self._recovered = True
            else:
                self._check_version(con)
        except BaseException:
            con.close()
            raise
        return con

    def _create(self) -> None:
        """Make a new, migrated catalog under a temporary name and link it into place.

        Two processes creating the same catalog at once would otherwise race: one can open the file the other
        has made but not yet written (DuckDB: "exists, but it is not a valid DuckDB database file").  The link
        fails if the catalog appeared meanwhile; then that one is used.
        """
        tmp = self.db_path.with_name(f".{self.db_path.name}.{os.getpid()}.tmp")
        try:
            con = duckdb.connect(str(tmp))
            try:
                self._migrate(con)
            finally:
                con.close()
            try:
                os.link(tmp, self.db_path)
            except FileExistsError:
                pass
            except OSError:  # a file system without hard links: a rename, which a racing creator may overwrite
                if not self.exists():
                    os.replace(tmp, self.db_path)
        except duckdb.Error as exc:
            raise StoreError(f"{self.db_path}: cannot create the catalog: {str(exc).splitlines()[0]}") from None
        finally:
            for path in (tmp, tmp.with_name(tmp.name + ".wal")):
                with contextlib.suppress(FileNotFoundError):
                    path.unlink()

    def _migrate(self, con: duckdb.DuckDBPyConnection) -> None:
        con.execute("CREATE TABLE IF NOT EXISTS schema_migrations (version INTEGER PRIMARY KEY, name VARCHAR, "
                    "applied_at TIMESTAMP, pen_version VARCHAR)")
        done = {row[0] for row in con.execute("SELECT version FROM schema_migrations").fetchall()}
        if done and max(done) > LATEST:
            raise StoreError(f"{self.db_path}: catalog schema version {max(done)} is newer than this pen "
                             f"({__version__}, schema {LATEST}); upgrade pen")
        for version, name, sql in MIGRATIONS:
            if version in done:
                continue
            con.execute("BEGIN TRANSACTION")
            try:
                con.execute(sql)
                con.execute("INSERT INTO schema_migrations VALUES (?, ?, ?, ?)", [version, name, _now(), __version__])
                con.execute("COMMIT")
            except BaseException:
                con.execute("ROLLBACK")
                raise

    def _check_version(self, con: duckdb.DuckDBPyConnection) -> None:
        try:
            version = con.execute("SELECT max(version) FROM schema_migrations").fetchone()[0]
        except duckdb.CatalogException:
            raise StoreError(f"{self.db_path}: not a pen workspace (no schema_migrations table)") from None
        if version is None or version > LATEST:
            raise StoreError(f"{self.db_path}: catalog schema version {version} is not one this pen reads "
                             f"(up to {LATEST})")
        # an older catalog is read as it is (migrations only add); writing commands upgrade it

    # ------------------------------------------------------------------ crash recovery
    def _recover(self, con: duckdb.DuckDBPyConnection) -> None:
        """Repair what a crash (kill -9, power loss) between a file's rename and its catalog commit leaves.

        Runs once per :class:`Workspace` when the catalog is first opened for writing, i.e. while this process
        holds the write lock, so no other pen is half-way through a write.  Temporary files of processes that
        are gone are removed; a stage, fit or sweep file the catalog does not know is adopted when its own
        metadata and content hash say exactly what it is, else moved to ``quarantine/<time>/`` (never
        deleted).  Each action is one :class:`PenNotice`.
        """
        root = self.db_path.parent
        strays = list(self._strays(con))
        removed = [path for kind, path in strays if kind == "temporary"]
        for path in removed:
            with contextlib.suppress(FileNotFoundError):
                path.unlink()
        if removed:
            warnings.warn(PenNotice(f"{self.db_path}: removed {len(removed)} temporary file(s) left by an "
                                    f"interrupted pen ({', '.join(str(p.relative_to(root)) for p in removed)})"),
                          stacklevel=2)
        adopters = {"stage": lambda path: self._adopt_stage(con, path), "fit": lambda path: self._adopt_fit(con, path),
                    "sweep": lambda path: None, "record": lambda path: field_store.adopt_record(self, con, path)}
        for kind, path in strays:
            if kind != "temporary":
                self._settle(path, kind, lambda: adopters[kind](path))
        for folder in (p for p in self.runs_dir.iterdir() if p.is_dir()) if self.runs_dir.is_dir() else ():
            if not any(folder.iterdir()) and con.execute(
                    "SELECT 1 FROM runs WHERE run_id = ?", [folder.name]).fetchone() is None:
                folder.rmdir()

    def _strays(self, con) -> Iterator[tuple[str, Path]]:
        """Files in the workspace's folders that the catalog does not account for, as (kind, path): kind is
        ``temporary`` (of a pen process that is gone), ``stage``, ``fit`` or ``sweep``; stages in stage order."""
        root = self.db_path.parent
        run_folders = sorted(p for p in self.runs_dir.iterdir() if p.is_dir()) if self.runs_dir.is_dir() else []
        for folder in [root, root / "fits", root / "sweeps", root / RECORDS_DIR, *run_folders]:
            for path in sorted(folder.iterdir()) if folder.is_dir() else ():
                match = _TEMPORARY.match(path.name)
                if match is None or (folder == root and not path.name.startswith(f".{self.db_path.name}.")):
                    continue
                if not _pid_alive(int(match.group("pid") or match.group("pid2") or match.group("pid3"))):
                    yield "temporary", path
        catalogued = {r[0] for sql in ("SELECT path FROM stages", "SELECT model_data_path FROM materials",
                                       "SELECT path FROM sweeps") for r in con.execute(sql).fetchall()}
        catalogued |= field_store.catalogued_paths(con)
        listed = [("stage", p) for folder in run_folders for p in sorted(folder.iterdir()) if _STAGE_FILE.match(p.name)]
        listed += [(kind, p) for kind, folder in (("fit", root / "fits"), ("sweep", root / "sweeps"),
                                                  ("record", root / RECORDS_DIR))
                   for p in (sorted(folder.glob("[!.]*.parquet")) if folder.is_dir() else ())]
        for kind, path in listed:
            if str(path.relative_to(root)) not in catalogued:
                yield kind, path

    def check(self, *, repair: bool = False) -> list[str]:
        """Every problem of the workspace, one line each (empty: all is well).

        Each catalogued stage is read and its content hash compared with the catalog's (a tampered or
        truncated file is found); fit and sweep files must exist; files the catalog does not account for are
        listed.  ``repair`` first runs the crash recovery (adopt, quarantine, remove stale temporaries).
        """
        if repair:
            with self.connect(write=True) as con:
                self._repair_catalog(con)
        root = self.db_path.parent
        problems = []
        with self.connect() as con:
            for run_id in [r[0] for r in con.execute("SELECT run_id FROM runs ORDER BY run_id").fetchall()]:
                records = self._stages(con, run_id)
                if not records or records[0].stage_no != 0:
                    problems.append(f"run '{run_id}': its raw stage is not in the catalog (a removal was interrupted; "
                                    f"pen runs check --repair finishes it)")
                for record in records:
                    try:
                        self._read_record(record)
                    except StoreError as exc:
                        problems.append(str(exc))
            problems += field_store.check_records(self, con)
            for what, sql in (("fitted material's model-vs-data table", "SELECT model_data_path FROM materials"),
                              ("sweep", "SELECT path FROM sweeps")):
                for (relative,) in con.execute(sql).fetchall():
                    if relative is not None and not (root / relative).is_file():
                        problems.append(f"{root / relative}: the {what} is missing from the workspace")
            for kind, path in self._strays(con):
                what = ("temporary file of an interrupted pen" if kind == "temporary"
                        else f"{kind} file not in the catalog")
                problems.append(f"{path}: {what} (pen runs check --repair adopts, quarantines or removes it)")
        return problems

    def _repair_catalog(self, con) -> None:
        """Make the catalog agree with the files again, each action one :class:`PenNotice`: a stage whose file
        is missing or changed goes from the catalog with every stage made from it (their files to quarantine;
        a raw stage takes the run, which can then be ingested again from its source); a fitted material's
        missing model-vs-data table is forgotten (the fit itself is kept); a sweep whose table is missing goes."""
        root = self.db_path.parent
        for run_id in [r[0] for r in con.execute("SELECT run_id FROM runs ORDER BY run_id").fetchall()]:
            records = self._stages(con, run_id)
            broken = []
            if not records or records[0].stage_no != 0:
                broken = records[:1] or [None]
            for record in records:
                if broken:
                    break
                try:
                    self._read_record(record)
                except StoreError:
                    broken = [record]
            if not broken:
                continue
            first = broken[0]
            dropped = records if first is None or first.stage_no == 0 else _lineage(records, first.stage_no)
            where = self._drop(con, run_id, dropped, whole=first is None or first.stage_no == 0)
            what = (f"run '{run_id}'" if first is None or first.stage_no == 0 else
                    f"stage {first.stage_no} ({first.stage})" + (f" and {len(dropped) - 1} stage(s) made from it"
                                                                 if len(dropped) > 1 else "") + f" of run '{run_id}'")
            source = self.db_path if first is None else first.path
            warnings.warn(PenNotice(f"{source}: missing or changed, so {what} left the catalog"
                                    + (f"; the files that remained were moved to {where.relative_to(root)}"
                                       if where is not None else "")
                                    + ("; ingest the run again from its source" if first is None or first.stage_no == 0
                                       else "; run that step again")), stacklevel=3)
        for material, version, relative in con.execute(
                "SELECT material, version, model_data_path FROM materials WHERE model_data_path IS NOT NULL"
        ).fetchall():
            if not (root / relative).is_file():
                con.execute("UPDATE materials SET model_data_path = NULL WHERE material = ? AND version = ?",
                            [material, version])
                warnings.warn(PenNotice(f"{root / relative}: missing, so version {version} of fitted material "
                                        f"'{material}' keeps its coefficients without its model-vs-data table"),
                              stacklevel=3)
        for note in field_store.repair_records(self, con):
            warnings.warn(PenNotice(note), stacklevel=3)
        for sweep_id, relative in con.execute("SELECT sweep_id, path FROM sweeps").fetchall():
            if not (root / relative).is_file():
                con.execute("DELETE FROM sweeps WHERE sweep_id = ?", [sweep_id])
                warnings.warn(PenNotice(f"{root / relative}: missing, so sweep {sweep_id} left the catalog"),
                              stacklevel=3)

    # ------------------------------------------------------------------ removal
    def remove(self, ref: str, *, stage: str | int | None = None, purge: bool = False) -> "Removal":
        """Take a run (or one derived stage and every stage made from it) out of the workspace.

        The files go to ``quarantine/<time>-removed/`` (deleted with ``purge``); the catalog rows go after the
        files have moved, so an interruption leaves files in quarantine and rows that ``pen runs check
        --repair`` finishes removing, never a row that names a file still in place of another.
        """
        run_id = self.resolve(ref)
        with self.connect(write=True) as con:
            records = self._stages(con, run_id)
            chosen = records
            if stage is not None:
                matches = [r for r in records if r.stage == str(stage) or str(r.stage_no) == str(stage)]
                if not matches:
                    raise StoreError(f"run '{run_id}' has no stage {stage!r}; it has: "
                                     f"{', '.join(f'{r.stage_no}:{r.stage}' for r in records)}")
                if matches[-1].stage_no != 0:
                    chosen = _lineage(records, matches[-1].stage_no)
            whole = not chosen or chosen[0].stage_no == 0
            where = self._drop(con, run_id, chosen, whole=whole)
        if purge and where is not None:
            shutil.rmtree(where, ignore_errors=True)
            with contextlib.suppress(OSError):
                where.parent.rmdir()  # quarantine/, when this removal made it
            where = None
        return Removal(run_id, tuple(f"{r.stage_no}:{r.stage}" for r in chosen), whole, where)

    def _drop(self, con, run_id: str, records: Sequence[StageRecord], *, whole: bool) -> Path | None:
        """Move ``records``' files to quarantine, then delete their rows (and the run's, when ``whole``).
        Returns the quarantine folder, or None when no file was there to move."""
        root = self.db_path.parent
        folder = root / QUARANTINE / f"{_now().strftime('%Y%m%dT%H%M%S')}-removed"
        moved: list[tuple[Path, Path]] = []
        made: list[Path] = []
        try:
            for record in records:
                if record.path.is_file():
                    target = folder / record.path.relative_to(root)
                    made += make_parents(target.parent)
                    os.replace(record.path, target)
                    moved.append((record.path, target))
            numbers = [r.stage_no for r in records]
            if numbers:
                con.execute(f"DELETE FROM stages WHERE run_id = ? AND stage_no IN ({', '.join('?' * len(numbers))})",
                            [run_id, *numbers])
        except BaseException:
            for original, target in moved:  # rows still in place: put their files back
                with contextlib.suppress(OSError):
                    os.replace(target, original)
            remove_made(made)
            raise
        if whole:
            # DuckDB checks a foreign key against rows deleted earlier in the same transaction, so each table
            # goes in its own; a run row left without stages is finished by --repair
            con.execute("DELETE FROM stages WHERE run_id = ?", [run_id])
            con.execute("DELETE FROM run_parameters WHERE run_id = ?", [run_id])
            con.execute("DELETE FROM runs WHERE run_id = ?", [run_id])
            with contextlib.suppress(OSError):
                (self.runs_dir / run_id).rmdir()
        return folder if moved else None

    def _settle(self, path: Path, kind: str, adopt) -> None:
        """Adopt one file the catalog does not know (``adopt()`` returns what it became), or quarantine it."""
        root = self.db_path.parent
        relative = path.relative_to(root)
        try:
            what = adopt()
        except (OSError, ValueError, KeyError, TypeError, pa.ArrowException, duckdb.Error, PenError):
            what = None
        if what is not None:
            warnings.warn(PenNotice(f"{path}: {kind} file left uncatalogued by an interrupted pen was checked "
                                    f"(content hash) and adopted as {what}"), stacklevel=3)
            return
        target = root / QUARANTINE / _now().strftime("%Y%m%dT%H%M%S") / relative
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.move(str(path), str(target))
        warnings.warn(PenNotice(f"{path}: {kind} file not in the catalog (left by an interrupted pen or put there "
                                f"by hand) moved to {target.relative_to(root)}; nothing was deleted"), stacklevel=3)

    def _adopt_stage(self, con, path: Path) -> str | None:
        run_id, stage_no = path.parent.name, int(path.name[:2])
        meta = {k.decode(): v.decode() for k, v in (pq.read_schema(path).metadata or {}).items()}
        if meta.get("pen:run_id") != run_id or meta.get("pen:stage_no") != str(stage_no):
            return None
        if not path.name.endswith(f"-{meta['pen:stage']}.parquet"):
            return None
        table = pq.read_table(path)
        digest = meta["pen:content_sha256"]
        if _stage_digest(table, stage_no) != digest:
            return None
        parent = json.loads(meta["pen:parent_no"])
        taken = con.execute("SELECT 1 FROM stages WHERE run_id = ? AND stage_no = ?", [run_id, stage_no]).fetchone()
        if taken is not None:
            return None
        created = dt.datetime.fromisoformat(meta["pen:created_at"])
        parameters = json.loads(meta["pen:parameters"])
        con.execute("BEGIN TRANSACTION")
        try:
            if stage_no == 0:
                if con.execute("SELECT 1 FROM runs WHERE run_id = ? OR content_sha256 = ?",
                               [run_id, digest]).fetchone() is not None:
                    con.execute("ROLLBACK")
                    return None
                sets = json.loads(meta["pen:run_parameters"])
                run = Run(raw_columns_of(table), *(validate_mapping(sets[kind], f"{path} ({kind})",
                                                                    expected_kind=kind, allow_out_of_range=True)
                                                   for kind in ("penetrator", "material", "energizing")),
                          info=json.loads(meta["pen:run_info"]), source=str(parameters.get("source", path)),
                          source_format=str(parameters.get("format", "")))
                self._insert_run(con, run_id, run, digest, created)
            elif parent is None or con.execute("SELECT 1 FROM stages WHERE run_id = ? AND stage_no = ?",
                                               [run_id, parent]).fetchone() is None:
                con.execute("ROLLBACK")
                return None
            _insert_stage_row(con, run_id, stage_no, meta["pen:stage"], parent,
                              str(path.relative_to(self.db_path.parent)), digest, meta["pen:command"],
                              meta["pen:parameters"], meta["pen:version"], created)
            con.execute("COMMIT")
        except BaseException:
            con.execute("ROLLBACK")
            raise
        return f"stage {stage_no} ({meta['pen:stage']}) of run '{run_id}'"

    def _adopt_fit(self, con, path: Path) -> str | None:
        meta = {k.decode(): v.decode() for k, v in (pq.read_schema(path).metadata or {}).items()}
        material, version = meta["pen:material"], int(meta["pen:version"])
        if path.name != f"{_ID_SAFE.sub('-', material)}-v{version}.parquet":
            return None
        if con.execute("SELECT 1 FROM materials WHERE material = ? AND version = ?",
                       [material, version]).fetchone() is not None:
            return None
        _insert_material_row(con, material, version, json.loads(meta["pen:fit"]),
                             json.loads(meta["pen:source_runs"]), json.loads(meta["pen:material_file"]),
                             str(path.relative_to(self.db_path.parent)), meta["pen:command"])
        return f"version {version} of fitted material '{material}'"

    # ------------------------------------------------------------------ runs
    def add_run(self, run: Run, *, command: str) -> AddedRun:
        """Add a raw run (immutable).  The same data added again returns the existing run."""
        digest = content_hash(run.columns)
        wanted = self._wanted_id(run)
        with self.connect(write=True) as con:
            row = con.execute("SELECT run_id FROM runs WHERE content_sha256 = ?", [digest]).fetchone()
            if row is not None:
                self._check_same_parameters(con, row[0], run)
                return AddedRun(row[0], False, run.source)
            run_id = wanted
            if field_store.id_taken(con, run_id):
                run_id = f"{wanted}-{digest[:8]}"
            asked = str(run.info.get("id") or Path(run.source).name or "run")
            table = raw_table(run)
            record = {
                "stage": RAW_STAGE, "run_id": run_id, "parent": None, "command": command,
                "parameters": {"source": run.source, "format": run.source_format, **run.reader_options},
            }
            stage = self._write_stage(con, run_id, 0, table, record, digest, run_rows=(run, digest))
        renamed = None
        if run_id != asked:
            why = (f"'{wanted}' is another run's id" if run_id != wanted else
                   f"ids keep letters A-Z and a-z, digits, '.', '_' and '-', at most {MAX_ID_LENGTH} characters")
            renamed = f"{run.source}: run id {asked!r} stored as {run_id!r} ({why})"
        return AddedRun(stage.run_id, True, run.source, renamed)

    def _wanted_id(self, run: Run) -> str:
        return safe_id(str(run.info.get("id") or Path(run.source).name or "run"))

    def _check_same_parameters(self, con, run_id: str, run: Run) -> None:
        stored = {k: json.loads(p) for k, p in con.execute(
            "SELECT kind, parameters FROM run_parameters WHERE run_id = ?", [run_id]).fetchall()}
        for ps in run.parameter_sets():
            old = stored.get(ps.kind, {})
            new = ps.to_mapping()
            for key in sorted(set(old) | set(new)):
                if key in ("name", "notes"):
                    continue
                if old.get(key) != new.get(key):
                    raise StoreError(
                        f"{run.source}: the same data is already run '{run_id}' but with {ps.kind} {key} = "
                        f"{old.get(key)!r}, not {new.get(key)!r}; raw runs are immutable (export it, fix the "
                        f"parameter file, or keep the stored one)")

    def _write_stage(self, con, run_id: str, stage_no: int, table: pa.Table, record: dict, digest: str,
                     run_rows: tuple[Run, str] | None = None) -> StageRecord:
        """Write one stage file and its catalog rows atomically."""
        folder = self.runs_dir / run_id
        created_folder = not folder.exists()
        folder.mkdir(parents=True, exist_ok=True)
        final = folder / f"{stage_no:02d}-{record['stage']}.parquet"
        if final.exists():
            raise StoreError(f"{final}: exists but is not in the catalog; move it away (left by an older failure?)")
        tmp = folder / f".{final.name}.{os.getpid()}.tmp"
        now = _now()
        meta = {
            "pen:stage": record["stage"], "pen:stage_no": str(stage_no), "pen:run_id": run_id,
            "pen:parent_no": json.dumps(record.get("parent")), "pen:command": record["command"],
            "pen:parameters": json.dumps(record["parameters"], default=str), "pen:version": __version__,
            "pen:created_at": now.isoformat(), "pen:content_sha256": digest,
        }
        if run_rows is not None:
            meta["pen:run_parameters"] = json.dumps({ps.kind: ps.to_mapping() for ps in run_rows[0].parameter_sets()})
            meta["pen:run_info"] = json.dumps(run_rows[0].info, default=str)
        merged = dict(table.schema.metadata or {})
        merged.update({k.encode(): v.encode() for k, v in meta.items()})
        table = table.replace_schema_metadata(merged)
        with _atomically(con, tmp, final, folder if created_folder else None):
            write_parquet(table, tmp)
            if run_rows is not None:
                self._insert_run(con, run_id, *run_rows, now)
            _insert_stage_row(con, run_id, stage_no, record["stage"], record.get("parent"),
                              str(final.relative_to(self.runs_dir.parent)), digest, record["command"],
                              json.dumps(record["parameters"], default=str), __version__, now)
        return StageRecord(run_id, stage_no, record["stage"], record.get("parent"), final, digest,
                           record["command"], record["parameters"], __version__, now)

    def _insert_run(self, con, run_id: str, run: Run, digest: str, now: dt.datetime) -> None:
        p, m, e = run.penetrator, run.material, run.energizing
        if e.drive != "springs":
            raise StoreError(f"{run.source}: drive {e.drive}: the workspace stores runs of the spring launcher only "
                             f"so far (a free-fall probe's record is ingested as a field record: BlueDrop .bin)")
        info = run.info
        tags = info.get("tags") or []
        if isinstance(tags, str):
            tags = [tags]
        run_date = info.get("date")
        if isinstance(run_date, str):
            try:
                run_date = dt.date.fromisoformat(run_date)
            except ValueError:
                run_date = None
        con.execute("INSERT INTO runs VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)", [
            run_id, digest, run.source, run.source_format, now, run_date,
            None if info.get("operator") is None else str(info.get("operator")),
            None if info.get("notes") is None else str(info.get("notes")),
            [str(t) for t in tags], json.dumps(info, default=str),
            m.name, p.name, e.name, p.get("blade_thickness_mm"), p.get("blade_width_mm"),  # None for a cone
            int(e.get("spring_count")), p.get("sprung_mass_kg"), e.get("surface_offset_mm"),
            run.sampling_rate_hz, run.n_samples, run.duration_s, __version__, p.geometry])
        for ps in run.parameter_sets():
            con.execute("INSERT INTO run_parameters VALUES (?, ?, ?, ?)",
                        [run_id, ps.kind, ps.name, json.dumps(ps.to_mapping())])

    # ------------------------------------------------------------------ stages
    def add_stage(self, run_id: str, stage: str, table: pa.Table | Mapping[str, Any], *, parent_no: int,
                  command: str, parameters: Mapping[str, Any]) -> StageRecord:
        """Append a conditioning stage to a run (atomic); ``table``: Arrow, or arrays by column name.

        The same step with the same parameters on the same parent giving the same table is the same stage:
        the existing record is returned and nothing is written (re-running ``pen tare`` does not stack copies).
        """
        table = _as_table(table)
        digest = table_hash(table)
        with self.connect(write=True) as con:
            last = con.execute("SELECT max(stage_no) FROM stages WHERE run_id = ?", [run_id]).fetchone()[0]
            if last is None:
                raise StoreError(f"no run '{run_id}' in {self.db_path}")
            recorded = json.loads(json.dumps(dict(parameters), default=str))  # as the catalog keeps them
            same = [r for r in self._stages(con, run_id) if r.stage == stage and r.parent_no == parent_no
                    and r.content_sha256 == digest and _same_parameters(r.parameters, recorded)]
            if same and same[-1].path.is_file():
                return same[-1]
            record = {"stage": stage, "parent": parent_no, "command": command, "parameters": dict(parameters)}
            return self._write_stage(con, run_id, last + 1, table, record, digest)

    def load_run(self, ref: str, stage: str | int | None = None) -> Run:
        """A stored run at ``stage`` (name or number; default: the latest): its columns, parameter sets, events
        and the lineage from the raw stage to it."""
        from pencli.filter.tare import Events
        from pencli.params.validate import sets_from_mappings

        with self.batch(write=False):  # one connection for the catalogue rows
            run_id = self.resolve(ref)
            records = self.stages(run_id)
            chosen = self._pick(records, run_id, stage)
            row = self.run_row(run_id)
            params = self.run_parameters(run_id)
        table = self._read_record(chosen)
        by_number = {r.stage_no: r for r in records}
        lineage, record = [], chosen
        while record is not None:
            lineage.append(Stage(record.stage, record.command, record.parameters, record.stage_no, record.parent_no))
            record = by_number.get(record.parent_no) if record.parent_no is not None else None
        raw = by_number[min(by_number)].parameters
        events = chosen.parameters.get("events")
        columns = (raw_columns_of(table) if chosen.stage == RAW_STAGE else
                   {name: table.column(name).to_numpy() for name in table.column_names})
        return Run(columns, *sets_from_mappings(params, run_id),
                   info=json.loads(row["info"]) if row.get("info") else {}, source=str(row["source"]),
                   source_format=str(row["source_format"]),
                   reader_options={k: v for k, v in raw.items() if k not in ("source", "format")},
                   run_id=run_id, lineage=tuple(reversed(lineage)), events=Events(**events) if events else None)

    def save_stage(self, run: Run) -> StageRecord:
        """Store the latest stage of ``run`` (made by :meth:`Run.with_stage` from a stored run)."""
        step = run.lineage[-1] if run.lineage else None
        if step is None or step.parent is None or not run.run_id:
            raise StoreError(f"run '{run.name}': only a new stage of a stored run can be saved as a stage")
        return self.add_stage(run.run_id, step.name, run.columns, parent_no=step.parent, command=step.command,
                              parameters=step.parameters)

    def stages(self, run_id: str) -> list[StageRecord]:
        """All stages of a run, oldest first."""
        with self.connect() as con:
            return self._stages(con, run_id)

    def _stages(self, con, run_id: str) -> list[StageRecord]:
        rows = con.execute("SELECT run_id, stage_no, stage, parent_no, path, content_sha256, command, parameters, "
                           "pen_version, created_at FROM stages WHERE run_id = ? ORDER BY stage_no",
                           [run_id]).fetchall()
        return [StageRecord(r[0], r[1], r[2], r[3], self.runs_dir.parent / r[4], r[5], r[6], json.loads(r[7]),
                            r[8], r[9]) for r in rows]

    def read_stage(self, run_id: str, stage: str | int | None = None) -> tuple[pa.Table, StageRecord]:
        """A stage's table (default: the latest stage) and its record."""
        chosen = self._pick(self.stages(run_id), run_id, stage)
        return self._read_record(chosen), chosen

    def _pick(self, records: Sequence[StageRecord], run_id: str, stage: str | int | None) -> StageRecord:
        """The stage ``stage`` names (a name: its newest; a number; None: the latest) of a run's records."""
        if not records:
            raise StoreError(f"no run '{run_id}' in {self.db_path}")
        if stage is None:
            return records[-1]
        matches = [r for r in records if r.stage == stage or r.stage_no == stage]
        if not matches:
            raise StoreError(f"run '{run_id}' has no stage {stage!r}; it has: "
                             f"{', '.join(f'{r.stage_no}:{r.stage}' for r in records)}")
        return matches[-1]

    def _read_record(self, chosen: StageRecord) -> pa.Table:
        """A stage's table, its content checked against the catalog's hash (else one line naming the file)."""
        run_id = chosen.run_id
        try:
            table = pq.read_table(chosen.path)
        except FileNotFoundError:
            raise StoreError(f"{chosen.path}: stage '{chosen.stage}' of run '{run_id}' is missing from the workspace; "
                             f"restore the file, or let pen runs check --repair drop it and the stages made from "
                             f"it") from None
        except (OSError, pa.ArrowException) as exc:
            raise StoreError(f"{chosen.path}: cannot read stage '{chosen.stage}' of run '{run_id}': {exc}") from None
        try:
            digest = _stage_digest(table, chosen.stage_no)
        except KeyError:
            digest = None  # a column is gone
        if digest != chosen.content_sha256:
            raise StoreError(f"{chosen.path}: stage '{chosen.stage}' of run '{run_id}' has changed since it was "
                             f"written (its content no longer matches the catalog's hash); restore it, or let pen "
                             f"runs check --repair drop it and the stages made from it")
        return table

    def read_table(self, relative: str, what: str, *, filters=None, columns=None) -> pa.Table:
        """A table pen wrote beside the catalog (fits/, sweeps/), or one line naming the file and what it is
        (``columns``: read only these)."""
        path = self.db_path.parent / relative
        try:
            return pq.read_table(path, filters=filters, columns=columns)
        except FileNotFoundError:
            raise StoreError(f"{path}: the {what} is missing from the workspace (was it copied without its "
                             f"{Path(relative).parts[0]}/ folder?); restore the file") from None
        except (OSError, pa.ArrowException) as exc:
            raise StoreError(f"{path}: cannot read the {what}: {str(exc).splitlines()[0]}") from None

    # ------------------------------------------------------------------ look-ups
    def resolve(self, ref: str) -> str:
        """A run id, a run folder under runs/, or an ingested source folder → run id."""
        with self.connect() as con:
            for candidate in dict.fromkeys((ref, safe_id(ref))):  # an id as it was asked for, or as stored
                if con.execute("SELECT 1 FROM runs WHERE run_id = ?", [candidate]).fetchone():
                    return candidate
            path = Path(ref)
            if path.exists():
                resolved = path.resolve()
                if resolved.parent == self.runs_dir.resolve():
                    name = resolved.name
                    if con.execute("SELECT 1 FROM runs WHERE run_id = ?", [name]).fetchone():
                        return name
                row = con.execute("SELECT run_id FROM runs WHERE source = ?", [str(resolved)]).fetchone()
                if row:
                    return row[0]
        raise StoreError(f"no run '{ref}' in {self.db_path} (give a run id from `pen runs`, or a folder under "
                         f"{self.runs_dir})")

    def run_parameters(self, run_id: str) -> dict[str, dict]:
        """The three parameter mappings stored with a run, by kind."""
        with self.connect() as con:
            rows = con.execute("SELECT kind, parameters FROM run_parameters WHERE run_id = ?", [run_id]).fetchall()
        if not rows:
            raise StoreError(f"no run '{run_id}' in {self.db_path}")
        return {kind: json.loads(text) for kind, text in rows}

    def run_row(self, run_id: str) -> dict:
        """The catalog row of a run."""
        with self.connect() as con:
            cur = con.execute("SELECT * FROM runs WHERE run_id = ?", [run_id])
            row = cur.fetchone()
            if row is None:
                raise StoreError(f"no run '{run_id}' in {self.db_path}")
            return dict(zip([d[0] for d in cur.description], row))

    def list_runs(self, *, material: str | None = None, penetrator: str | None = None,
                  thickness_mm: float | None = None, springs: int | None = None, tag: str | None = None,
                  since: dt.date | None = None, until: dt.date | None = None) -> list[dict]:
        """Runs matching every given filter, by date then id."""
        conditions = (("material = ?", material), ("penetrator = ?", penetrator), ("spring_count = ?", springs),
                      ("abs(blade_thickness_mm - ?) < 1e-9", thickness_mm), ("list_contains(tags, ?)", tag),
                      ("run_date >= ?", since), ("run_date <= ?", until))
        where = [condition for condition, value in conditions if value is not None]
        args = [value for _, value in conditions if value is not None]
        sql = ("SELECT r.run_id, r.run_date, r.material, r.penetrator, r.blade_thickness_mm, r.spring_count, "
               "r.sampling_rate_hz, r.duration_s, r.tags, "
               "(SELECT stage FROM stages s WHERE s.run_id = r.run_id ORDER BY stage_no DESC LIMIT 1) AS latest_stage "
               "FROM runs r")
        if where:
            sql += " WHERE " + " AND ".join(where)
        sql += " ORDER BY r.run_date NULLS LAST, r.run_id"
        with self.connect() as con:
            cur = con.execute(sql, args)
            names = [d[0] for d in cur.description]
            return [dict(zip(names, row)) for row in cur.fetchall()]

    def query(self, sql: str) -> tuple[list[str], list[tuple]]:
        """Run SQL against the catalog that can read it and nothing else.

        The connection is read-only and has no external access, locked: no COPY to a file, no ATTACH of
        another database, no file reads (stage Parquet files included), no extensions.
        """
        if not sql.strip(" \t\r\n;"):
            raise StoreError(f"query {sql!r} is empty; give a statement, e.g. \"SELECT run_id, material FROM runs\"")
        con = self._open(write=False, config={"enable_external_access": False, "lock_configuration": True})
        try:
            try:
                cur = con.execute(sql)
            except duckdb.Error as exc:
                first = str(exc).splitlines()[0]
                if "disabled by configuration" in first or "read-only" in first or "attached in read-only" in first:
                    first += " (pen runs query reads the catalog only: it writes nothing and opens no file)"
                raise StoreError(f"query failed: {first}") from None
            if cur is None or cur.description is None:
                return [], []
            return [d[0] for d in cur.description], cur.fetchall()
        finally:
            con.close()

    # ------------------------------------------------------------------ fitted materials
    def add_material_version(self, material: str, fit: Mapping[str, Any], material_file: Mapping[str, Any],
                             source_runs: Sequence[str], model_data: pa.Table | Mapping[str, Any] | None, *,
                             command: str) -> int:
        """Record a fit as the next version of ``material``; its model-vs-data table (Arrow, or arrays by
        column name) goes to fits/ (atomic)."""
        model_data = None if model_data is None else _as_table(model_data)
        with self.connect(write=True) as con:
            last = con.execute("SELECT max(version) FROM materials WHERE material = ?", [material]).fetchone()[0]
            version = (last or 0) + 1
            rel = None
            final = tmp = None
            if model_data is not None:
                folder = self.db_path.parent / "fits"
                folder.mkdir(parents=True, exist_ok=True)
                final = folder / f"{_ID_SAFE.sub('-', material)}-v{version}.parquet"
                tmp = folder / f".{final.name}.{os.getpid()}.tmp"
                rel = str(final.relative_to(self.db_path.parent))
            with _atomically(con, tmp, final):
                if model_data is not None:
                    meta = {b"pen:material": material.encode(), b"pen:version": str(version).encode(),
                            b"pen:fit": json.dumps(fit, default=str).encode(), b"pen:command": command.encode(),
                            b"pen:source_runs": json.dumps(list(source_runs)).encode(),
                            b"pen:material_file": json.dumps(material_file, default=str).encode()}
                    write_parquet(model_data.replace_schema_metadata(meta), tmp)
                _insert_material_row(con, material, version, json.loads(json.dumps(fit, default=str)),
                                     list(source_runs), material_file, rel, command)
        return version

    def material_versions(self, material: str | None = None) -> list[dict]:
        """Fitted material versions (newest last)."""
        sql = "SELECT * FROM materials"
        args: list = []
        if material is not None:
            sql += " WHERE material = ?"
            args.append(material)
        with self.connect() as con:
            try:
                cur = con.execute(sql + " ORDER BY material, version", args)
            except duckdb.CatalogException:  # a catalog from before migration 2
                return []
            names = [d[0] for d in cur.description]
            return [dict(zip(names, row)) for row in cur.fetchall()]

    # ------------------------------------------------------------------ sweeps
    def sweep_path(self) -> Path:
        """A fresh Parquet path under sweeps/ for the next sweep (the file is written by the caller)."""
        folder = self.db_path.parent / "sweeps"
        folder.mkdir(parents=True, exist_ok=True)
        return folder / f".pending-{os.getpid()}-{time.time_ns()}.parquet"

    def add_sweep(self, pending: Path, *, penetrator: str, material: str, energizing: str, variables: Mapping,
                  n_designs: int, command: str) -> tuple[int, Path]:
        """Index a finished sweep file: rename it to sweeps/sweep-<id>.parquet and add its row (atomic)."""
        with self.connect(write=True) as con:
            last = con.execute("SELECT max(sweep_id) FROM sweeps").fetchone()[0]
            sweep_id = (last or 0) + 1
            final = pending.with_name(f"sweep-{sweep_id}.parquet")
            with _atomically(con, pending, final):
                con.execute("INSERT INTO sweeps VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)", [
                    sweep_id, _now(), penetrator, material, energizing, json.dumps(variables), n_designs,
                    str(final.relative_to(self.db_path.parent)), command, __version__])
        return sweep_id, final

    def sweep_row(self, sweep_id: int) -> dict | None:
        """The catalogue row of one sweep (None if there is no such sweep)."""
        with self.connect() as con:
            cursor = con.execute("SELECT * FROM sweeps WHERE sweep_id = ?", [int(sweep_id)])
            row = cursor.fetchone()
            return None if row is None else dict(zip([c[0] for c in cursor.description], row))

    def sweep_ids(self) -> list[int]:
        """Ids of the indexed sweeps (none on a catalog from before migration 3)."""
        with self.connect() as con:
            try:
                return [r[0] for r in con.execute("SELECT sweep_id FROM sweeps ORDER BY sweep_id").fetchall()]
            except duckdb.CatalogException:
                return []

    def compact(self) -> None:
        """Rewrite the catalog into a fresh file, dropping free blocks (atomic)."""
        tmp = self.db_path.with_name(f".{self.db_path.name}.compact-{os.getpid()}")
        with self.connect(write=True):
            pass  # migrate first
        error = None
        try:
            con = duckdb.connect(str(tmp))
            try:
                target = con.execute("SELECT current_database()").fetchone()[0]
                con.execute(f"ATTACH '{self.db_path}' AS source (READ_ONLY)")
                con.execute(f'COPY FROM DATABASE source TO "{target}"')
            finally:
                con.close()
            os.replace(tmp, self.db_path)
        except duckdb.Error as exc:
            error = exc
        finally:
            for path in (tmp, tmp.with_name(tmp.name + ".wal")):
                with contextlib.suppress(FileNotFoundError):
                    path.unlink()
        if error is not None:
            raise StoreError(f"{self.db_path}: compaction failed: {str(error).splitlines()[0]}")

    def run_ids(self) -> list[str]:
        """Every run id, sorted."""
        with self.connect() as con:
            return [r[0] for r in con.execute("SELECT run_id FROM runs ORDER BY run_id").fetchall()]


@dataclass(frozen=True)
class Removal:
    """What ``pen runs rm`` took out: a run, or a stage and what was made from it."""

    run_id: str
    stages: tuple[str, ...]
    """``stage_no:stage`` of each stage removed."""
    whole_run: bool
    quarantine: Path | None
    """Where the files went (None: deleted with --purge, or none were there)."""


def _lineage(records: Sequence[StageRecord], stage_no: int) -> list[StageRecord]:
    """Stage ``stage_no`` and every stage made from it, directly or through others, in stage order."""
    chosen = {stage_no}
    for record in records:
        if record.parent_no in chosen:
            chosen.add(record.stage_no)
    return [r for r in records if r.stage_no in chosen]


def _same_parameters(a: Any, b: Any, rtol: float = 1e-9) -> bool:
    """Stage parameters equal up to round-off in the derived numbers they carry (events, offsets): another
    numpy may put the last bit of a contact speed elsewhere; that is not another stage."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same_parameters(a[k], b[k], rtol) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same_parameters(x, y, rtol) for x, y in zip(a, b))
    numbers = all(isinstance(q, (int, float)) and not isinstance(q, bool) for q in (a, b))
    if numbers and (isinstance(a, float) or isinstance(b, float)):
        return abs(a - b) <= rtol * max(abs(a), abs(b)) or a == b
    return a == b


def _insert_stage_row(con, run_id: str, stage_no: int, stage: str, parent_no: int | None, relative: str,
                      digest: str, command: str, parameters_json: str, pen_version: str, created: dt.datetime) -> None:
    con.execute("INSERT INTO stages VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)", [
        run_id, stage_no, stage, parent_no, relative, digest, command, parameters_json, pen_version, created])


def _insert_material_row(con, material: str, version: int, fit: Mapping[str, Any], source_runs: list,
                         material_file: Mapping[str, Any], relative: str | None, command: str) -> None:
    con.execute("INSERT INTO materials VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)", [
        material, version, _now(), fit["mode"], list(fit["terms"]), json.dumps(fit["coefficients"]),
        json.dumps(fit["stderr"]), json.dumps(fit, default=str), list(source_runs), json.dumps(fit["ranges"]),
        json.dumps(material_file, default=str), relative, command, __version__])


def write_parquet(table: pa.Table, path: Path) -> None:
    """Parquet as pen writes every stage: zstd, byte-stream-split floats (27 % smaller on noisy channels)."""
    floats = [f.name for f in table.schema if pa.types.is_floating(f.type)]
    pq.write_table(table, path, compression="zstd", use_byte_stream_split=floats or False,
                   use_dictionary=[f.name for f in table.schema if f.name not in floats] or False)


def raw_columns_of(table: pa.Table) -> dict:
    """The CONTRACT §3 columns of a raw-stage table as float64 numpy arrays."""
    return {name: table.column(name).to_numpy() for name in RAW_COLUMNS}


__all__: Sequence[str] = ("AddedRun", "Removal", "StageRecord", "Workspace", "RAW_STAGE", "raw_columns_of")
