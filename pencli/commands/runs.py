"""``pen ingest``, ``pen runs`` and ``pen export``: runs into and out of a workspace."""

from __future__ import annotations

import datetime as dt
import json
from pathlib import Path
from typing import List, Optional

import typer
from rich.markup import escape
from rich.table import Table

from pencli.lazy import lazy
from pencli.commands.common import (DbOption, PenTyper, console, db_path, err_console, fail, print_json, progress_bar,
                                    usage_check)

api = lazy("pencli.api")  # loaded when a command runs, not for --help

app = PenTyper()
runs_app = PenTyper(help="List, show and query the runs of a workspace.", invoke_without_command=True)


def _unit(quantity: str):
    def check(unit: str) -> float:
        from pencli.io.runfolder import unit_factor  # at parse time, not start-up (pyarrow)

        return unit_factor(quantity, unit)

    return usage_check(check)


@app.command("ingest")
def ingest(
    paths: List[str] = typer.Argument(..., help="Run folders (CONTRACT §3), globs, or parent folders to search."),
    columns: Optional[str] = typer.Option(None, "--columns", metavar="NAME=HEADER,...",
                                          help="Column map for workbooks with other headers, e.g. "
                                               "'time=Time (s),position=Pos,fz=Force Z' (names: time, position, "
                                               "fx, fy, fz, tx, ty, tz)."),
    time_unit: str = typer.Option("s", "--time-unit", callback=_unit("time"), help="Unit of the time column: s or ms."),
    position_unit: str = typer.Option("mm", "--position-unit", callback=_unit("position"), help="Unit of position: mm, cm, m or in."),
    force_unit: str = typer.Option("N", "--force-unit", callback=_unit("force"), help="Unit of forces: N, kN or lbf."),
    torque_unit: str = typer.Option("Nm", "--torque-unit", callback=_unit("torque"), help="Unit of torques: Nm, Nmm or lbf-in."),
    penetrator: Optional[str] = typer.Option(None, "--penetrator", help="Preset or file for folders without "
                                                                        "penetrator.yaml."),
    material: Optional[str] = typer.Option(None, "--material", help="Preset or file for folders without "
                                                                    "material.yaml."),
    energizing: Optional[str] = typer.Option(None, "--energizing", help="Preset or file for folders without "
                                                                        "energizing.yaml."),
    allow_out_of_range: bool = typer.Option(False, "--allow-out-of-range",
                                            help="Accept parameter values outside their documented range (hard "
                                                 "limits still hold)."),
    allow_implausible_units: bool = typer.Option(
        False, "--allow-implausible-units",
        help="Accept runs whose travel or axial force is far off the scale their parameter files set "
             "(travel within 2× of stand-off … stand-off + full depth [mm]; peak force within 30× of S·w·T [N]); recorded in the raw stage's provenance."),
    calibration: Optional[Path] = typer.Option(None, "--calibration", help="A free-fall probe's calibration "
                                                                           "sheet (CSV channel,offset,scale,unit), "
                                                                           "for BlueDrop records (.bin)."),
    json_out: bool = typer.Option(False, "--json", help='Print [{"id": ..., "source": ...}, ...] (CONTRACT §6).'),
    db: Optional[Path] = DbOption,
) -> None:
    """Add recorded runs and field records to the workspace; each bad one is rejected on its own.

    Run folders (data.csv or data.xlsx with parameter files) become runs;
    field files become one record per sounding, profile or drop they hold:
    SGF (.cpt, .std, .tot, .sgf), GEF (.gef), AGS4 (.ags), SnowMicroPen
    (.pnt), BlueDrop (.bin, with --calibration); plain or .gz. Raw data is
    stored immutably and content-hashed: the same data ingested twice is
    the same run or record. Exit code 1 when any source was rejected.
    Example: pen ingest lab/2026-11-20/* --json
    """
    catalog = db_path(db)
    refs = {"penetrator": penetrator, "material": material, "energizing": energizing}
    if json_out:
        outcomes = api.ingest(paths, catalog, allow_out_of_range=allow_out_of_range,
                              allow_implausible_units=allow_implausible_units, columns=columns, time_unit=time_unit, position_unit=position_unit,
                              force_unit=force_unit, torque_unit=torque_unit, parameter_refs=refs,
                              calibration=calibration)
    else:
        with progress_bar("ingesting") as progress:
            outcomes = api.ingest(paths, catalog, allow_out_of_range=allow_out_of_range,
                              allow_implausible_units=allow_implausible_units, columns=columns, time_unit=time_unit, position_unit=position_unit,
                                  force_unit=force_unit, torque_unit=torque_unit, parameter_refs=refs,
                                  progress=progress, calibration=calibration)
    rejected = [o for o in outcomes if o.status == "rejected"]
    if json_out:
        print_json([{"id": o.id, "source": o.source, "status": o.status, **({"error": o.message} if o.message else {}),
                     **({"warnings": list(o.warnings)} if o.warnings else {})} for o in outcomes])
    else:
        for o in outcomes:
            if o.status == "rejected":
                err_console.print(f"[red]rejected[/red] {escape(o.message)}", highlight=False, soft_wrap=True)
            else:
                console.print(f"{'[green]added[/green]   ' if o.status == 'added' else '[dim]existing[/dim]'} "
                              f"{escape(o.id or '')}  [dim]{escape(o.source)}[/dim]", highlight=False)
            for warning in o.warnings:
                err_console.print(f"[yellow]warning:[/yellow] {escape(warning)}", highlight=False, soft_wrap=True)
        added = sum(o.status == "added" for o in outcomes)
        console.print(f"{added} added, {sum(o.status == 'existing' for o in outcomes)} already present, "
                      f"{len(rejected)} rejected → {catalog}")
    if rejected:
        raise typer.Exit(1)


