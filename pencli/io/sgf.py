"""Reader of the Swedish/Norwegian SGF sounding format (CPTu, total soundings), field records of constant-rate pushes.

An SGF file holds one or more soundings.  Each begins with a line ``$``,
then header lines of comma-separated ``KEY=value`` fields (``HK`` the
sounding's name, ``HM`` its method: 07 a piezocone, 24 a total sounding;
``HD`` the date), then a line ``#`` and one data row per depth step, again
``KEY=value`` fields (``D`` the depth, ``QC`` the cone resistance, ...),
where a field ``%<digits>`` is the logger's clock in milliseconds.  A line
``#$`` ends the rows; ``<code>:<text>`` lines after it name the event codes
the rows' ``F`` field carries.  Files from Norwegian loggers are written in
cp1252 (``Ø`` in a name); a file that is valid UTF-8 is read as UTF-8.  A
file whose name ends in ``.gz`` is read through gzip.

Every field a row carries is kept: the codes in :data:`CHANNELS` under
pen's name and unit, any other under ``sgf_<code>`` as written.  A value
left blank is NaN.  Errors name the file, the line and the field.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pencli.errors import DataError

CHANNELS: dict[str, tuple[str, str, str]] = {
    "D": ("depth_m", "m", "depth below the ground surface"),
    "QC": ("qc_mpa", "MPa", "cone (tip) resistance, uncorrected"),
    "FS": ("fs_kpa", "kPa", "sleeve friction"),
    "U": ("u2_kpa", "kPa", "pore pressure behind the cone (u₂)"),
    "B": ("rate_mm_s", "mm/s", "penetration rate as the logger reads it"),
    "A": ("push_force_kn", "kN", "push force on the rods (total sounding)"),
    "R": ("rotation_rpm", "rpm", "rod rotation (total sounding)"),
    "I": ("flushing_pressure_mpa", "MPa", "flushing pressure (total sounding)"),
    "AZ": ("hammer_pressure_mpa", "MPa", "hammering pressure (total sounding)"),
    "TA": ("tilt_deg", "°", "inclination of the cone"),
    "O": ("temperature_c", "°C", "temperature in the cone"),
}
"""SGF data codes pen names: code → (column name, unit, meaning).  Codes not here are kept as ``sgf_<code>``,
except ``F`` and ``K``, a row's event and comment codes (one or several of each), kept in
:attr:`Sounding.row_events` and :attr:`Sounding.row_comments`, and ``AK``, the logger's clock as a time of day
(``hh:mm:ss.sss``), kept as ``clock_ms`` (milliseconds since midnight, a day added where it wraps) where a row
has no ``%`` clock."""

CODES_PER_ROW = {"F": "an event", "K": "a comment"}
"""Data codes a row may give several times: code numbers, not values."""

METHODS: dict[str, str] = {"07": "cptu", "24": "total_sounding"}
"""The header's ``HM`` method codes pen knows: code → kind of sounding."""


@dataclass(frozen=True)
class Sounding:
    """One sounding of an SGF file: its header fields as written, its columns by pen's names (float64, one value per
    data row; NaN where a row leaves a field blank or out), its event legend, and where it came from."""

    name: str
    method: str
    header: dict[str, str]
    columns: dict[str, np.ndarray]
    events: dict[int, str] = field(default_factory=dict)
    """The file's event legend: code → text (``14`` → "Transmission lost")."""
    row_events: tuple[tuple[int, int], ...] = ()
    """(row, code) of each event a data row carries (rows from 0), in the file's order."""
    row_comments: tuple[tuple[int, int], ...] = ()
    """(row, code) of each comment code (``K``) a data row carries, in the file's order."""
    row_text: tuple[tuple[int, str, str], ...] = ()
    """(row, code, text) of each field of a data row whose value is text (a remark such as ``T=...``) and whose
    code is not one of :data:`CHANNELS`."""
    source: str = ""

    @property
    def kind(self) -> str:
        """``cptu``, ``total_sounding``, or ``sgf_method_<HM>`` for a method pen does not know; a GEF or AGS4
        file's (method ``gef``, ``ags``) ``cptu`` where it has u₂, else ``cpt``."""
        if self.method in ("gef", "ags"):
            return "cptu" if "u2_kpa" in self.columns else "cpt"
        return METHODS.get(self.method, f"sgf_method_{self.method}")

    @property
    def time_s(self) -> np.ndarray | None:
        """Time since the first row from the logger's clock (the ``%`` field, or the ``AK`` time of day), or None
        where the rows carry none. [s]"""
        clock = self.columns.get("clock_ms")
        if clock is None or not np.isfinite(clock).any():
            return None
        return (clock - clock[np.isfinite(clock)][0]) / 1e3

    def header_number(self, key: str) -> float | None:
        """A header field as a number (``MA``, ``MC``, ...), None where it is absent, blank or not a number."""
        text = self.header.get(key, "").strip()
        if text.count(",") == 1 and "." not in text:
            text = text.replace(",", ".")  # a decimal comma
        try:
            value = float(text)
        except ValueError:
            return None
        return value if math.isfinite(value) else None


