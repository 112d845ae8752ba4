"""``pen acquire``: fire the rig and put the run straight into the workspace."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import List, Optional

import typer
from rich.markup import escape

from pencli.lazy import lazy
from pencli.errors import PenError
from pencli.commands.common import (DbOption, PenTyper, console, db_path, err_console, fail, os_error_line, print_json,
                                    progress_bar)

api = lazy("pencli.api")  # loaded when a command runs, not for --help

app = PenTyper()


@app.command("acquire")
def acquire(
    springs: Optional[int] = typer.Option(None, "--springs", help="Springs fitted (2, 4 or 6): picks the "
                                                                  "springs_N energizing preset."),
    penetrator: str = typer.Option("al6061_1mm", "--penetrator", "-p", help="Blade: preset name or YAML file."),
    material: str = typer.Option("grill_brick", "--material", "-m",
                                 help="The block's material (measured properties are recorded with the run)."),
    energizing: Optional[str] = typer.Option(None, "--energizing", "-e", help="Launcher preset or file "
                                                                              "(instead of --springs)."),
    rig: Optional[Path] = typer.Option(None, "--rig", help="Rig file (driver, sensors; for the simulated rig its "
                                                           "true material and hidden effects). Default: the "
                                                           "bundled simulated rig."),
    driver: Optional[str] = typer.Option(None, "--driver", help="Rig driver: sim or nidaq (default: the rig "
                                                                "file's)."),
    rate: Optional[float] = typer.Option(None, "--rate", min=1000.0, help="Sampling rate [Hz] (default 30000)."),
    duration: float = typer.Option(2.0, "--duration", min=0.5, help="Length of the recording [s]; the stored "
                                                                    "run is trimmed to 0.2 s around the motion."),
    position_cal: Optional[Path] = typer.Option(None, "--position-cal", help="Position calibration file "
                                                                             "(counts per mm)."),
    force_cal: Optional[Path] = typer.Option(None, "--force-cal", help="Force calibration file (ATI-style .cal, "
                                                                       "6×6)."),
    yes: bool = typer.Option(False, "--yes", "-y", help="Fire without asking (scripts)."),
    save: Optional[bool] = typer.Option(None, "--save/--discard", help="Keep or drop the run without asking."),
    run_id: Optional[str] = typer.Option(None, "--id", help="Run id (default acq-<UTC time>)."),
    operator: Optional[str] = typer.Option(None, "--operator", help="Who ran it."),
    notes: Optional[str] = typer.Option(None, "--notes", help="Free text stored with the run."),
    tag: Optional[List[str]] = typer.Option(None, "--tag", help="Tag stored with the run (repeatable)."),
    truth_out: Optional[Path] = typer.Option(None, "--truth-out", help="Simulated rig only: write its true "
                                                                       "figures (contact, stop, strength) as JSON."),
    allow_out_of_range: bool = typer.Option(False, "--allow-out-of-range",
                                            help="Accept parameter values outside their documented ranges."),
    json_out: bool = typer.Option(False, "--json", help='Print {"id": ..., "saved": ...} as JSON.'),
    db: Optional[Path] = DbOption,
) -> None:
    """Fire the rig once and save the run into the workspace.

    Arms, tares, asks before firing, records 0.2 s before the motion and 0.2 s
    after it stops, then saves or discards.
    Example: pen acquire --springs 4 -p al6061_1.5mm -m grill_brick --yes --save
    """
    def confirm() -> bool:
        if yes:
            return True
        return typer.confirm("Springs energised. Fire?", default=False, err=True)

    info = {"id": run_id, "operator": operator, "notes": notes, "tags": list(tag or [])}
    interactive = sys.stdin.isatty() and not json_out
    if save is None and not interactive:
        save = True  # nobody to ask: a recorded shot is kept, never dropped at a prompt that cannot be answered
    if truth_out is not None:
        api.check_output(truth_out, db_path(db), "--truth-out")
    if save:
        api.check_can_save(db_path(db), run_id)  # before firing: a shot that cannot be saved is not fired
    with progress_bar("arming", disable=json_out) as progress:
        shot = api.acquire(springs=springs, penetrator=penetrator, material=material, energizing=energizing, rig=rig,
                           driver=driver, rate_hz=rate, duration_s=duration, position_cal=position_cal,
                           force_cal=force_cal, info=info, confirm=confirm, progress=progress,
                           allow_out_of_range=allow_out_of_range)
    for warning in shot.warnings:
        err_console.print(f"[yellow]warning:[/yellow] {escape(warning)}")
    columns = shot.run.columns
    fz, position = columns["fz_n"], columns["position_mm"]
    pre = columns["time_s"] < 0
    summary = (f"{shot.run.n_samples} samples at {shot.run.sampling_rate_hz:.0f} Hz; travel "
               f"{position.max() - position.min():.2f} mm; fz peak {(fz - fz[pre].mean()).max():.0f} N above the "
               f"pre-trigger level")
    if not json_out:
        console.print(summary)
    if truth_out is not None and shot.truth is not None:
        from pencli.io.atomic import write_atomic

        text = json.dumps(shot.truth, indent=2, default=float)
        write_atomic(truth_out, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    if save is None:
        save = typer.confirm("Save this run?", default=True, err=True)
    added = None
    if save:
        try:
            added = api.add_run(shot.run, db_path(db), command="pen acquire")
        except (PenError, OSError) as exc:
            reason = str(exc) if isinstance(exc, PenError) else os_error_line(exc)
            where = api.rescue_run(shot.run)
            raise fail(f"{reason}; the shot is kept as a run folder in {where} (pen ingest it when fixed)")
    if added is not None and added.renamed:
        err_console.print(f"[yellow]note:[/yellow] {escape(added.renamed)}", highlight=False, soft_wrap=True)
    if json_out:
        print_json({"id": added.run_id if added else None, "saved": bool(save), "summary": summary})
        return
    if added is None:
        console.print("discarded")
    else:
        console.print(f"saved as {added.run_id} in {db_path(db)}")


__all__ = ["app", "fail"]
