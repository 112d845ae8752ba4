"""Field records (soundings, snow profiles, free-fall drops): the formats pen reads, and one stored form for all.

A field record is what a field instrument writes of one push or drop: a
constant-rate cone sounding (SGF, GEF, AGS4), a SnowMicroPen profile
(``.pnt``) or a free-fall probe's record (BlueDrop ``.bin``).  Each format
is one :class:`FieldFormat` in :data:`FORMATS`: the file suffixes it owns,
its reader, and the pair of functions that turn what the reader returns into
a :class:`FieldRecord` and back.  A new format is one reader module and one
entry here; ``pen ingest``, the workspace and every command that takes a
sounding, profile or drop use the registry, never a format by name.

A :class:`FieldRecord` is the stored form: float64 columns by pen's names
(every channel the file carries), the header and whatever else the file
says (event legends, comments) as JSON, the record's kind and the
instrument's geometry, drive and sensors.  Its :attr:`FieldRecord.digest`
is taken over the data, so the same record read from two copies of a file
is the same record.
"""

from __future__ import annotations

import base64
import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from pencli.errors import DataError


def json_safe(value: Any) -> Any:
    """``value`` as JSON keeps it: non-finite floats as None (JSON has no NaN), numpy scalars as Python's, tuples
    as lists, bytes as text."""
    if isinstance(value, dict):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    if isinstance(value, (np.floating, np.integer)):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, bytes):
        return value.decode("latin-1")
    return value


@dataclass(frozen=True)
class Instrument:
    """What kind of instrument made a record: its geometry, how it was driven, what it sensed (pen's words; None
    where the format does not say)."""

    geometry: str | None
    drive: str
    sensors: str
    chain: str | None = None
    """The sensor chain (:data:`pencli.sensors.CHAINS`) fit and diagnosis read it through (None: none of pen's)."""


KINDS: dict[str, Instrument] = {
    "cptu": Instrument("cone", "constant_rate", "tip, sleeve, pore pressure", "cone_tip"),
    "cpt": Instrument("cone", "constant_rate", "tip, sleeve", "cone_tip"),
    "total_sounding": Instrument("drill_bit", "constant_rate", "push force, rotation, flushing", "rod_force"),
    "smp": Instrument("cone", "constant_rate", "tip force", "tip_force"),
    "free_fall": Instrument("cone", "free_fall", "accelerometers, pore pressure, tilt", "accelerometers"),
}
"""Kinds of field record pen knows → the instrument.  A sounding of a method pen does not know keeps its kind
(``sgf_method_<code>``) with no geometry."""


def instrument_of(kind: str) -> Instrument:
    """The instrument of a record kind (a kind pen does not know: a constant-rate push of unknown geometry)."""
    return KINDS.get(kind, Instrument(None, "constant_rate", "as the file says"))


@dataclass(frozen=True)
class FieldRecord:
    """One field record in pen's stored form."""

    format: str
    """The file format it was read from (a key of :data:`FORMATS`)."""
    kind: str
    """``cptu``, ``cpt``, ``total_sounding``, ``smp``, ``free_fall`` (:data:`KINDS`), or a kind pen does not
    know."""
    name: str
    """The record's name in its file (a sounding's test id, a profile's file name)."""
    columns: dict[str, np.ndarray]
    """Every channel, float64, one value per row, by pen's names (units in the name's suffix)."""
    header: dict[str, Any]
    """The file's header fields (JSON values)."""
    extras: dict[str, Any] = field(default_factory=dict)
    """Whatever else the file says (event legends, row events and comments, the raw header bytes), JSON values."""
    source: str = ""

    @property
    def instrument(self) -> Instrument:
        return instrument_of(self.kind)

    @property
    def digest(self) -> str:
        """SHA-256 over the format, kind, name, header, extras and columns (names and float64 bytes)."""
        h = hashlib.sha256()
        h.update(json.dumps(json_safe([self.format, self.kind, self.name, self.header, self.extras]),
                            sort_keys=True).encode())
        for name in sorted(self.columns):
            h.update(name.encode())
            h.update(np.ascontiguousarray(self.columns[name], dtype="<f8").tobytes())
        return h.hexdigest()

    @property
    def rows(self) -> int:
        return int(next(iter(self.columns.values())).size) if self.columns else 0

    @property
    def depth_max_m(self) -> float | None:
        """The deepest row (a sounding's depth, a profile's travel), None for a record without depth. [m]"""
        if "depth_m" in self.columns:
            depth = self.columns["depth_m"]
        elif "depth_mm" in self.columns:
            depth = self.columns["depth_mm"] / 1e3
        else:
            return None
        finite = depth[np.isfinite(depth)]
        return float(finite.max()) if finite.size else None

    def to_object(self):
        """The record as its format's reader returns it (a :class:`~pencli.io.sgf.Sounding`, an
        :class:`~pencli.io.pnt.SmpProfile`, a :class:`~pencli.io.bluedrop.DropRecord`)."""
        return FORMATS[self.format].rebuild(self)


