"""Reader of a soil-units file: per site, the units of a set of constant-rate soundings and how each sounding's depths
map onto the reference sounding's (the format is in docs/formats/field-records.md)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from pencli.errors import DataError


@dataclass(frozen=True)
class SiteSounding:
    """One sounding of a site: its file (resolved against the units file's folder), the rate it was set to, its
    depth warp (pairs [depth here, depth at the reference], m) and the ranges left out (at the reference's depths, m)."""

    name: str
    path: Path
    nominal_rate_mm_s: float | None
    warp_m: tuple[tuple[float, float], ...]
    drop_m: tuple[tuple[float, float], ...]


@dataclass(frozen=True)
class Site:
    """A site's soil units (``[top, bottom]`` at the reference sounding's depths, m) and its soundings.  ``units_m``
    is None where the file says ``"units_m": "layers"``: the units are the layers found on the reference
    sounding (:func:`pencli.api.site_unit_means`)."""

    name: str
    reference_sounding: str
    reference_rate_mm_s: float
    units_m: tuple[tuple[float, float], ...] | None
    soundings: tuple[SiteSounding, ...]


LAYERS = "layers"
"""``"units_m": "layers"``: the units are the layers found on the reference sounding."""


def _pairs(source: str, where: str, value, *, ordered: bool) -> tuple[tuple[float, float], ...]:
    if not isinstance(value, list) or not all(isinstance(v, list) and len(v) == 2 for v in value):
        raise DataError(f"{source}: {where}: expected a list of [number, number] pairs")
    try:
        pairs = tuple((float(a), float(b)) for a, b in value)
    except (TypeError, ValueError):
        raise DataError(f"{source}: {where}: expected numbers in each [number, number] pair") from None
    if ordered and any(a >= b for a, b in pairs):
        bad = next(p for p in pairs if p[0] >= p[1])
        raise DataError(f"{source}: {where}: range [{bad[0]:g}, {bad[1]:g}] does not go down (top < bottom expected)")
    return pairs


def read_units_file(path: str | Path) -> dict[str, Site]:
    """The sites of a units file, by name; :class:`DataError` naming the file and the key for anything missing or
    malformed."""
    path = Path(path)
    source = str(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise DataError(f"{source}: cannot read: {exc.strerror or exc}") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise DataError(f"{source}: not a JSON file ({exc})") from None
    sites = data.get("sites") if isinstance(data, dict) else None
    if not isinstance(sites, dict) or not sites:
        raise DataError(f"{source}: expected a 'sites' mapping of site names to their units and soundings")
    out = {}
    for name, site in sites.items():
        where = f"sites.{name}"
        if not isinstance(site, dict):
            raise DataError(f"{source}: {where}: expected a mapping")
        for key in ("reference_sounding", "units_m", "soundings"):
            if key not in site:
                raise DataError(f"{source}: {where}.{key}: missing")
        soundings = []
        if not isinstance(site["soundings"], dict) or not site["soundings"]:
            raise DataError(f"{source}: {where}.soundings: expected a mapping of sounding names")
        for sname, s in site["soundings"].items():
            at = f"{where}.soundings.{sname}"
            if not isinstance(s, dict) or "file" not in s:
                raise DataError(f"{source}: {at}.file: missing")
            rate = s.get("nominal_rate_mm_s")
            soundings.append(SiteSounding(sname, path.parent / str(s["file"]),
                                          None if rate is None else float(rate),
                                          _pairs(source, f"{at}.warp_m", s.get("warp_m", []), ordered=False),
                                          _pairs(source, f"{at}.drop_m", s.get("drop_m", []), ordered=True)))
        try:
            reference_rate = float(site.get("reference_rate_mm_s", 20.0))
        except (TypeError, ValueError):
            raise DataError(f"{source}: {where}.reference_rate_mm_s: expected a number [mm/s]") from None
        if not reference_rate > 0:
            raise DataError(f"{source}: {where}.reference_rate_mm_s: {reference_rate:g}; expected a rate above 0 [mm/s]")
        units = (None if site["units_m"] == LAYERS else
                 _pairs(source, f"{where}.units_m", site["units_m"], ordered=True))
        if units is None and str(site["reference_sounding"]) not in {s.name for s in soundings}:
            raise DataError(f"{source}: {where}.reference_sounding: {site['reference_sounding']!r} is not one of the "
                            f"site's soundings; its layers are the units")
        out[name] = Site(name, str(site["reference_sounding"]), reference_rate, units, tuple(soundings))
    return out
