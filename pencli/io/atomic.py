"""Atomic file writes: write beside the target, then rename over it.

A failure or Ctrl-C midway leaves the target untouched, no temporary file behind, and no folder that the
write created for it.
"""

from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from pathlib import Path
from typing import Callable, Iterator

from pencli.errors import OutputError


def _umask() -> int:
    current = os.umask(0)
    os.umask(current)
    return current


def honour_umask(path: Path, *, folder: bool = False) -> None:
    """Give ``path`` the mode a plain open()/mkdir() would have (tempfile makes 0600 files and 0700 folders)."""
    os.chmod(path, (0o777 if folder else 0o666) & ~_umask())


def make_parents(folder: Path) -> list[Path]:
    """Create ``folder`` and its missing parents; return the folders made, deepest first (to undo)."""
    missing = [p for p in (folder, *folder.parents) if not p.exists()]
    folder.mkdir(parents=True, exist_ok=True)
    return missing


def remove_made(folders: list[Path]) -> None:
    """Remove folders :func:`make_parents` made, deepest first, where they are still empty."""
    for made in folders:
        with contextlib.suppress(OSError):
            made.rmdir()


@contextlib.contextmanager
def atomic_path(target: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``target``; rename it over ``target`` on success."""
    with atomic_group([Path(target)]) as temps:
        yield temps[0]


def write_atomic(target: str | Path, write: Callable[[Path], None]) -> Path:
    """Call ``write(tmp_path)`` and move the result to ``target`` atomically."""
    with atomic_path(target) as tmp:
        write(tmp)
    return Path(target)


@contextlib.contextmanager
def atomic_group(targets: list[Path]) -> Iterator[list[Path]]:
    """Temporary paths for several files that appear together or not at all (a report's HTML and PDF).

    Each is renamed into place only when the body has written them all; a failure leaves every target as it
    was.
    """
    made: list[Path] = []
    for target in targets:
        with contextlib.suppress(FileNotFoundError):
            if not stat.S_ISREG(os.stat(target).st_mode):
                raise OutputError(f"{target}: is not a regular file; name a file")
        made += make_parents(target.parent)
    temps: list[Path] = []
    done = False
    try:
        for target in targets:
            fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
            os.close(fd)
            temps.append(Path(tmp))
        yield temps
        for tmp, target in zip(temps, targets):
            honour_umask(tmp)
            os.replace(tmp, target)
        done = True
    finally:
        for tmp in temps:
            if tmp.exists():
                tmp.unlink()
        if not done:
            remove_made(made)