# ---------------------------------------------------------------------------- soundings (SGF, GEF, AGS4)
def _sounding_record(fmt: str) -> Callable[[Any], FieldRecord]:
    def to_record(sounding) -> FieldRecord:
        extras = {"method": sounding.method, "events": {str(k): v for k, v in sounding.events.items()},
                  "row_events": [list(e) for e in sounding.row_events],
                  "row_comments": [list(e) for e in sounding.row_comments],
                  "row_text": [list(e) for e in sounding.row_text]}
        return FieldRecord(fmt, sounding.kind, sounding.name,
                           {k: np.asarray(v, dtype=np.float64) for k, v in sounding.columns.items()},
                           dict(sounding.header), extras, sounding.source)

    return to_record


def _sounding_of(record: FieldRecord):
    from pencli.io.sgf import Sounding

    x = record.extras
    return Sounding(name=record.name, method=x["method"], header={k: str(v) for k, v in record.header.items()},
                    columns=dict(record.columns), events={int(k): v for k, v in x.get("events", {}).items()},
                    row_events=tuple(tuple(e) for e in x.get("row_events", ())),
                    row_comments=tuple(tuple(e) for e in x.get("row_comments", ())),
                    row_text=tuple(tuple(e) for e in x.get("row_text", ())), source=record.source)


def _read_sgf(path: Path, options: Mapping[str, Any]) -> list:
    from pencli.io.sgf import read_sgf

    return read_sgf(path)


def _read_gef(path: Path, options: Mapping[str, Any]) -> list:
    from pencli.io.gef import read_gef

    return [read_gef(path)]


def _read_ags(path: Path, options: Mapping[str, Any]) -> list:
    from pencli.io.ags import read_ags

    return read_ags(path)


# ---------------------------------------------------------------------------- SnowMicroPen
def _read_pnt(path: Path, options: Mapping[str, Any]) -> list:
    from pencli.io.pnt import read_pnt

    return [read_pnt(path)]


def _smp_record(profile) -> FieldRecord:
    return FieldRecord("pnt", "smp", profile.name, {"depth_mm": np.asarray(profile.depth_mm, dtype=np.float64),
                                                    "force_n": np.asarray(profile.force_n, dtype=np.float64)},
                       dict(profile.header), {"raw_header": base64.b64encode(profile.raw_header).decode()},
                       profile.source)


def _smp_of(record: FieldRecord):
    from pencli.io.pnt import SmpProfile

    return SmpProfile(name=record.name, header=dict(record.header), depth_mm=record.columns["depth_mm"],
                      force_n=record.columns["force_n"], raw_header=base64.b64decode(record.extras["raw_header"]),
                      source=record.source)


# ---------------------------------------------------------------------------- BlueDrop
def _read_bluedrop(path: Path, options: Mapping[str, Any]) -> list:
    from pencli.io.bluedrop import read_bluedrop, read_calibration

    sheet = options.get("calibration")
    if sheet is None:
        raise DataError(f"{path}: a BlueDrop record's counts mean nothing without the probe's calibration sheet; "
                        f"give it with --calibration FILE (CSV channel,offset,scale,unit)")
    return [read_bluedrop(path, read_calibration(sheet))]


