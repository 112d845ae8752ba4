"""What every command shares: the error boundary, ``--db``, output helpers."""

from __future__ import annotations

import contextlib
import functools
import json
import math
import os
import re
import sys
import warnings
from pathlib import Path
from typing import Any, Callable, Iterator

import typer
from rich.console import Console
from rich.markup import escape

from pencli.errors import PenError, PenNotice, describe_os_error

console = Console()
err_console = Console(stderr=True)

DB_HELP = "Workspace catalog (DuckDB file; a runs/ folder sits beside it). Default: $PEN_DB, else ./runs.duckdb."
DbOption = typer.Option(None, "--db", help=DB_HELP, show_default=False)


def db_path(db: Path | None) -> Path:
    """The workspace catalog path: --db, else $PEN_DB, else ./runs.duckdb."""
    if db is not None:
        return db
    env = os.environ.get("PEN_DB")
    return Path(env) if env else Path("runs.duckdb")


def number_pair(text: str | None, separator: str, form: str, option: str) -> tuple[float, float] | None:
    """Parse an option like ``12.5,30`` or ``0.1:2`` into two floats (usage error otherwise)."""
    if text is None:
        return None
    try:
        first, second = (float(v) for v in text.split(separator))
    except ValueError:
        raise typer.BadParameter(f"'{text}' is not {form}", param_hint=option) from None
    return first, second


def usage_check(check: Callable[[Any], Any]) -> Callable[[Any], Any]:
    """An option callback that runs the library's own check of the value; its error is a usage error (exit 2).

    CONTRACT §6: a malformed option (``--set`` without ``=``, an unknown term or unit) is a usage error.
    """
    def callback(value: Any) -> Any:
        if value is None:
            return value
        try:
            check(value)
        except PenError as exc:
            raise typer.BadParameter(str(exc)) from None
        return value

    return callback


def fail(message: str, code: int = 1) -> typer.Exit:
    """Print one red line on stderr; return the Exit to raise."""
    err_console.print(f"[red]error:[/red] {escape(message)}", highlight=False, soft_wrap=True)
    return typer.Exit(code)


_python_showwarning = warnings.showwarning


def _show_notice(message, category, filename, lineno, file=None, line=None) -> None:
    """A :class:`PenNotice` is one yellow ``note:`` line on stderr; other warnings as Python shows them."""
    if issubclass(category, PenNotice):
        err_console.print(f"[yellow]note:[/yellow] {escape(str(message))}", highlight=False, soft_wrap=True)
    else:
        _python_showwarning(message, category, filename, lineno, file, line)


def os_error_line(exc: OSError) -> str:
    """An operating-system fault as one line; pen's writes are atomic, so nothing was half-written."""
    return f"{describe_os_error(exc)} (nothing was half-written)"


def pen_errors(fn: Callable) -> Callable:
    """The one place a :class:`PenError` becomes one red line and exit code 1."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("always", PenNotice)
                warnings.showwarning = _show_notice
                return fn(*args, **kwargs)
        except PenError as exc:
            raise fail(str(exc)) from None
        except OSError as exc:  # the machine's faults (a full disk, a read-only folder): one line, not a traceback
            raise fail(os_error_line(exc)) from None
        except MemoryError:
            raise fail("out of memory; ask for less at once (fewer runs, a smaller --n or --resolution)") from None
        except KeyboardInterrupt:
            raise fail("interrupted; nothing was written", 130) from None

    return wrapper


class PenTyper(typer.Typer):
    """A Typer whose commands all pass through :func:`pen_errors`."""

    def command(self, *args, **kwargs):
        register = super().command(*args, **kwargs)

        def wrap(fn):
            wrapped = pen_errors(fn)
            if wrapped.__doc__:  # plain help re-flows paragraphs: an example line gets a paragraph of its own
                wrapped.__doc__ = re.sub(r"\n([ \t]*)(Examples?:)", r"\n\n\1\2", wrapped.__doc__)
            return register(wrapped)

        return wrap

    def callback(self, *args, **kwargs):
        register = super().callback(*args, **kwargs)
        return lambda fn: register(pen_errors(fn))


def _json_default(value: Any):
    if hasattr(value, "item"):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def _finite(value: Any) -> Any:
    """JSON has no inf/nan: they become null."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def print_json(data: Any) -> None:
    """Write ``data`` as JSON on stdout (plain, no colour, no wrapping)."""
    sys.stdout.write(json.dumps(_finite(data), indent=2, default=_json_default, allow_nan=False) + "\n")


@contextlib.contextmanager
def progress_bar(label: str, *, disable: bool = False) -> Iterator[Callable[[str, int, int], None]]:
    """A transient bar on stderr (nothing when ``disable``, e.g. with ``--json``, or when stderr is not a terminal:
    a log or a pipe gets the result lines only).

    Yields ``update(description, done, total)``, the progress callback every long ``api`` call takes.
    """
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  console=err_console, transient=True, disable=disable or not err_console.is_terminal) as bar:
        task = bar.add_task(label, total=None)
        yield lambda description, done, total: bar.update(task, description=description, completed=done,
                                                          total=total)
