"""``pen records``: the field records (soundings, snow profiles, free-fall drops) ingested into a workspace."""

from __future__ import annotations

import datetime as dt
import json
from pathlib import Path
from typing import Optional

import typer
from rich.markup import escape
from rich.table import Table

from pencli.commands.common import DbOption, PenTyper, console, db_path, print_json
from pencli.lazy import lazy

api = lazy("pencli.api")  # loaded when a command runs, not for --help

app = PenTyper()


@app.command("records")
def records(
    kind: Optional[str] = typer.Option(None, "--kind", help="Only records of this kind: cptu, cpt, total_sounding, "
                                                            "smp or free_fall."),
    json_out: bool = typer.Option(False, "--json", help="Print the records' catalog rows as JSON."),
    db: Optional[Path] = DbOption,
) -> None:
    """List the field records of the workspace: id, kind, instrument (geometry, drive), rows, deepest row [m],
    format and source file. `pen ingest` adds them; `pen soundings` and `pen snow` take their ids.

    Example: pen records --kind cptu
    """
    rows = api.list_records(db_path(db), kind=kind)
    if json_out:
        print_json([{k: (v.isoformat() if isinstance(v, (dt.date, dt.datetime)) else
                         json.loads(v) if k == "header" else v) for k, v in r.items()} for r in rows])
        return
    columns = ("record", "kind", "geometry", "drive", "rows", "depth [m]", "format", "source")
    cells = [[r["record_id"], r["kind"], r["geometry"] or "–", r["drive"], str(r["n_rows"]),
              "–" if r["depth_max_m"] is None else f"{r['depth_max_m']:.2f}", r["source_format"],
              Path(r["source"]).name] for r in rows]
    if not console.is_terminal:  # piped: plain tab-separated text, nothing cut
        typer.echo("\t".join(columns))
        for row in cells:
            typer.echo("\t".join(row))
        return
    table = Table(header_style="bold", caption=f"{len(rows)} record(s) in {db_path(db)}")
    for column in columns:
        table.add_column(escape(column), justify="right" if column in ("rows", "depth [m]") else "left",
                         no_wrap=column == "record")
    for row in cells:
        table.add_row(*(escape(c) for c in row))
    console.print(table)
