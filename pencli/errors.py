"""Errors a user can act on.

Every error pen raises for bad input is a :class:`PenError`.  Each subclass
also inherits the builtin exception a Python caller would expect, so library
users can catch ``ValueError`` or ``OSError`` as usual.  The CLI turns any
``PenError`` into one red line on stderr and exit code 1, in one place
(:func:`pencli.cli.main`).  Messages say what was received, what is valid and,
where it helps, what to do.
"""

from __future__ import annotations


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
