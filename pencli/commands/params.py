"""``pen params``: bundled presets, parameter definitions, file validation."""

from __future__ import annotations

import json
from pathlib import Path
from typing import List, Optional

import typer
from rich.markup import escape
from rich.table import Table

from pencli.lazy import lazy
from pencli.commands.common import DbOption, PenTyper, console, db_path, fail, print_json
from pencli.params.definitions import CHOICES, KINDS, PARAMETERS

api = lazy("pencli.api")  # loaded when a command runs, not for --help

app = PenTyper(help="Parameter files and bundled presets (CONTRACT §1).", no_args_is_help=True)


@app.command("list")
def list_presets(
    json_out: bool = typer.Option(False, "--json", help="Print the presets as JSON."),
    db: Optional[Path] = DbOption,
) -> None:
    """List the bundled presets of the three kinds.

    Example: pen params list
    """
    presets = api.presets()
    if json_out:
        print_json([{"kind": p.kind, "name": p.name, "notes": p.notes} for p in presets])
        return
    table = Table(show_header=True, header_style="bold")
    for col in ("kind", "name", "what (pen params show NAME for more)"):
        table.add_column(col)
    for p in presets:
        first = p.notes.split(". ")[0].rstrip(".")
        table.add_row(p.kind, p.name, first)
    console.print(table)


@app.command("show")
def show(
    name: str = typer.Argument(..., help="Preset name (or a YAML file)."),
    kind: Optional[str] = typer.Option(None, "--kind", help="penetrator, material or energizing "
                                                             "(when a name has presets of several kinds)."),
    json_out: bool = typer.Option(False, "--json", help="Print as JSON."),
    db: Optional[Path] = DbOption,
) -> None:
    """Show a preset as a YAML parameter file, with units and meanings.

    Example: pen params show mpacs_c
    """
    if kind is not None and kind not in KINDS:
        raise typer.BadParameter(f"'{kind}' is not one of {', '.join(KINDS)}", param_hint="--kind")
    found = api.show_preset(name, kind)  # type: ignore[arg-type]
    if json_out:
        print_json([p.to_mapping() for p in found])
        return
    import yaml  # here, not at start-up: `pen --help` stays fast

    for p in found:
        console.print(f"[bold]# {p.kind} preset {p.name}[/bold]  [dim]({escape(p.source)})[/dim]")
        typer.echo(yaml.safe_dump(p.to_mapping(), sort_keys=False, allow_unicode=True).rstrip())


@app.command("validate")
def validate(
    files: List[Path] = typer.Argument(..., help="Parameter YAML files to check."),
    allow_out_of_range: bool = typer.Option(False, "--allow-out-of-range",
                                            help="Accept values outside the documented ranges."),
    json_out: bool = typer.Option(False, "--json", help="Print one record per file as JSON."),
    db: Optional[Path] = DbOption,
) -> None:
    """Check parameter files against CONTRACT §1; exit 1 if any is invalid.

    Example: pen params validate penetrator.yaml material.yaml energizing.yaml
    """
    results = api.validate_files(files, allow_out_of_range=allow_out_of_range)
    if json_out:
        print_json([r.__dict__ for r in results])
    else:
        for r in results:
            if r.ok:
                console.print(f"[green]ok[/green]   {escape(r.path)} ({r.kind} '{escape(r.name)}')", highlight=False)
            else:
                console.print(f"[red]FAIL[/red] {escape(r.message)}", highlight=False, soft_wrap=True)
    bad = sum(not r.ok for r in results)
    if bad:
        raise fail(f"{bad} of {len(results)} file(s) invalid")


@app.command("keys")
def keys(
    kind: Optional[str] = typer.Option(None, "--kind", help="Only this kind."),
    json_out: bool = typer.Option(False, "--json", help="Print as JSON."),
    db: Optional[Path] = DbOption,
) -> None:
    """List every parameter key with its unit, documented range and meaning.

    These are the keys of the YAML files, of `--set` and of sweep variables.
    Example: pen params keys --kind material
    """
    rows = [p for p in PARAMETERS if kind is None or p.kind == kind]
    named = [c for c in CHOICES if kind is None or c.kind == kind]
    if json_out:
        print_json([{"key": c.key, "kind": c.kind, "options": list(c.options), "default": c.default,
                     "meaning": c.help, "geometries": list(c.geometries)} for c in named]
                   + [{"key": p.key, "kind": p.kind, "unit": p.unit, "symbol": p.symbol, "meaning": p.meaning,
                       "range": [p.range_min, p.range_max], "hard": p.hard_text, "required": p.required,
                       "default": p.default, "geometries": list(p.geometries)} for p in rows])
        return
    table = Table(show_header=True, header_style="bold")
    for col in ("key", "kind", "unit", "range", "meaning"):
        table.add_column(col)
    for c in named:
        table.add_row(c.key, c.kind + _of(c.geometries), "", " | ".join(c.options), c.help)
    for p in rows:
        table.add_row(p.key, p.kind + _of(p.geometries), p.unit, p.range_text.replace(f" {p.unit}", ""),
                      f"{p.symbol}: {p.meaning}" + ("" if p.required else " (optional)"))
    console.print(table)


def _of(geometries: tuple[str, ...]) -> str:
    """' (cone)' after a kind whose key only some geometries' files hold."""
    return f" ({', '.join(geometries)})" if geometries else ""


@app.command("schema")
def schema(
    out: Optional[Path] = typer.Option(None, "--out", help="Folder to write <kind>.schema.json into."),
    db: Optional[Path] = DbOption,
) -> None:
    """Print or write the JSON Schemas of the three kinds (derived from the definitions).

    Example: pen params schema --out schema/
    """
    from pencli.io.atomic import write_atomic
    from pencli.params.schema import json_schema

    if out is None:
        print_json({kind: json_schema(kind) for kind in KINDS})
        return
    api.check_output(out, db_path(db), "--out", folder=True)
    for kind in KINDS:
        text = json.dumps(json_schema(kind), indent=2, ensure_ascii=False) + "\n"
        target = write_atomic(out / f"{kind}.schema.json", lambda tmp, t=text: tmp.write_text(t, encoding="utf-8"))
        console.print(f"wrote {target}")