def _decode(path: Path, raw: bytes) -> str:
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        return raw.decode("cp1252", errors="replace")


def _fields(path: Path, number: int, line: str, header: bool = False) -> list[tuple[str, str]]:
    """A line's comma-separated fields as (key, value); the logger clock ``%<digits>`` as ("%", digits).  In a
    header a piece without ``=`` continues the previous value (a decimal comma: ``MA=0,864``)."""
    out: list[tuple[str, str]] = []
    for token in line.split(","):
        token = token.strip()
        if not token:
            continue
        if token.startswith("%"):
            out.append(("%", token[1:].strip()))
            continue
        key, eq, value = token.partition("=")
        if not eq and header and out:
            out[-1] = (out[-1][0], f"{out[-1][1]},{token}")
            continue
        if not eq or not key.strip():
            raise DataError(f"{path}: line {number}: field {token!r} is not KEY=value")
        out.append((key.strip().upper(), value.strip()))
    return out


def read_sgf(path: str | Path) -> list[Sounding]:
    """The soundings of an SGF file, in the file's order (at least one).  Raises :class:`DataError` naming the file,
    the line and the field for anything it cannot read: no ``$`` header, no rows, a value that is not a number,
    a row without a depth, depths that go back up."""
    path = Path(path)
    try:
        raw = path.read_bytes()
        if path.suffix.lower() == ".gz":
            import gzip

            raw = gzip.decompress(raw)
    except OSError as exc:
        raise DataError(f"{path}: cannot read: {getattr(exc, 'strerror', None) or exc}") from None
    except EOFError:
        raise DataError(f"{path}: the gzip stream ends early (a truncated file?)") from None
    lines = _decode(path, raw).splitlines()
    soundings: list[Sounding] = []
    i = 0
    while i < len(lines):
        if not lines[i].strip():
            i += 1
            continue
        if lines[i].strip() != "$":
            raise DataError(f"{path}: line {i + 1}: expected '$' (a sounding's header) and found "
                            f"{lines[i].strip()[:40]!r}; is this an SGF file?")
        start = i + 1
        header: dict[str, str] = {}
        i += 1
        while i < len(lines) and lines[i].strip() not in ("#", "$"):
            for key, value in _fields(path, i + 1, lines[i], header=True):
                header[key] = value
            i += 1
        if i >= len(lines) or lines[i].strip() != "#":
            raise DataError(f"{path}: line {start}: a header with no '#' line and no data rows after it")
        i += 1
        rows: list[tuple[int, list[tuple[str, str]]]] = []
        while i < len(lines) and lines[i].strip() not in ("#$", "$"):
            if lines[i].strip():
                rows.append((i + 1, _fields(path, i + 1, lines[i])))
            i += 1
        events: dict[int, str] = {}
        if i < len(lines) and lines[i].strip() == "#$":
            i += 1
            while i < len(lines) and lines[i].strip() != "$":
                code, colon, text = lines[i].partition(":")
                if colon and code.strip().isdigit():
                    events[int(code)] = text.strip()
                elif lines[i].strip():
                    raise DataError(f"{path}: line {i + 1}: expected '<code>:<text>' in the event legend, found "
                                    f"{lines[i].strip()[:40]!r}")
                i += 1
        soundings.append(_sounding(path, start, header, rows, events))
    if not soundings:
        raise DataError(f"{path}: empty file; expected an SGF sounding ('$', header lines, '#', data rows)")
    return soundings


