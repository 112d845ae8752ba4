"""``pen report``: HTML and PDF reports of runs, fits, sweeps and diagnoses, and a CI gate."""

from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer
from rich.markup import escape

from pencli.lazy import lazy
from pencli.commands.common import DbOption, PenTyper, console, db_path, err_console, fail, print_json, progress_bar
from pencli.errors import PenError

api = lazy("pencli.api")  # loaded when a command runs, not for --help

app = PenTyper()


@app.command("report")
def report(
    runs: Optional[List[str]] = typer.Argument(None, help="Run ids, folders or patterns to report on."),
    material: Optional[str] = typer.Option(None, "--material", "-m", help="Report a fitted material (latest "
                                                                          "version unless --version)."),
    version: Optional[int] = typer.Option(None, "--version", help="With --material: which version."),
    sweep: Optional[int] = typer.Option(None, "--sweep", help="Report a sweep by id (pen runs query "
                                                              "'SELECT * FROM sweeps')."),
    diagnose: bool = typer.Option(False, "--diagnose", help="Report a diagnosis of the RUNs (with --all: of each "
                                                            "material's conditioned runs)."),
    all_: bool = typer.Option(False, "--all", help="Every run, fitted material and sweep of the workspace, one "
                                                   "report each, into --out DIR, with an index.html."),
    out: Path = typer.Option(..., "--out", help="HTML file to write (a PDF of the same goes beside it), or a "
                                                "folder with --all."),
    pdf: bool = typer.Option(True, "--pdf/--no-pdf", help="Also write the PDF."),
    all_versions: bool = typer.Option(False, "--all-versions", help="With --all: every fitted version of each "
                                                                   "material, not only the newest."),
    check: Optional[List[str]] = typer.Option(None, "--check", metavar="METRIC<=VALUE",
                                              help="Gate: nrmse<=0.15, r2>=0.9, rms_n<=50 (each run the report is "
                                                   "of, in the newest fit that holds it) or shrink>=50 (with "
                                                   "--diagnose). Exit 1 naming everything that breaks one; the "
                                                   "report records the gate."),
    allow_unchecked: bool = typer.Option(False, "--allow-unchecked",
                                         help="Let a check that cannot be evaluated pass (a run no fit holds, "
                                              "shrink without --diagnose) instead of failing the gate."),
    json_out: bool = typer.Option(False, "--json", help="Print what was written and every check as JSON."),
    db: Optional[Path] = DbOption,
) -> None:
    """Write self-contained HTML (figures embedded) and PDF reports; optionally gate on thresholds.

    Example: pen report --all --out reports/ --check nrmse<=0.15
    """
    from pencli.report.build import write_report

    catalog = db_path(db)
    api.check_output(out, catalog, "--out", folder=all_)
    try:
        checks = api.parse_checks(check or [])
    except PenError as exc:  # a malformed gate is a usage error (exit 2), not a breach
        raise typer.BadParameter(str(exc), param_hint="--check") from None
    written: list[Path] = []
    if all_:
        results = api.run_checks(catalog, checks, api.GateScope(everything=True)) if checks else []
        extra = [("gate", [api.gate_section(results)])] if checks else []
        with progress_bar("reports", disable=json_out) as progress:
            written += api.report_all(catalog, out, pdf=pdf, progress=progress, extra=extra,
                                      all_versions=all_versions, diagnose=diagnose)
    else:
        if out.suffix.lower() != ".html":
            raise typer.BadParameter(f"'{out}' must end in .html (or use --all with a folder)", param_hint="--out")
        if not (material or sweep is not None or runs):
            raise typer.BadParameter("name RUNs, --material, --sweep, RUNs with --diagnose, or --all")
        sections, diagnosis = _sections(catalog, runs, material, version, sweep, diagnose, json_out)
        scope = api.GateScope(runs=tuple(api.run_ids(catalog, runs)) if runs else (),
                              materials=((material, version),) if material else ())
        results = api.run_checks(catalog, checks, scope, diagnosis) if checks else []
        if checks:
            sections.append(api.gate_section(results))
        written += write_report(_title(runs, material, version, sweep, diagnose), sections, out, pdf=pdf)
    broken = [r for r in results if not r.passed and (r.evaluated or not allow_unchecked)]
    if json_out:
        print_json({"written": [str(p) for p in written],
                    "checks": [{**r.__dict__, "evaluated": r.evaluated} for r in results],
                    "failures": [r.__dict__ for r in broken]})
    else:
        for path in written:
            console.print(f"wrote {path}")
        for r in broken:
            if r.evaluated:
                err_console.print(f"[red]check failed:[/red] {escape(r.subject)}: {r.metric} = {r.value:.4g} breaks "
                                  f"{escape(r.rule)}", highlight=False)
            else:
                err_console.print(f"[red]check not evaluated:[/red] {escape(r.subject)}: {escape(r.rule)}: "
                                  f"{escape(r.reason)} (--allow-unchecked lets it pass)", highlight=False)
    if broken:
        raise fail(f"{len(broken)} check(s) failed or could not be evaluated")


def _title(runs, material, version, sweep, diagnose) -> str:
    """A report's title says what it is of."""
    parts = []
    if material:
        parts.append(f"material {material}" + (f" v{version}" if version else ""))
    if sweep is not None:
        parts.append(f"sweep {sweep}")
    if runs:
        parts.append(("diagnosis of " if diagnose else "runs ") + ", ".join(runs))
    return "pen report: " + "; ".join(parts)


def _sections(catalog, runs, material, version, sweep, diagnose, quiet: bool):
    """The report's sections and, with --diagnose, the diagnosis (its checks need it)."""
    parts = [p for p, wanted in (("material", material), ("sweep", sweep is not None),
                                 ("diagnosis" if diagnose else "runs", runs)) if wanted]
    sections, diagnosis = [], None
    with progress_bar("report", disable=quiet) as progress:
        total = len(parts) + 1
        for k, part in enumerate(parts):
            progress(part, k, total)
            if part == "material":
                sections += api.report_material(catalog, material, version)
            elif part == "sweep":
                sections += api.report_sweep(catalog, sweep)
            elif part == "diagnosis":
                diag_sections, diagnosis = api.report_diagnosis(
                    catalog, runs, progress=lambda stage, done, k=k: progress(f"diagnosis: {stage}", k + done,
                                                                              total))
                sections += diag_sections
            else:
                sections += api.report_runs(catalog, runs)
        progress("writing", len(parts), total)
    return sections, diagnosis
