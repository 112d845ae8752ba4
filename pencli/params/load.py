"""Reading parameter files and bundled presets.

A parameter reference (``--material mpacs_c`` or ``--material my.yaml``) is a
bundled preset name or a file path; :func:`resolve` takes either.  YAML is
read with a loader that rejects duplicate keys, since a repeated key is
almost always a typo that would otherwise be silently ignored.
"""

from __future__ import annotations

import re
from importlib import resources
from pathlib import Path
from typing import Any

import yaml

from pencli.errors import ParameterError
from pencli.params.definitions import KINDS, Kind
from pencli.params.validate import ParameterSet, validate_mapping

PRESET_PACKAGE = "pencli.params.presets"


MAX_YAML_BYTES = 1 << 20
"""Largest parameter or run.yaml file read (1 MiB; a parameter file is a few hundred bytes). [bytes]"""


class _StrictLoader(yaml.SafeLoader):
    """SafeLoader that refuses duplicate mapping keys and aliases, and reads YAML 1.2 numbers.

    Aliases (``*name``) are refused: no parameter file needs them, and nested aliases expand a
    370-byte file into gigabytes (the "billion laughs").  ``1.0e12`` is a number here, as in YAML 1.2
    (YAML 1.1 reads it as a string for want of a sign in the exponent).
    """

    def compose_node(self, parent, index):
        if self.check_event(yaml.events.AliasEvent):
            event = self.peek_event()
            raise yaml.composer.ComposerError(None, None, f"alias *{event.anchor} is not accepted in pen's files "
                                              f"(write the value out)", event.start_mark)
        return super().compose_node(parent, index)


_StrictLoader.yaml_implicit_resolvers = {k: list(v) for k, v in yaml.SafeLoader.yaml_implicit_resolvers.items()}
_StrictLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"), list("-+0123456789"))


def _construct_mapping(loader: _StrictLoader, node: yaml.MappingNode, deep: bool = False) -> dict:
    seen: dict[Any, int] = {}
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f"duplicate key {key!r} (first on line {seen[key] + 1})", key_node.start_mark)
        seen[key] = key_node.start_mark.line
    return loader.construct_mapping(node, deep=deep)


_StrictLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)


def read_text_capped(path: Path, limit: int, what: str) -> str:
    """A UTF-8 text file read whole, refusing one over ``limit`` bytes without reading past the cap (a device
    like /dev/zero reports size 0 and never ends) and naming the first byte that is not UTF-8."""
    try:
        with open(path, "rb") as handle:
            data = handle.read(limit + 1)
    except FileNotFoundError:
        raise ParameterError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise ParameterError(f"{path}: is a folder, not a {what}") from None
    except OSError as exc:
        raise ParameterError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if len(data) > limit:
        raise ParameterError(f"{path}: more than {limit} bytes; a {what} is at most {limit} bytes")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise ParameterError(f"{path}: line {line}: byte 0x{data[exc.start]:02x} is not UTF-8 text; save the "
                             f"{what} as UTF-8") from None


def read_yaml(path: Path) -> Any:
    """Parse a YAML file strictly; errors name the file and line."""
    text = read_text_capped(Path(path), MAX_YAML_BYTES, "YAML file")
    try:
        return yaml.load(text, Loader=_StrictLoader)  # noqa: S506 - strict SafeLoader subclass
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" line {mark.line + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise ParameterError(f"{path}:{where}: not valid YAML: {problem}") from None
    except (ValueError, OverflowError) as exc:  # a value YAML recognises but cannot build (date 2026-13-45)
        raise ParameterError(f"{path}: a value cannot be read: {str(exc).splitlines()[0]} (write dates as "
                             f"YYYY-MM-DD)") from None
    except RecursionError:
        raise ParameterError(f"{path}: nested too deeply to read (lists or mappings inside each other hundreds of "
                             f"levels down); a parameter file is two levels deep") from None


def load_file(path: str | Path, expected_kind: Kind | None = None, *,
              allow_out_of_range: bool = False) -> ParameterSet:
    """Load and validate one parameter file."""
    path = Path(path)
    return validate_mapping(read_yaml(path), str(path), expected_kind=expected_kind,
                            allow_out_of_range=allow_out_of_range)


def _preset_dir(kind: Kind):
    return resources.files(PRESET_PACKAGE).joinpath(kind)


def preset_names(kind: Kind) -> list[str]:
    """Names of the bundled presets of one kind, sorted."""
    folder = _preset_dir(kind)
    return sorted(entry.name[:-5] for entry in folder.iterdir() if entry.name.endswith(".yaml"))


def load_preset(name: str, kind: Kind) -> ParameterSet:
    """Load a bundled preset by name."""
    entry = _preset_dir(kind).joinpath(f"{name}.yaml")
    if not entry.is_file():
        raise ParameterError(
            f"no {kind} preset named '{name}'; bundled {kind} presets: {', '.join(preset_names(kind))} "
            f"(or give a file path)")
    with resources.as_file(entry) as path:
        data = read_yaml(Path(path))
    return validate_mapping(data, f"preset:{kind}/{name}", expected_kind=kind)


def resolve(ref: str | Path, kind: Kind, *, allow_out_of_range: bool = False) -> ParameterSet:
    """A preset name or a file path, loaded and validated as ``kind``."""
    text = str(ref)
    path = Path(text)
    looks_like_path = path.suffix in (".yaml", ".yml") or "/" in text or "\\" in text
    if looks_like_path or (path.exists() and path.is_file()):
        return load_file(path, kind, allow_out_of_range=allow_out_of_range)
    return load_preset(text, kind)


def all_presets() -> list[ParameterSet]:
    """Every bundled preset, by kind then name."""
    return [load_preset(name, kind) for kind in KINDS for name in preset_names(kind)]