def _date(text: Optional[str], option: str) -> Optional[dt.date]:
    if text is None:
        return None
    try:
        return dt.date.fromisoformat(text)
    except ValueError:
        raise typer.BadParameter(f"'{text}' is not a date (YYYY-MM-DD)", param_hint=option) from None


@runs_app.callback()
def runs(
    ctx: typer.Context,
    material: Optional[str] = typer.Option(None, "--material", help="Only runs in this material (name)."),
    blade: Optional[float] = typer.Option(None, "--blade", help="Only blades of this thickness [mm]."),
    springs: Optional[int] = typer.Option(None, "--springs", help="Only runs with this many springs."),
    tag: Optional[str] = typer.Option(None, "--tag", help="Only runs carrying this tag."),
    since: Optional[str] = typer.Option(None, "--since", help="Only runs recorded on or after (YYYY-MM-DD)."),
    until: Optional[str] = typer.Option(None, "--until", help="Only runs recorded on or before (YYYY-MM-DD)."),
    json_out: bool = typer.Option(False, "--json", help="Print the runs as JSON."),
    db: Optional[Path] = DbOption,
) -> None:
    """List the runs of the workspace, filtered.

    Example: pen runs --material mpacs_c --springs 4
    """
    if ctx.invoked_subcommand is not None:
        ctx.obj = {"db": db}
        return
    rows = api.list_runs(db_path(db), material=material, thickness_mm=blade, springs=springs, tag=tag,
                         since=_date(since, "--since"), until=_date(until, "--until"))
    if json_out:
        print_json([{k: (v.isoformat() if isinstance(v, (dt.date, dt.datetime)) else v) for k, v in r.items()}
                    for r in rows])
        return
    columns = (("run", "left"), ("date", "left"), ("material", "left"), ("blade", "left"), ("T [mm]", "right"),
               ("springs", "right"), ("rate [kHz]", "right"), ("duration [s]", "right"), ("stage", "left"),
               ("tags", "left"))
    cells = [[r["run_id"], str(r["run_date"] or ""), r["material"], r["penetrator"],
              _thickness(r["blade_thickness_mm"]),
              str(r["spring_count"]), f"{r['sampling_rate_hz'] / 1e3:.1f}", f"{r['duration_s']:.3f}",
              r["latest_stage"] or "", ", ".join(r["tags"] or [])] for r in rows]
    if not console.is_terminal:  # piped: plain tab-separated text, nothing cut
        typer.echo("\t".join(col for col, _ in columns))
        for row in cells:
            typer.echo("\t".join(row))
        return
    table = Table(show_header=True, header_style="bold", caption=f"{len(rows)} run(s) in {db_path(db)}")
    for col, justify in columns:  # ids never wrap or get cut; the other columns give way
        table.add_column(escape(col), justify=justify, no_wrap=col == "run",
                         min_width=max((len(r[0]) for r in cells), default=3) if col == "run" else None)
    for row in cells:
        table.add_row(*row)
    console.print(table)


