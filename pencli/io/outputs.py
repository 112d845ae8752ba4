"""Where a command may write a file the user named: never onto the workspace, never onto a device.

Every command that writes a user-named path (``--out``, ``--json FILE``, ``--plot``, ``--to``,
``--truth-out``) checks it here *before* it starts work, so a wrong path costs one line and no time:

- the catalog, its write-ahead log and its lock or compaction files are refused (they are pen's, and a
  file written over them loses every run's index);
- anything inside the workspace's data folders (``runs/``, ``fits/``, ``sweeps/``, ``records/``,
  ``quarantine/``) is refused: pen alone writes there, and a stage or record is immutable;
- a folder output (``export --to``, ``report --all --out``) may not be the workspace root or a folder
  holding it;
- an existing folder where a file is written, a file where a folder is written, a device or pipe
  (``/dev/full``), an existing DuckDB database (another workspace's catalog), and a folder this process
  cannot create a file in are refused.

The write itself then goes to a temporary file beside the target and is renamed into place
(:mod:`pencli.io.atomic`), so a refused or failed write leaves the target as it was.
"""

from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from pathlib import Path

from pencli.errors import OutputError, describe_os_error

DATA_FOLDERS = ("runs", "fits", "sweeps", "records", "quarantine")
"""The workspace's folders beside the catalog, which pen alone writes."""

_DUCKDB_MAGIC = b"DUCK"
"""DuckDB database files carry this at byte 8."""


def nearest_existing(path: Path) -> Path:
    """``path`` or its nearest parent that exists (where a file written under ``path`` would land)."""
    for candidate in (path, *path.parents):
        if candidate.exists():
            return candidate
    return Path(path.anchor or ".")


def _is_duckdb(path: Path) -> bool:
    try:
        with open(path, "rb") as handle:
            handle.seek(8)
            return handle.read(4) == _DUCKDB_MAGIC
    except OSError:
        return False


def check_output(target: str | Path, db: str | Path | None, option: str, *, folder: bool = False) -> Path:
    """Refuse (one line, :class:`~pencli.errors.OutputError`) a path that would harm the workspace whose
    catalog is ``db`` or that cannot be written; return the path as given.

    ``folder``: the command writes a folder there (else a file).  Nothing is written, except a probe file
    that is created and removed at once to learn whether the folder takes new files.
    """
    text = str(target)
    if not text.strip():
        raise OutputError(f"{option}: an empty path; name the {'folder' if folder else 'file'} to write")
    given = Path(target).expanduser()
    resolved = given.resolve()
    what = "folder" if folder else "file"
    if db is not None:
        catalog = Path(db).expanduser().resolve()
        root = catalog.parent
        if resolved.parent == root and (resolved.name == catalog.name or resolved.name.startswith(catalog.name + ".")
                                        or resolved.name.startswith("." + catalog.name + ".")):
            part = "the workspace catalog" if resolved == catalog else "a file of the workspace catalog (its log, lock or copy)"
            raise OutputError(f"{option} {text}: is {part}, which pen alone writes; name another {what}")
        for name in DATA_FOLDERS:
            inside = root / name
            if resolved == inside or inside in resolved.parents:
                raise OutputError(f"{option} {text}: inside the workspace's {name}/ folder, which pen alone writes; "
                                  f"name a {what} outside it")
        if folder and (resolved == root or resolved in root.parents):
            raise OutputError(f"{option} {text}: holds the workspace ({catalog}); name a folder of its own")
    if given.exists() or given.is_symlink():
        try:
            mode = os.stat(given).st_mode
        except OSError as exc:
            raise OutputError(f"{option} {text}: cannot be written: {exc.strerror or exc}") from None
        if folder:
            if not stat.S_ISDIR(mode):
                kind = "a file" if stat.S_ISREG(mode) else "a device, pipe or socket"
                raise OutputError(f"{option} {text}: is {kind}, not a folder; name a folder")
        elif stat.S_ISDIR(mode):
            raise OutputError(f"{option} {text}: is a folder; name a file in it")
        elif not stat.S_ISREG(mode):
            raise OutputError(f"{option} {text}: is not a regular file (a device, pipe or socket); name a file")
        elif _is_duckdb(given):
            raise OutputError(f"{option} {text}: is a DuckDB database (a workspace catalog?); pen does not write "
                              f"over one; name another file")
    parent = nearest_existing(given if folder and given.is_dir() else given.parent)
    if not parent.is_dir():
        raise OutputError(f"{option} {text}: {parent} is a file, not a folder")
    try:
        fd, probe = tempfile.mkstemp(prefix=".pen-probe-", dir=parent)
    except OSError as exc:
        raise OutputError(f"{option} {text}: cannot write in {parent}: {describe_os_error(exc)}") from None
    os.close(fd)
    with contextlib.suppress(OSError):
        os.unlink(probe)
    return Path(target)


__all__ = ["DATA_FOLDERS", "check_output", "nearest_existing"]
