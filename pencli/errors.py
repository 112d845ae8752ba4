"""Errors a user can act on.

Every error pen raises for bad input is a :class:`PenError`.  Each subclass
also inherits the builtin exception a Python caller would expect, so library
users can catch ``ValueError`` or ``OSError`` as usual.  The CLI turns any
``PenError`` into one red line on stderr and exit code 1, in one place
(:func:`pencli.cli.main`).  Messages say what was received, what is valid and,
where it helps, what to do.
"""

from __future__ import annotations

import errno
import re


class PenError(Exception):
    """Base class of every error pen reports to a user as one line."""


class PenNotice(UserWarning):
    """Something pen did on its own that a user should hear about (e.g. a workspace repaired after a crash).

    Issued with :func:`warnings.warn`; the CLI prints each as one ``note:`` line on stderr.
    """


class ParameterError(PenError, ValueError):
    """A parameter file, preset name or ``--set`` override is invalid."""


class ModelError(PenError, ValueError):
    """A model request that cannot be computed (e.g. a missing coefficient)."""


class DataError(PenError, ValueError):
    """A run's data file is malformed (columns, rows, values)."""


class FitError(PenError, RuntimeError):
    """A fit that could not be carried out or did not converge."""


class StoreError(PenError, OSError):
    """The workspace (DuckDB catalog or run folders) cannot be read or written."""


class OutputError(PenError, ValueError):
    """A path a command was told to write is refused: it would land on the workspace, or cannot be written."""


class RigError(PenError, RuntimeError):
    """The rig driver refused or failed (arming, firing, streaming)."""


_OS_ADVICE = {
    errno.ENOSPC: "no space left on the device; free some, or write elsewhere",
    errno.EDQUOT: "disk quota exceeded; free some space, or write elsewhere",
    errno.EROFS: "the file system is read-only; write elsewhere",
    errno.EACCES: "permission denied; fix the permissions, or write elsewhere",
    errno.EPERM: "not permitted; fix the permissions, or write elsewhere",
    errno.ENAMETOOLONG: "a file name is too long; choose a shorter name",
}


def describe_os_error(exc: OSError) -> str:
    """An operating-system fault in a user's words: the file where known, what went wrong, what to do."""
    code = exc.errno
    if code is None:  # pyarrow and others put "[Errno 28] ..." in the text only
        found = re.search(r"\[?errno[ =:]*(\d+)", str(exc), re.IGNORECASE)
        code = int(found.group(1)) if found else None
    text = str(exc).strip()
    what = _OS_ADVICE.get(code) or exc.strerror or (text.splitlines()[0] if text else type(exc).__name__)
    where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
    return f"{where}{what}"