def _db_from(ctx: typer.Context, db: Optional[Path]) -> Path:
    parent = (ctx.obj or {}).get("db") if ctx.obj else None
    return db_path(db or parent)


@runs_app.command("show")
def show(
    ctx: typer.Context,
    run: str = typer.Argument(..., help="Run id or run folder."),
    json_out: bool = typer.Option(False, "--json", help="Print as JSON."),
    db: Optional[Path] = DbOption,
) -> None:
    """Show a run: catalog record, parameter sets and every stage with its provenance.

    Example: pen runs show example-001
    """
    detail = api.run_detail(_db_from(ctx, db), run)
    if json_out:
        print_json({"run": {k: (v.isoformat() if isinstance(v, (dt.date, dt.datetime)) else v)
                            for k, v in detail.row.items()},
                    "parameters": detail.parameters,
                    "stages": [{"stage_no": s.stage_no, "stage": s.stage, "parent_no": s.parent_no,
                                "path": str(s.path), "content_sha256": s.content_sha256, "command": s.command,
                                "parameters": s.parameters, "pen_version": s.pen_version,
                                "created_at": s.created_at.isoformat()} for s in detail.stages]})
        return
    row = detail.row
    console.print(f"[bold]{row['run_id']}[/bold]  {row['material']} · {row['penetrator']} · {row['energizing']}  "
                  f"[dim]sha256 {row['content_sha256'][:16]}…[/dim]")
    console.print(f"source {escape(row['source'])} ({row['source_format']}), ingested {row['ingested_at']}, "
                  f"{row['n_samples']} samples at {row['sampling_rate_hz']:.1f} Hz over {row['duration_s']:.3f} s")
    if row.get("info"):
        console.print(f"info: {row['info']}", highlight=False)
    for kind, mapping in detail.parameters.items():
        flat = []
        for key, value in mapping.items():
            if key in ("kind", "name", "notes"):
                continue
            if isinstance(value, dict):
                flat += [f"{key}.{k}={v:g}" for k, v in value.items()]
            else:
                flat.append(f"{key}={value:g}" if isinstance(value, (int, float)) else f"{key}={value}")
        console.print(f"[bold]{kind}[/bold] {mapping.get('name')}: " + ", ".join(flat), highlight=False)
    table = Table(title="stages", show_header=True, header_style="bold")
    for col in ("#", "stage", "parent", "command", "parameters", "pen", "created"):
        table.add_column(col)
    for s in detail.stages:
        table.add_row(str(s.stage_no), s.stage, "" if s.parent_no is None else str(s.parent_no), s.command,
                      json.dumps(s.parameters)[:80], s.pen_version, str(s.created_at))
    console.print(table)


@runs_app.command("query")
def query(
    ctx: typer.Context,
    sql: str = typer.Argument(..., help="SQL over the catalog tables (runs, run_parameters, stages)."),
    json_out: bool = typer.Option(False, "--json", help="Print rows as JSON objects."),
    db: Optional[Path] = DbOption,
) -> None:
    """Run read-only SQL on the catalog (tables documented in schema/catalog.md).

    Example: pen runs query "SELECT material, count(*) FROM runs GROUP BY material"
    """
    names, rows = api.query(_db_from(ctx, db), sql)
    if json_out:
        print_json([{n: (v.isoformat() if isinstance(v, (dt.date, dt.datetime)) else v) for n, v in zip(names, r)}
                    for r in rows])
        return
    table = Table(show_header=True, header_style="bold")
    for name in names:
        table.add_column(escape(name))
    for r in rows:
        table.add_row(*("" if v is None else str(v) for v in r))
    console.print(table)