def _clock_ms(path: Path, number: int, text: str) -> float:
    """The logger's clock field in milliseconds: a count of milliseconds, or a time stamp ``YYYYMMDDhhmmssSSS``
    (17 digits; milliseconds since 1970, UTC as far as the file says)."""
    if not text.isdigit():
        raise DataError(f"{path}: line {number}: field % is {text!r}; expected the logger's clock (digits)")
    if len(text) == 17 and text[:2] in ("19", "20"):
        from datetime import datetime, timezone

        try:
            stamp = datetime.strptime(text[:14], "%Y%m%d%H%M%S").replace(tzinfo=timezone.utc)
        except ValueError:
            raise DataError(f"{path}: line {number}: field % is {text!r}; a 17-digit clock is read as "
                            "YYYYMMDDhhmmssSSS and this is not a date") from None
        return stamp.timestamp() * 1e3 + int(text[14:])
    return float(text)


def _sounding(path: Path, start: int, header: dict[str, str], rows, events) -> Sounding:
    name = header.get("HK", "").strip()
    if not rows:
        raise DataError(f"{path}: line {start}: sounding {name or '(unnamed)'} has no data rows after its '#' line")
    values: dict[str, np.ndarray] = {}
    row_events: list[tuple[int, int]] = []
    row_comments: list[tuple[int, int]] = []
    time_of_day: list[tuple[int, float]] = []
    row_text: list[tuple[int, str, str]] = []
    for r, (number, fields) in enumerate(rows):
        seen = set()
        for key, text in fields:
            if key in CODES_PER_ROW:
                try:
                    (row_events if key == "F" else row_comments).append((r, int(text)))
                except ValueError:
                    raise DataError(f"{path}: line {number}: field {key} is {text!r}; expected {CODES_PER_ROW[key]} "
                                    "code (a whole number)") from None
                continue
            if key == "AK":
                time_of_day.append((r, _time_of_day_ms(path, number, text)))
                continue
            column = "clock_ms" if key == "%" else CHANNELS[key][0] if key in CHANNELS else f"sgf_{key}"
            if column in seen:
                raise DataError(f"{path}: line {number}: field {key} given twice in one row")
            seen.add(column)
            if text == "":
                number_value = math.nan
            elif key == "%":
                number_value = _clock_ms(path, number, text)
            else:
                try:
                    number_value = float(text)
                except ValueError:
                    if key not in CHANNELS and key != "%":
                        row_text.append((r, key, text))
                        seen.discard(column)
                        continue
                    raise DataError(f"{path}: line {number}: field {'%' if key == '%' else key} is {text!r}; "
                                    "expected a number") from None
            if column not in values:
                values[column] = np.full(len(rows), np.nan)
            values[column][r] = number_value
        if "depth_m" not in seen or not math.isfinite(values["depth_m"][r]):
            raise DataError(f"{path}: line {number}: a data row without a depth (D=...)")
    depth = values["depth_m"]
    back = np.flatnonzero(np.diff(depth) < 0)
    if back.size:
        k = int(back[0]) + 1
        raise DataError(f"{path}: line {rows[k][0]}: depth {depth[k]:g} m after {depth[k - 1]:g} m; "
                        "expected depths that do not go back up")
    if time_of_day and "clock_ms" not in values:
        clock = np.full(len(rows), np.nan)
        for r, ms in time_of_day:
            clock[r] = ms
        finite = np.isfinite(clock)
        wraps = np.concatenate([[0], np.cumsum(np.diff(clock[finite]) < -DAY_MS / 2)])  # past midnight
        clock[finite] += wraps * DAY_MS
        values["clock_ms"] = clock
    method = header.get("HM", "").strip()
    return Sounding(name=name, method=f"{int(method):02d}" if method.isdigit() else method, header=header,
                    columns=values, events=events, row_events=tuple(row_events), row_text=tuple(row_text),
                    row_comments=tuple(row_comments), source=str(path))


DAY_MS = 86_400_000.0
"""Milliseconds in a day: a time-of-day clock that goes back by more than half of one has passed midnight."""


def _time_of_day_ms(path: Path, number: int, text: str) -> float:
    """The ``AK`` clock field ``hh:mm:ss[.sss]`` in milliseconds since midnight."""
    parts = text.strip().split(":")
    try:
        hours, minutes, seconds = (float(v) for v in parts)
        if len(parts) != 3 or not (0 <= hours < 24 and 0 <= minutes < 60 and 0 <= seconds < 61):
            raise ValueError
    except ValueError:
        raise DataError(f"{path}: line {number}: field AK is {text!r}; expected the logger's time of day "
                        "hh:mm:ss.sss") from None
    return 1e3 * (3600.0 * hours + 60.0 * minutes + seconds)