def _drop_record(drop) -> FieldRecord:
    from pencli.io.bluedrop import CHANNELS

    columns = {"time_s": np.asarray(drop.time_s, dtype=np.float64)}
    columns.update({name: np.asarray(values, dtype=np.float64) for name, values in drop.channels.items()})
    columns.update({f"raw_{name}": drop.raw[:, k].astype(np.float64) for k, name in enumerate(CHANNELS)})
    return FieldRecord("bluedrop", "free_fall", drop_name(drop.source), columns, {"units": dict(drop.units)}, {},
                       drop.source)


def drop_name(source: str | Path) -> str:
    """A BlueDrop record's name: its file's, without ``.bin`` (and ``.gz``)."""
    return Path(str(source).removesuffix(".gz")).name.removesuffix(".bin").removesuffix(".BIN") or "drop"


def _drop_of(record: FieldRecord):
    from pencli.io.bluedrop import CHANNELS, DropRecord

    units = record.header["units"]
    raw = np.stack([record.columns[f"raw_{name}"] for name in CHANNELS], axis=1).astype(np.int32)
    return DropRecord(time_s=record.columns["time_s"], channels={k: record.columns[k] for k in units},
                      units=dict(units), raw=raw, source=record.source)


# ---------------------------------------------------------------------------- the registry
@dataclass(frozen=True)
class FieldFormat:
    """A field format: its suffixes (``.gz`` aside), reader (path, options → the reader's objects), and the
    conversions to and from the stored form."""

    name: str
    title: str
    suffixes: tuple[str, ...]
    read: Callable[[Path, Mapping[str, Any]], list]
    record: Callable[[Any], FieldRecord]
    rebuild: Callable[[FieldRecord], Any]
    family: str
    """``sounding``, ``snow`` or ``drop``: which commands take it."""


FORMATS: dict[str, FieldFormat] = {f.name: f for f in (
    FieldFormat("sgf", "SGF sounding", (".cpt", ".std", ".tot", ".sgf"), _read_sgf, _sounding_record("sgf"),
                _sounding_of, "sounding"),
    FieldFormat("gef", "GEF CPT", (".gef",), _read_gef, _sounding_record("gef"), _sounding_of, "sounding"),
    FieldFormat("ags", "AGS4 CPT", (".ags",), _read_ags, _sounding_record("ags"), _sounding_of, "sounding"),
    FieldFormat("pnt", "SnowMicroPen profile", (".pnt",), _read_pnt, _smp_record, _smp_of, "snow"),
    FieldFormat("bluedrop", "BlueDrop free-fall record", (".bin",), _read_bluedrop, _drop_record, _drop_of, "drop"),
)}
"""Every field format pen reads, by name."""

FAMILY_TITLES = {"sounding": "a sounding (SGF, GEF or AGS4)", "snow": "a SnowMicroPen profile (.pnt)",
                 "drop": "a free-fall record (BlueDrop .bin)"}


def suffix_of(path: str | Path) -> str:
    """A file's format suffix, lower case, ``.gz`` aside (``KJTS01-Tot.std.gz`` → ``.std``)."""
    return Path(str(path).removesuffix(".gz").removesuffix(".GZ")).suffix.lower()


def format_of(path: str | Path) -> FieldFormat | None:
    """The field format a file's suffix names, None for any other file."""
    suffix = suffix_of(path)
    return next((f for f in FORMATS.values() if suffix in f.suffixes), None)


def known_suffixes() -> str:
    """The field suffixes, for messages: ``.cpt, .std, ...``."""
    return ", ".join(s for f in FORMATS.values() for s in f.suffixes)


def read_field_file(path: str | Path, options: Mapping[str, Any] | None = None) -> list[FieldRecord]:
    """Every record of a field file, in the file's order.  Raises :class:`DataError` (one line naming the file) for
    a file of no known format or one its reader refuses."""
    path = Path(path)
    fmt = format_of(path)
    if fmt is None:
        raise DataError(f"{path}: not a field record pen reads (suffixes {known_suffixes()}, plain or .gz)")
    records = [fmt.record(obj) for obj in fmt.read(path, options or {})]
    if not records:
        raise DataError(f"{path}: holds no {fmt.title}")
    return records


__all__ = ["FAMILY_TITLES", "FORMATS", "FieldFormat", "FieldRecord", "Instrument", "KINDS", "drop_name", "format_of",
           "instrument_of", "json_safe", "known_suffixes", "read_field_file", "suffix_of"]