@runs_app.command("check")
def check(
    ctx: typer.Context,
    repair: bool = typer.Option(False, "--repair", help="First adopt, quarantine or remove what an interrupted pen "
                                                        "left (every writing command does this too)."),
    json_out: bool = typer.Option(False, "--json", help="Print the problems as a JSON list."),
    db: Optional[Path] = DbOption,
) -> None:
    """Verify the workspace: read every stage and compare its content hash with the catalog's.

    Reports stage files that are missing or changed since they were written, missing fit and sweep
    files, and files the catalog does not account for. Exit 1 when anything is wrong.
    Example: pen runs check --repair
    """
    problems = api.check_workspace(_db_from(ctx, db), repair=repair)
    if json_out:
        print_json(problems)
    elif problems:
        for problem in problems:
            err_console.print(f"[red]problem:[/red] {escape(problem)}", highlight=False, soft_wrap=True)
    else:
        console.print("workspace consistent: every stage file present and matching its catalog hash", highlight=False)
    if problems:
        raise typer.Exit(1)


@runs_app.command("rm")
def remove(
    ctx: typer.Context,
    runs: List[str] = typer.Argument(..., help="Run ids, run folders or id patterns ('gb-*')."),
    stage: Optional[str] = typer.Option(None, "--stage", help="Remove only this stage (name or number) and every "
                                                              "stage made from it; the raw stage means the run."),
    purge: bool = typer.Option(False, "--purge", help="Delete the files instead of moving them to quarantine/."),
    json_out: bool = typer.Option(False, "--json", help="Print what was removed as JSON."),
    db: Optional[Path] = DbOption,
) -> None:
    """Remove runs, or a stage and what was made from it, from the workspace.

    The files move to quarantine/<time>-removed/ beside the catalog (nothing is deleted unless --purge);
    a removed run can be ingested again from its source.
    Example: pen runs rm mc-1.5-2 --stage tare
    """
    removed = api.remove_runs(_db_from(ctx, db), runs, stage=stage, purge=purge)
    if json_out:
        print_json([{"run_id": r.run_id, "stages": list(r.stages), "whole_run": r.whole_run,
                     "quarantine": str(r.quarantine) if r.quarantine else None} for r in removed])
        return
    for r in removed:
        what = "run" if r.whole_run else "stage(s) " + ", ".join(r.stages) + " of run"
        where = f"; files in {r.quarantine}" if r.quarantine else ("; files deleted" if purge else "")
        console.print(f"removed {what} {escape(r.run_id)}{escape(where)}", highlight=False)


@app.command("export")
def export(
    run: str = typer.Argument(..., help="Run id or run folder."),
    to: Path = typer.Option(..., "--to", help="Folder to write (CONTRACT §3 layout)."),
    data_format: str = typer.Option("csv", "--format", help="Data file format: csv or xlsx."),
    force: bool = typer.Option(False, "--force", help="Replace a non-empty --to folder."),
    db: Optional[Path] = DbOption,
) -> None:
    """Write a run's raw data and parameter files as a CONTRACT §3 run folder.

    Example: pen export example-001 --to out/example-001
    """
    if data_format not in ("csv", "xlsx"):
        raise typer.BadParameter(f"'{data_format}' is not csv or xlsx", param_hint="--format")
    target = api.export_run(db_path(db), run, to, data_format=data_format, overwrite=force)
    console.print(f"exported to {target}")


__all__ = ["app", "runs_app", "fail"]


def _thickness(value: float | None) -> str:
    """A run's blade thickness, or a dash for a penetrator without one (a cone). [mm]"""
    return "–" if value is None else f"{value:g}"
