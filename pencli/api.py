"""The Python API of pen; the ``pen`` command maps onto it one to one.

Each function takes plain values (names, paths, numbers), calls into the
pure core and returns result objects.  Nothing here prints.
"""

from __future__ import annotations

import functools
import glob
import json
import math
import os
import shutil
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterable, Mapping, Sequence

import numpy as np

from pencli.errors import DataError, FitError, ParameterError, PenError, StoreError, describe_os_error
from pencli.model.design import Design, design_from_sets

if TYPE_CHECKING:
    from pencli.model.dynamics import SimulationResult
from pencli.params.definitions import COEFFICIENT_NAMES, COVARIANCE_KEY, Kind
from pencli.params.load import all_presets, load_file, load_preset, preset_names, resolve
from pencli.params.overrides import parse_overrides
from pencli.params.validate import ParameterSet


def simulate(*args, **kwargs):
    """:func:`pencli.model.dynamics.simulate`, imported when first needed (scipy stays out of `pen --help`)."""
    from pencli.model.dynamics import simulate as run

    return run(*args, **kwargs)


@dataclass(frozen=True)
class Prediction:
    """A simulated design with the parameter sets it came from."""

    penetrator: ParameterSet
    material: ParameterSet
    energizing: ParameterSet
    design: Design
    result: SimulationResult
    warnings: tuple[str, ...] = ()
    """Where the design leaves what the material's fit saw (``fitted_ranges``)."""
    terms: tuple[str, ...] | str | None = None
    """The Eq. 9 terms switched on (None: all)."""
    speed_at_contact_m_s: float | None = None
    """The contact speed asked for instead of the launcher's (None: the launcher's). [m/s]"""

    def band(self, draws: int | None = None):
        """The prediction band over the material's fitted covariance
        (:func:`pencli.predict.band.prediction_band`), or None when the material file carries none."""
        from pencli.predict.band import BAND_DRAWS, prediction_band

        covariance = self.material.coefficient_covariance
        if not covariance:
            return None
        mean = {name: self.material.values[f"coefficients.{name}"] for name in COEFFICIENT_NAMES}
        return prediction_band(self.design, mean, covariance, self.result, terms=self.terms,
                               speed_at_contact_m_s=self.speed_at_contact_m_s, draws=draws or BAND_DRAWS,
                               geometry=self.geometry, drive=self.drive)

    @property
    def geometry(self):
        """The penetrator's geometry (:func:`pencli.model.geometry.geometry_of`)."""
        from pencli.model.geometry import geometry_of

        return geometry_of(self.penetrator)

    @property
    def drive(self):
        """The launcher's drive (:func:`pencli.model.drive.drive_of`)."""
        from pencli.model.drive import drive_of

        return drive_of(self.energizing, self.design, self.geometry)

    def to_dict(self) -> dict:
        """CONTRACT §5 record plus where the parameters came from."""
        record = self.result.to_dict()
        record["warnings"] = list(self.warnings) + ([self.result.message] if self.result.message else [])
        record["penetrator"] = self.penetrator.name
        record["geometry"] = self.penetrator.geometry
        record["drive"] = self.energizing.drive
        record["material"] = self.material.name
        record["energizing"] = self.energizing.name
        overrides = {**self.penetrator.overrides, **self.material.overrides, **self.energizing.overrides}
        record["overrides"] = overrides
        return record

    def provenance(self) -> dict:
        """Everything needed to redo this prediction."""
        return {
            "penetrator": self.penetrator.to_mapping(),
            "material": self.material.to_mapping(),
            "energizing": self.energizing.to_mapping(),
            "sources": {"penetrator": self.penetrator.source, "material": self.material.source,
                        "energizing": self.energizing.source},
            "overrides": self.to_dict()["overrides"],
        }


def load_parameter_sets(penetrator: str | Path, material: str | Path, energizing: str | Path, *,
                        overrides: Sequence[str] = (), allow_out_of_range: bool = False, blade_only: str = ""
                        ) -> tuple[ParameterSet, ParameterSet, ParameterSet]:
    """Resolve three preset names or files and apply ``--set`` overrides.  ``blade_only``: the command that
    integrates Eq. 9's blade alone (a penetrator of another geometry is then one line)."""
    sets = {
        "penetrator": resolve(penetrator, "penetrator", allow_out_of_range=allow_out_of_range),
        "material": resolve(material, "material", allow_out_of_range=allow_out_of_range),
        "energizing": resolve(energizing, "energizing", allow_out_of_range=allow_out_of_range),
    }
    for kind, updates in parse_overrides(overrides).items():
        sets[kind] = sets[kind].with_values(updates, allow_out_of_range=allow_out_of_range)
    shape = sets["penetrator"].geometry
    if blade_only and sets["energizing"].drive != "springs":
        raise ParameterError(f"{sets['energizing'].source}: drive {sets['energizing'].drive}: {blade_only} "
                             f"integrates the spring launcher only so far; `pen predict` simulates a "
                             f"{sets['energizing'].drive.replace('_', ' ')}, one design at a time")
    if blade_only and shape != "blade":
        raise ParameterError(f"{sets['penetrator'].source}: geometry {shape}: {blade_only} integrates the blade's "
                             f"Eq. 9 law only so far; `pen predict` simulates a {shape.replace('_', ' ')}, one design "
                             f"at a time")
    return sets["penetrator"], sets["material"], sets["energizing"]


def predict(penetrator: str | Path, material: str | Path, energizing: str | Path, *,
            overrides: Sequence[str] = (), terms: Iterable[str] | str | None = None,
            speed_at_contact_m_s: float | None = None, allow_out_of_range: bool = False,
            output_rate_hz: float = 50_000.0) -> Prediction:
    """Simulate one design from presets or files (``pen predict``)."""
    p, m, e = load_parameter_sets(penetrator, material, energizing, overrides=overrides,
                                  allow_out_of_range=allow_out_of_range)
    from pencli.model.drive import drive_of
    from pencli.model.geometry import geometry_of

    design = design_from_sets(p, m, e)
    geometry = geometry_of(p)
    result = simulate(design, terms, speed_at_contact_m_s=speed_at_contact_m_s, output_rate_hz=output_rate_hz,
                      geometry=geometry, drive=drive_of(e, design, geometry))
    return Prediction(p, m, e, design, result, outside_fitted_ranges(p, m, result),
                      tuple(terms) if terms is not None and not isinstance(terms, str) else terms, speed_at_contact_m_s)


def outside_fitted_ranges(penetrator: ParameterSet, material: ParameterSet, result: SimulationResult) -> tuple[str, ...]:
    """Warnings for every quantity of this prediction outside what the material's fit saw."""
    ranges = material.fitted_ranges
    if not ranges:
        return ()
    s = result.summary
    asked = {
        "contact_speed_m_s": (s.contact_speed_m_s, "m/s", "contact speed"),
        "depth_mm": (s.final_depth_mm, "mm", "depth"),
        "blade_thickness_mm": (penetrator.values.get("blade_thickness_mm"), "mm", "blade thickness"),
        "blade_width_mm": (penetrator.values.get("blade_width_mm"), "mm", "blade width"),
        "microstructure_strength_kpa": (material.values["microstructure_strength_kpa"], "kPa", "strength"),
    }
    out = []
    for key, (value, unit, label) in asked.items():
        if key in ranges and value is not None:  # a cone has no blade width
            lo, hi = ranges[key]
            # 1 % of what the fit saw: a full-depth prediction (133 mm) against runs recorded at 132.9 mm is
            # not an extrapolation
            slack = max(1e-6 * max(abs(lo), abs(hi), 1.0), 0.01 * (hi - lo))
            if value < lo - slack or value > hi + slack:
                out.append(f"{label} {value:.4g} {unit} is outside what {material.name}'s fit saw ({lo:.4g}–{hi:.4g} "
                           f"{unit}); the coefficients are extrapolated")
    return tuple(out)


def write_prediction_trajectory(prediction: Prediction, path: str | Path) -> Path:
    """Write the trajectory of a prediction to Parquet with its provenance."""
    from pencli.io.trajectory import write_trajectory  # pyarrow only when asked

    return write_trajectory(prediction.result, path, {"parameters": prediction.provenance()})


def plot_prediction(prediction: Prediction, path: str | Path) -> str:
    """Draw a prediction (``pen predict --plot``) to a PNG, SVG or PDF file; returns the figure's caption."""
    from pencli.report.figures import prediction as prediction_figure

    title = f"{prediction.penetrator.name} · {prediction.material.name} · {prediction.energizing.name}"
    fig, caption = prediction_figure(title, prediction.result.trajectory, prediction.result.summary,
                                     prediction.band(), shape=prediction.penetrator.geometry,
                                     drive_work={"springs": "springs", "free_fall": "buoyancy, drag and tether"}.get(
                                         prediction.energizing.drive, "push"))
    return _save_captioned(fig, caption, path, fontsize=9, dpi=200)


def _save_captioned(fig, caption: str, path: str | Path, *, fontsize: float, dpi: int, top: float | None = None
                    ) -> str:
    """A figure with its caption as title, written atomically in the format of ``path``'s suffix and closed;
    returns the caption."""
    import matplotlib.pyplot as plt

    from pencli.io.atomic import write_atomic

    fig.suptitle(caption, fontsize=fontsize, wrap=True)
    if top is not None:
        fig.subplots_adjust(top=top)
    path = Path(path)
    try:
        write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=dpi, format=path.suffix.lstrip(".").lower()))
    finally:
        plt.close(fig)
    return caption


def presets() -> list[ParameterSet]:
    """Every bundled preset."""
    return all_presets()


def show_preset(name: str, kind: Kind | None = None) -> list[ParameterSet]:
    """The preset(s) called ``name`` (one per kind that has it) or a file."""
    if Path(name).suffix in (".yaml", ".yml") or "/" in name:
        return [load_file(name, kind)]
    kinds: tuple[Kind, ...] = (kind,) if kind else ("penetrator", "material", "energizing")
    found = [load_preset(name, k) for k in kinds if name in preset_names(k)]
    if not found:
        names = sorted({n for k in kinds for n in preset_names(k)})
        raise ParameterError(f"no preset named '{name}'; bundled presets: {', '.join(names)}")
    return found


@dataclass(frozen=True)
class Validation:
    """Outcome of validating one file."""

    path: str
    ok: bool
    kind: str = ""
    name: str = ""
    message: str = ""


def validate_files(paths: Iterable[str | Path], *, allow_out_of_range: bool = False) -> list[Validation]:
    """Validate each parameter file; one :class:`Validation` per file."""
    out = []
    for path in paths:
        try:
            ps = load_file(path, allow_out_of_range=allow_out_of_range)
        except PenError as exc:
            out.append(Validation(str(path), False, message=str(exc)))
        else:
            out.append(Validation(str(path), True, ps.kind, ps.name))
    return out


Progress = Callable[[str, int, int], None]
"""The progress callback every long call takes: (what is being done, done, total)."""


def check_output(path: str | Path, db: str | Path | None, option: str, *, folder: bool = False) -> Path:
    """Refuse, before any work, an output path that would land on the workspace or cannot be written
    (:func:`pencli.io.outputs.check_output`)."""
    from pencli.io.outputs import check_output as check

    return check(path, db, option, folder=folder)


# ---------------------------------------------------------------------------- workspace: ingest, runs, export
def workspace(db: str | Path):
    """The workspace whose catalog is ``db``."""
    from pencli.store.workspace import Workspace

    return Workspace(db)


@dataclass(frozen=True)
class IngestOutcome:
    """What happened to one source: ``added``, ``existing`` or ``rejected``."""

    source: str
    status: str
    id: str | None = None
    message: str = ""
    warnings: tuple[str, ...] = ()


def expand_sources(paths: Iterable[str | Path]) -> list[tuple[str, Path | None, str]]:
    """Run folders named by paths, globs and parent folders, in a stable order.

    Returns (argument, folder or None, problem) triples; a problem names an
    argument that matched nothing.
    """
    from pencli.io.field import format_of, known_suffixes
    from pencli.io.runfolder import is_run_folder

    out: list[tuple[str, Path | None, str]] = []
    for arg in paths:
        text = str(arg)
        matches = sorted(Path(m) for m in glob.glob(text)) if any(c in text for c in "*?[") else [Path(text)]
        if not matches:
            out.append((text, None, f"{text}: matches no file or folder"))
            continue
        for path in matches:
            if not path.exists():
                out.append((text, None, f"{path}: no such file or folder"))
            elif path.is_file():
                if path.name in ("data.csv", "data.xlsx"):
                    out.append((text, path.parent, ""))
                elif format_of(path) is not None:
                    out.append((text, path, ""))  # a field record's file
                else:
                    out.append((text, None, f"{path}: expected a run folder (holding data.csv or data.xlsx) or a "
                                            f"field record ({known_suffixes()}, plain or .gz)"))
            elif is_run_folder(path):
                out.append((text, path, ""))
            else:
                # run folders below: CONTRACT §3 ones (data.csv, data.xlsx) and BAM-era ones (one workbook or
                # CSV of any name, read with --columns)
                files = [p for p in path.rglob("*") if p.is_file()]
                found = {p.parent for p in files if p.suffix.lower() in (".csv", ".xlsx")}
                found |= {p for p in files if format_of(p) is not None}
                if not found:
                    out.append((text, None, f"{path}: no run folders (data.csv, data.xlsx or a BAM workbook) or "
                                            f"field records ({known_suffixes()}) inside"))
                for folder in sorted(found):
                    out.append((text, folder, ""))
    return out


def ingest(paths: Sequence[str | Path], db: str | Path, *, columns: str | None = None, time_unit: str = "s",
           position_unit: str = "mm", force_unit: str = "N", torque_unit: str = "Nm",
           parameter_refs: Mapping[str, str] | None = None, command: str = "pen ingest",
           progress: Progress | None = None,
           allow_out_of_range: bool = False, allow_implausible_units: bool = False,
           calibration: str | Path | None = None) -> list[IngestOutcome]:
    """Ingest run folders and field records into the workspace; each source is accepted or rejected on its own.

    ``allow_implausible_units`` takes runs whose travel or force is far off their parameter files' scale
    (:func:`pencli.io.checks.check_units`); the raw stage's provenance records that it was given.  A field file
    (:mod:`pencli.io.field`) gives one record per sounding, profile or drop it holds; ``calibration`` is the
    probe's calibration sheet a BlueDrop record needs.
    """
    from pencli.io.field import format_of, read_field_file
    from pencli.io.runfolder import ReadOptions, ignored_columns_warning, parse_column_map, read_run_folder, unit_factor

    options = ReadOptions(parse_column_map(columns), time_unit, position_unit, force_unit, torque_unit,
                          allow_out_of_range=allow_out_of_range, allow_implausible_units=allow_implausible_units)
    for quantity, unit in (("time", time_unit), ("position", position_unit), ("force", force_unit),
                           ("torque", torque_unit)):
        unit_factor(quantity, unit)
    ws = workspace(db)
    sources = expand_sources(paths)

    def read(item):
        _, folder, problem = item
        if folder is None:
            return None, problem
        try:
            if folder.is_file() and format_of(folder) is not None:
                return read_field_file(folder, {"calibration": calibration}), ""
            return read_run_folder(folder, options, parameter_refs), ""
        except PenError as exc:
            return None, str(exc)
        except Exception as exc:  # noqa: BLE001 - each run is its own unit: one line for it, the batch goes on
            return None, f"{folder}: could not be read: {_one_line(exc)}"

    # Read the next runs while the current one is written: parsing releases the GIL, and the
    # catalog is still opened per run so a concurrent ingest can interleave.
    from concurrent.futures import ThreadPoolExecutor

    def prefetched(pool, window: int = 2):
        """Results of read() in order, at most ``window`` runs ahead (bounded memory)."""
        pending = []
        for item in sources:
            pending.append(pool.submit(read, item))
            if len(pending) > window:
                yield pending.pop(0).result()
        for future in pending:
            yield future.result()

    outcomes: list[IngestOutcome] = []
    with ThreadPoolExecutor(max_workers=2) as pool, ws.batch():
        for (_, folder, problem), (run, error) in zip(sources, prefetched(pool)):
            if folder is None:
                outcome = IngestOutcome(problem.split(":")[0], "rejected", message=problem)
            elif run is None:
                outcome = IngestOutcome(str(folder), "rejected", message=error)
            elif isinstance(run, list):  # a field file's records
                outcomes += _add_records(ws, folder, run, command)
                if progress is not None:
                    progress(str(folder), len(outcomes), len(sources))
                continue
            else:
                try:
                    added = ws.add_run(run, command=command)
                except PenError as exc:
                    outcome = IngestOutcome(str(folder), "rejected", message=str(exc))
                except OSError as exc:  # a full disk: this run, not the batch
                    outcome = IngestOutcome(str(folder), "rejected",
                                            message=f"{folder}: not stored: {describe_os_error(exc)}")
                except (MemoryError, ValueError) as exc:  # no memory: this run, not the batch
                    outcome = IngestOutcome(str(folder), "rejected", message=f"{folder}: not stored: {_one_line(exc)}")
                else:
                    notes = (ignored_columns_warning(run), added.renamed) if added.created else ()
                    outcome = IngestOutcome(str(folder), "added" if added.created else "existing", added.run_id,
                                            warnings=tuple(n for n in notes if n))
            outcomes.append(outcome)
            if progress is not None:
                progress(outcome.source, len(outcomes), len(sources))
    return outcomes


def _add_records(ws, path: Path, records: list, command: str) -> list[IngestOutcome]:
    """Store a field file's records, each on its own (one outcome each)."""
    from pencli.store.records import add_record, file_sha256

    try:
        source_sha256 = file_sha256(path)
    except OSError as exc:
        return [IngestOutcome(str(path), "rejected", message=f"{path}: cannot read it: {describe_os_error(exc)}")]
    out = []
    for record in records:
        source = f"{path}#{record.name}" if len(records) > 1 else str(path)
        try:
            added = add_record(ws, record, several=len(records) > 1, source_sha256=source_sha256, command=command)
        except PenError as exc:
            out.append(IngestOutcome(source, "rejected", message=str(exc)))
        except OSError as exc:  # a full disk: this record, not the batch
            out.append(IngestOutcome(source, "rejected", message=f"{source}: not stored: {describe_os_error(exc)}"))
        else:
            out.append(IngestOutcome(source, "added" if added.created else "existing", added.record_id,
                                     warnings=(added.renamed,) if added.renamed else ()))
    return out


MAX_NAME_LENGTH = 80
"""Longest material name taken: it names a file under fits/ and a column a table shows whole. [characters]"""


def check_name(name: str, option: str) -> str:
    """A name pen records and files under (a fitted material): not empty, not too long, printable."""
    if not name.strip():
        raise ParameterError(f"{option} {name!r}: empty; give a name, e.g. mpacs_c")
    if len(name) > MAX_NAME_LENGTH:
        raise ParameterError(f"{option}: {len(name)} characters; a name is at most {MAX_NAME_LENGTH}")
    if not name.isprintable():
        raise ParameterError(f"{option} {name!r}: holds control characters; use letters, digits, '_' and '-'")
    return name


def _one_line(exc: BaseException) -> str:
    """An unexpected error as one line: its kind and first line (``OSError: [Errno 28] No space left``)."""
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0] if text else 'no message'}"


def check_can_save(db: str | Path, run_id: str | None = None) -> None:
    """Raise (one line) when a run could not be saved into ``db``: checked before the rig fires."""
    target = Path(db)
    home = target.parent
    if not home.is_dir():
        raise StoreError(f"{db}: folder {home} does not exist; create it or give --db elsewhere before firing")
    for path in (target, home / "runs"):
        if path.exists() and not os.access(path, os.W_OK):
            raise StoreError(f"{path}: not writable, so the shot could not be saved; fix it or give --db elsewhere "
                             f"before firing")
    if not target.exists() and not os.access(home, os.W_OK):
        raise StoreError(f"{home}: not writable, so the shot could not be saved; fix it or give --db elsewhere "
                         f"before firing")
    if run_id and target.exists():
        ws = workspace(db)
        if any(row["run_id"] == run_id for row in ws.list_runs()):
            raise StoreError(f"{db}: run id {run_id!r} is taken; give another --id before firing")


def rescue_run(run, folder: str | Path | None = None) -> Path:
    """Write an unsaved shot as a CONTRACT §3 run folder (a new folder under ``folder`` or the system's
    temporary folder) so that no recorded shot is lost; returns where."""
    import tempfile

    from pencli.io.runfolder import write_run_folder

    parent = Path(folder) if folder is not None else Path(tempfile.gettempdir())
    target = Path(tempfile.mkdtemp(prefix=f"pen-unsaved-{run.info.get('id', 'shot')}-", dir=parent))
    return write_run_folder(target, run.columns, {ps.kind: ps.to_mapping() for ps in run.parameter_sets()},
                            dict(run.info), overwrite=True)


def add_run(run, db: str | Path, *, command: str):
    """Add an in-memory raw :class:`~pencli.run.Run` (e.g. from the rig) to the workspace."""
    from pencli.io.checks import check_run_columns, check_units
    from pencli.io.runfolder import unit_scales

    check_run_columns(run.columns, run.source, surface_offset_mm=float(run.energizing.get("surface_offset_mm")))
    check_units(run.columns, run.source, unit_scales(run.penetrator, run.material, run.energizing))
    return workspace(db).add_run(run, command=command)


def list_runs(db: str | Path, **filters) -> list[dict]:
    """Catalog rows of the runs matching the filters (see ``Workspace.list_runs``)."""
    return workspace(db).list_runs(**filters)


@dataclass(frozen=True)
class RunDetail:
    """One run: its catalog row, parameters and stages."""

    row: dict
    parameters: dict
    stages: list = field(default_factory=list)


def run_detail(db: str | Path, ref: str) -> RunDetail:
    """A run's catalog row, parameter sets and stages with provenance."""
    ws = workspace(db)
    run_id = ws.resolve(ref)
    return RunDetail(ws.run_row(run_id), ws.run_parameters(run_id), ws.stages(run_id))


def query(db: str | Path, sql: str) -> tuple[list[str], list[tuple]]:
    """Read-only SQL on the catalog."""
    return workspace(db).query(sql)


def remove_runs(db: str | Path, refs: Sequence[str], *, stage: str | None = None, purge: bool = False) -> list:
    """``pen runs rm``: take runs (or a stage of each and what was made from it) out of the workspace; their
    files go to quarantine unless ``purge``.  Returns a :class:`~pencli.store.workspace.Removal` per run."""
    ws = workspace(db)
    ids = expand_run_refs(ws, refs)
    return [ws.remove(run_id, stage=stage, purge=purge) for run_id in ids]


def check_workspace(db: str | Path, *, repair: bool = False) -> list[str]:
    """Every problem of a workspace (missing or tampered stage files, files the catalog does not know), one line
    each; ``repair`` first adopts, quarantines or removes what an interrupted pen left."""
    return workspace(db).check(repair=repair)


def export_run(db: str | Path, ref: str, to: str | Path, *, data_format: str = "csv", overwrite: bool = False
               ) -> Path:
    """Write a run's raw stage as a CONTRACT §3 folder."""
    from pencli.io.runfolder import write_run_folder

    check_output(to, db, "--to", folder=True)
    ws = workspace(db)
    run = ws.load_run(ref, "raw")
    info = {**run.info}
    info.setdefault("id", run.run_id)
    return write_run_folder(to, run.columns, ws.run_parameters(run.run_id), info, data_format=data_format,
                            overwrite=overwrite)


# ---------------------------------------------------------------------------- acquisition
@dataclass(frozen=True)
class Acquisition:
    """One shot of the rig, calibrated and trimmed, not yet saved."""

    run: Any
    """The raw :class:`~pencli.run.Run` to save."""
    warnings: tuple[str, ...]
    truth: dict | None
    """The simulated rig's true figures (None on the real rig); never stored with the run."""


def measured_only(material: ParameterSet) -> ParameterSet:
    """A material set without its Eq. 9 coefficients (what a run records: measured properties)."""
    from dataclasses import replace

    values = {k: v for k, v in material.values.items() if not k.startswith("coefficients.")}
    return replace(material, values=values)


def acquire(*, springs: int | None, penetrator: str, material: str, energizing: str | None = None,
            rig: str | Path | Mapping[str, Any] | None = None, driver: str | None = None,
            rate_hz: float | None = None,
            duration_s: float = 2.0, pre_trigger_s: float = 0.2, post_motion_s: float = 0.2,
            position_cal: str | Path | None = None, force_cal: str | Path | None = None,
            info: Mapping[str, Any] | None = None, confirm: Callable[[], bool] = lambda: True,
            progress: Progress | None = None, allow_out_of_range: bool = False) -> Acquisition:
    """Fire one shot on the rig (simulated by default) and return it, unsaved."""
    import datetime as _dt

    from pencli.acquire.calibration import load_force_calibration, load_position_calibration
    from pencli.acquire.drivers import ShotSetup, make_driver
    from pencli.acquire.rig import load_rig
    from pencli.acquire.session import run_shot
    from pencli.run import Run

    if energizing is None:
        if springs is None:
            raise ParameterError("give --springs N (2, 4 or 6) or --energizing PRESET_OR_FILE")
        energizing = f"springs_{springs}"
    e = resolve(energizing, "energizing", allow_out_of_range=allow_out_of_range)
    if e.drive != "springs":
        raise ParameterError(f"{e.source}: drive {e.drive}: pen acquire fires the spring rig; a "
                             f"{e.drive.replace('_', ' ')} is predicted by `pen predict`")
    if springs is not None and int(e.values["spring_count"]) != springs:
        raise ParameterError(f"--springs {springs} but {e.source} has spring_count {e.values['spring_count']}")
    p = resolve(penetrator, "penetrator", allow_out_of_range=allow_out_of_range)
    m = resolve(material, "material", allow_out_of_range=allow_out_of_range)
    rig_config = load_rig(rig)
    name = driver or rig_config["driver"]
    rate = float(rate_hz or rig_config["sampling_rate_hz"])
    if duration_s <= pre_trigger_s + post_motion_s:
        raise ParameterError(f"--duration {duration_s:g} s leaves no time for the motion after "
                             f"{pre_trigger_s:g} s pre-trigger and {post_motion_s:g} s after it")
    pcal = load_position_calibration(position_cal)
    fcal = load_force_calibration(force_cal)
    rig_driver = make_driver(name, rig_config, pcal, fcal)
    setup = ShotSetup(rate, duration_s, pre_trigger_s, p, m, e)
    shot = run_shot(rig_driver, setup, pcal, fcal, confirm=confirm, post_motion_s=post_motion_s, progress=progress)
    now = _dt.datetime.now(_dt.timezone.utc)
    record = {"id": f"acq-{now.strftime('%Y%m%dT%H%M%S')}", "date": now.date().isoformat()}
    record.update({k: v for k, v in (info or {}).items() if v not in (None, [], "")})
    record.update({"driver": name, "rig": rig_config.name, "sampling_rate_hz": rate,
                   "tare_before_fire": shot.tare, "position_calibration": pcal.source,
                   "force_calibration": fcal.source})
    run = Run(shot.columns, p, measured_only(m), e, record, f"acquire:{name}", "acquire",
              {"driver": name, "rig": rig_config.source, "duration_s": duration_s})
    return Acquisition(run, shot.warnings, getattr(rig_driver, "truth", None))


# ---------------------------------------------------------------------------- conditioning
@dataclass(frozen=True)
class StageOutcome:
    """What a conditioning command did to one run."""

    run: str
    status: str
    """``done`` or ``rejected``."""
    run_id: str | None = None
    stage_no: int | None = None
    message: str = ""
    details: dict = field(default_factory=dict)
    warnings: tuple[str, ...] = ()


def _each_run(db: str | Path, refs: Sequence[str], work: Callable[[Any, str], StageOutcome],
              progress: Progress | None = None) -> list[StageOutcome]:
    """Apply ``work(workspace, run_id)`` to every run; a failure rejects that run only."""
    ws = workspace(db)
    outcomes = []
    refs = expand_run_refs(ws, refs)
    with ws.batch():
        for k, ref in enumerate(refs):
            if progress is not None:
                progress(str(ref), k, len(refs))
            try:
                run_id = ws.resolve(ref)
                outcomes.append(work(ws, run_id))
            except PenError as exc:
                outcomes.append(StageOutcome(ref, "rejected", message=str(exc)))
    return outcomes


def expand_run_refs(ws, refs: Sequence[str]) -> list[str]:
    """Run ids, run folders or id patterns (``gb-*``); ``all`` means every run of the workspace."""
    import fnmatch

    out: list[str] = []
    for ref in refs:
        text = str(ref)
        if text == "all":
            out.extend(ws.run_ids())
        elif any(c in text for c in "*?[") and not Path(text).exists():
            matched = fnmatch.filter(ws.run_ids(), text)
            if not matched:
                raise StoreError(f"no run id matches '{text}' in {ws.db_path}")
            out.extend(matched)
        else:
            out.append(text)
    return out


def tare_runs(db: str | Path, refs: Sequence[str], *, window_ms: tuple[float, float] | None = None,
              progress: Progress | None = None) -> list[StageOutcome]:
    """``pen tare``: offsets from the pre-trigger span, depth from the stand-off, events; a new stage."""
    def work(ws, run_id):
        tared = ws.load_run(run_id, "raw").tared(window_ms)
        record = ws.save_stage(tared)
        return StageOutcome(run_id, "done", run_id, record.stage_no, details=tared.events.to_dict())

    return _each_run(db, refs, work, progress)


def subtract_inertia_runs(db: str | Path, refs: Sequence[str], *, method: str | None = None,
                          use_flight_mass: bool = False, progress: Progress | None = None) -> list[StageOutcome]:
    """``pen subtract-inertia``: v and a from the encoder, R = F − m_lc·a; a new stage (``method`` None: each
    run's own, :func:`pencli.filter.inertia.method_for`)."""

    def work(ws, run_id):
        if not any(r.stage == "tare" for r in ws.stages(run_id)):
            raise DataError(f"run '{run_id}' has no tare stage; run `pen tare {run_id}` first")
        run, est = ws.load_run(run_id, "tare").inertia_subtracted(method, use_flight_mass=use_flight_mass)
        record = ws.save_stage(run)
        warnings = []
        if est is not None and est.disagrees:
            warnings.append(f"{run_id}: the free flight says the load-cell mass is {est.value_kg:.4f} ± "
                            f"{est.stderr_kg:.4f} kg, not the file's {run.penetrator.get('load_cell_mass_kg'):g} kg "
                            f"(use --mass-from flight, or fix load_cell_mass_kg)")
        return StageOutcome(run_id, "done", run_id, record.stage_no,
                            details={"mass_estimate": run.stage_parameters["mass_estimate"]},
                            warnings=tuple(warnings))

    return _each_run(db, refs, work, progress)


# ---------------------------------------------------------------------------- fitting
def load_campaign(db: str | Path, refs: Sequence[str], progress: Progress | None = None):
    """Each run's latest stage, which must be an inertia stage, as a :class:`~pencli.run.Campaign`."""
    from pencli.run import Campaign

    ws = workspace(db)
    out = []
    with ws.batch(write=False):  # one catalogue connection for every run
        refs = expand_run_refs(ws, refs)
        for k, ref in enumerate(refs):
            if progress is not None:
                progress(f"reading {ref}", k, len(refs))
            run = ws.load_run(ref)
            if "resistance_n" not in run.columns:
                raise DataError(f"run '{run.run_id}': its latest stage is '{run.stage}', which has no resistance; "
                                f"run `pen tare {run.run_id}` and `pen subtract-inertia {run.run_id}` first")
            out.append(run)
    return Campaign(tuple(out))


@dataclass(frozen=True)
class FitOutcome:
    """A fit, where it was recorded, and (with --all-subsets) BAM's table."""

    result: Any
    """:class:`~pencli.fit.result.FitResult`."""
    version: int | None
    material_file: dict
    out: Path | None = None
    subsets: tuple = ()
    warnings: tuple[str, ...] = ()


def parse_fix(items: Sequence[str]) -> dict[str, float]:
    """``damping=0`` or ``coefficients.damping_kpa_s_m=0`` → {coefficient: value} (file units)."""
    from pencli.fit.result import COEFFICIENT_OF, COEFFICIENTS

    out: dict[str, float] = {}
    for item in items:
        key, sep, text = item.partition("=")
        key = key.strip().removeprefix("coefficients.")
        name = COEFFICIENT_OF.get(key, key)
        if not sep or name not in COEFFICIENTS:
            raise ParameterError(f"--fix {item!r}: expected TERM=VALUE with a term ({', '.join(COEFFICIENT_OF)}) or a "
                                 f"coefficient ({', '.join(COEFFICIENTS)})")
        try:
            value = float(text)
        except ValueError:
            raise ParameterError(f"--fix {item!r}: '{text}' is not a number") from None
        if value < 0 or value != value:
            raise ParameterError(f"--fix {item!r}: coefficients are ≥ 0")
        out[name] = value
    return out


def material_file_from_fit(name: str, runs: Sequence, result) -> dict:
    """A CONTRACT §1 material mapping carrying the fitted coefficients and what the fit saw."""
    import statistics

    from pencli import __version__ as pen_version

    props = {
        "density_kg_m3": statistics.median(r.design.density_kg_m3 for r in runs),
        "microstructure_strength_kpa": statistics.median(r.design.strength_pa / 1e3 for r in runs),
        "friction_coefficient": statistics.median(r.design.friction_coefficient for r in runs),
        "gravity_m_s2": statistics.median(r.design.gravity_m_s2 for r in runs),
    }
    return {
        "kind": "material",
        "name": name,
        "notes": (f"Fitted by pen {pen_version} ({result.mode} mode, terms {', '.join(result.terms)}) over "
                  f"{len(runs)} run(s): {', '.join(r.run_id for r in runs)}. Measured properties are the "
                  f"runs' medians."),
        **{k: float(v) for k, v in props.items()},
        "coefficients": {k: float(v) for k, v in result.values().items()},
        "fitted_ranges": {k: [float(a), float(b)] for k, (a, b) in result.ranges.items()},
        **({COVARIANCE_KEY: covariance} if (covariance := result.covariance()) else {}),
    }


def fit(db: str | Path, material: str, refs: Sequence[str], *, mode: str = "resistance",
        terms: str | Sequence[str] | None = None, fix: Sequence[str] = (), all_subsets: bool = False,
        bootstrap: int = 200, out: str | Path | None = None, record: bool = True,
        command: str = "pen fit", progress: Progress | None = None) -> FitOutcome:
    """``pen fit``: Eq. 9 coefficients over runs, recorded as a new material version."""
    import yaml

    from pencli.fit.compare import model_vs_data
    from pencli.fit.dynamic import fit_dynamic
    from pencli.fit.resistance import all_subsets as fit_all_subsets
    from pencli.fit.resistance import fit_resistance
    from pencli.io.atomic import write_atomic

    if mode not in ("resistance", "dynamic"):
        raise ParameterError(f"--mode {mode!r}: expected resistance or dynamic")
    check_name(material, "--material")
    step = progress or (lambda description, done, total: None)
    runs = load_campaign(db, refs, progress)
    fixed = parse_fix(fix)
    notes = []
    if len(runs) == 1 and "damping_kpa_s_m" not in fixed:
        fixed["damping_kpa_s_m"] = 0.0  # paper §5: single-run fits hold damping at 0
        notes.append("single run: damping held at 0 (paper §5); --fix damping=VALUE to choose otherwise")
    names = runs.materials
    if len(names) > 1:
        notes.append(f"runs of several materials fitted together: {', '.join(names)}")
    step("fitting", 0, 1)
    result = fit_resistance(runs, material, terms=terms, fixed=fixed, bootstrap=bootstrap,
                            progress=lambda done, total: step("fitting, bootstrap over runs", done, total))
    if mode == "dynamic":
        step("fitting the dynamics of each run", 0, 1)
        result = fit_dynamic(runs, material, result.values(), terms=terms, fixed=fixed)
    if all_subsets:
        step("fitting every subset of the terms", 0, 1)
    subsets = tuple(fit_all_subsets(runs, material, terms=terms, fixed=fixed)) if all_subsets else ()
    step("recording", 1, 1)
    mapping = material_file_from_fit(material, runs, result)
    version = None
    if record:
        table = model_vs_data(runs, result.values(), result.terms)
        version = workspace(db).add_material_version(material, result.to_dict(), mapping,
                                                     [r.run_id for r in runs], table, command=command)
        mapping["notes"] += f" Catalog: {material} version {version}."
    out_path = None
    if out is not None:
        out_path = Path(out)
        text = yaml.safe_dump(mapping, sort_keys=False, allow_unicode=True)
        write_atomic(out_path, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    return FitOutcome(result, version, mapping, out_path, subsets, tuple(notes))


# ---------------------------------------------------------------------------- diagnosis
def workers_from_environment() -> int:
    """``PEN_WORKERS``: the processes (and compiled threads) a diagnosis may use [–] (default
    :data:`pencli.diagnose.WORKERS`), or one line saying what is wrong with it.  Set it to 1 where other jobs
    already fill the cores (a test runner's workers, a batch queue): a second process then only competes."""
    from pencli.diagnose import MAX_WORKERS, WORKERS
    from pencli.environment import number_from_environment

    return number_from_environment("PEN_WORKERS", int, 1, MAX_WORKERS, WORKERS,
                                   "how many processes a diagnosis may use", ParameterError)


def diagnose(db: str | Path, refs: Sequence[str], *, effects: Sequence[str] | None = None,
             false_alarm: float | None = None, bootstrap: int | None = None, seed: int = 0, suggest: int = 0,
             workers: int | None = None, progress: Callable[[str, float], None] | None = None):
    """``pen diagnose``: where the model and the runs part, which effect, how far it closes; with ``suggest``,
    the next runs that would best tell the leading candidates apart.

    ``false_alarm`` and ``bootstrap`` default to the engine's (1 %, 200 replicates), ``workers`` to
    :func:`workers_from_environment`.  The verdict does not depend on ``workers``.
    """
    from pencli.diagnose import engine

    workers = workers_from_environment() if workers is None else workers  # before the runs are read
    campaign = load_campaign(db, refs)
    return engine.diagnose(campaign, effects=effects,
                           false_alarm=engine.FALSE_ALARM if false_alarm is None else false_alarm,
                           bootstrap=engine.BOOTSTRAP if bootstrap is None else bootstrap, seed=seed,
                           suggest=suggest, progress=progress, workers=workers)


# ---------------------------------------------------------------------------- sweeps
@dataclass(frozen=True)
class SweepOutcome:
    """A finished sweep: where its table is and a summary."""

    n_designs: int
    variables: dict
    summary: dict
    path: Path | None
    sweep_id: int | None
    seconds: float


def sweep(penetrator: str, material: str, energizing: str, *, vary: Sequence[str] = (), resolution: int = 20,
          sample: str | None = None, n: int = 1000, seed: int = 0, overrides: Sequence[str] = (),
          out: str | Path | None = None, db: str | Path | None = None, engine: str = "local",
          scheduler: str | None = None, workers: int = 2, progress: Callable[[int, int], None] | None = None,
          speed_at_contact_m_s: float | None = None, command: str = "pen sweep",
          allow_out_of_range: bool = False) -> SweepOutcome:
    """``pen sweep``: the CONTRACT §5 figures over a grid or a sample of designs, streamed to Parquet."""
    import contextlib
    import time as _time

    from pencli.io.outputs import nearest_existing
    from pencli.model.dynamics import check_contact_speed
    from pencli.predict.batch import ENDS, NOT_SIMULATED
    from pencli.predict.chunks import evaluate_columns
    from pencli.predict.sweep import MAX_DESIGNS, SPEED, Grid, Sample, parse_vary, table_bytes
    from pencli.store.tables import StreamedTable

    if not vary:
        raise ParameterError("give at least one --vary KEY=... (e.g. --vary friction_coefficient=+40%,-30%)")
    if resolution < 2:
        raise ParameterError(f"--resolution {resolution}: at least 2 points per variable")
    if speed_at_contact_m_s is not None:
        check_contact_speed(speed_at_contact_m_s)
    from pencli.model.geometry import geometry_of
    from pencli.predict import shapes

    p, m, e = load_parameter_sets(penetrator, material, energizing, overrides=overrides,
                                  allow_out_of_range=allow_out_of_range)
    from pencli.model.drive import drive_of

    base = {**p.values, **m.values, **e.values}
    design, geometry = design_from_sets(p, m, e), geometry_of(p)
    base[SPEED] = (float(speed_at_contact_m_s) if speed_at_contact_m_s is not None else
                   float(simulate(design, output_rate_hz=1000.0, geometry=geometry,
                                  drive=drive_of(e, design, geometry)).summary.contact_speed_m_s))
    variables = [parse_vary(spec, base, resolution, p.geometry, e.drive) for spec in vary]
    total = n if sample else Grid(variables).size
    # not Eq. 9's form on CONTRACT §2's springs: each design integrated on its own
    shaped = p.geometry != "blade" or e.drive != "springs"
    if shaped and total > shapes.MAX_DESIGNS:
        what = p.geometry.replace("_", " ") + ("" if e.drive == "springs" else f" in a {e.drive.replace('_', ' ')}")
        raise ParameterError(f"{'--n' if sample else '--resolution/--vary'}: {total:.3g} designs of a {what}, each "
                             f"integrated on its own (about 12 ms a design); pen sweeps at most "
                             f"{shapes.MAX_DESIGNS:.0e} of them: lower --resolution or --n")
    if total > MAX_DESIGNS:
        raise ParameterError(f"{'--n' if sample else '--resolution/--vary'}: {total:.3g} designs; pen sweeps at most "
                             f"{MAX_DESIGNS:.0e} (about 100 GB of Parquet): lower --resolution or --n, or "
                             f"sample the space (--sample lhs --n N)")
    runner = (functools.partial(shapes.run_chunk_shaped, geometry=p.geometry, choices=dict(p.choices),
                                drive=e.drive) if shaped else None)
    ws = workspace(db) if db is not None else None
    written_to = out if out is not None else db
    folder = Path(written_to).expanduser().absolute().parent if written_to is not None else None
    needed = table_bytes(total, len(variables))
    free = shutil.disk_usage(nearest_existing(folder)).free if folder is not None else needed
    if needed > free:
        raise StoreError(f"{folder}: the sweep's table of {total:.3g} designs takes about {needed / 1e9:.3g} GB and "
                         f"{free / 1e9:.3g} GB are free there; free space, write elsewhere (--out), or sweep fewer "
                         f"designs (--n, --resolution)")
    fixed = {SPEED: float(speed_at_contact_m_s)} if speed_at_contact_m_s is not None else None
    columns = (Sample({v.key: v.domain() for v in variables}, n, sample, seed, fixed) if sample else
               Grid(variables, fixed))
    target = Path(out) if out is not None else (ws.sweep_path() if ws is not None else None)
    started = _time.perf_counter()
    stats = {"full_penetration": 0, "penetration_time_s": [np.inf, -np.inf], "peak_resistance_n": [np.inf, -np.inf],
             "final_depth_mm": [np.inf, -np.inf], "near_critical": 0}
    not_simulated: dict[str, int] = {}
    meta = {"pen:version": __import__("pencli").__version__, "pen:base": json.dumps(base),
            "pen:variables": json.dumps([v.key for v in variables])}
    with (StreamedTable(target, meta, categories={"end": ENDS}, compression="none",
                        nullable=False) if target is not None
          else contextlib.nullcontext()) as table:
        chunking = {"runner": runner, "chunk_size": shapes.CHUNK, "workers": 1} if shaped else {"workers": workers}
        for chunk, result in evaluate_columns(base, columns, engine=engine, scheduler=scheduler, progress=progress,
                                              **chunking):
            if table is not None:
                table.write({**{k: np.asarray(v, dtype=float) for k, v in chunk.items()}, **result})
            stats["full_penetration"] += int(np.sum(result["full_penetration"]))
            stats["near_critical"] += int(np.sum(result["near_critical"]))
            counts = np.bincount(np.asarray(result["end"]), minlength=len(ENDS))  # per code into ENDS, no sort
            for code in range(NOT_SIMULATED, len(ENDS)):
                if counts[code]:
                    not_simulated[ENDS[code]] = not_simulated.get(ENDS[code], 0) + int(counts[code])
            for key in ("penetration_time_s", "peak_resistance_n", "final_depth_mm"):
                values = result[key][np.isfinite(result[key])]  # not simulated: NaN, no figure
                if values.size:
                    stats[key] = [min(stats[key][0], float(np.min(values))),
                                  max(stats[key][1], float(np.max(values)))]
    seconds = _time.perf_counter() - started
    sweep_id = None
    path = Path(target) if target is not None else None
    varied = {v.key: {"unit": v.unit, "min": float(v.values.min()), "max": float(v.values.max()),
                      "points": int(v.values.size)} for v in variables}
    if ws is not None and out is None and path is not None:
        sweep_id, path = ws.add_sweep(path, penetrator=p.name, material=m.name, energizing=e.name,
                                      variables=varied, n_designs=total, command=command)
    summary = {"n_designs": total, "full_penetration_share": stats["full_penetration"] / total,
               "penetration_time_s": stats["penetration_time_s"], "peak_resistance_n": stats["peak_resistance_n"],
               "final_depth_mm": stats["final_depth_mm"], "not_simulated": not_simulated,
               "near_critical": stats["near_critical"],
               "designs_per_s": total / seconds if seconds else None}
    return SweepOutcome(total, varied, summary, path, sweep_id, seconds)


@dataclass(frozen=True)
class SensitivityRow:
    """One line of the Appendix C table: a variable at a relative step."""

    key: str
    step: float
    value: float
    unit: str
    penetration_time_s: float | None
    peak_resistance_n: float | None
    residual_ke_j: float | None
    """None (blank) where full depth is not reached, as in the paper."""
    end: str = ""
    """How the run ended: arrest, full_depth, or invalid (e.g. compressed length ≥ nominal length)."""


def sensitivity(penetrator: str = "appendix_c", material: str = "grill_brick", energizing: str = "appendix_c", *,
                steps: Sequence[float] = (-0.5, -0.2, 0.2, 0.5), keys: Sequence[str] | None = None,
                overrides: Sequence[str] = (), allow_out_of_range: bool = False) -> list[SensitivityRow]:
    """The paper's Appendix C study: each design variable moved alone; blank where full depth is not reached."""

    from pencli.params.definitions import BY_KEY
    from pencli.predict.batch import simulate_batch
    from pencli.predict.sweep import SENSITIVITY_KEYS, one_at_a_time, si_designs

    p, m, e = load_parameter_sets(penetrator, material, energizing, overrides=overrides,
                                  allow_out_of_range=allow_out_of_range, blade_only="pen sweep --sensitivity")
    base = {**p.values, **m.values, **e.values}
    chosen = list(keys or SENSITIVITY_KEYS)
    rows, columns = one_at_a_time(base, chosen, [0.0, *steps])
    designs, _ = si_designs(base, columns)
    result = simulate_batch(designs)
    figures, figures_end = result.figures, result.end
    out = []
    for i, (key, step) in enumerate(rows):
        if step == 0.0 and key != chosen[0]:
            continue
        full = bool(figures["full_penetration"][i])
        out.append(SensitivityRow("(default)" if step == 0.0 else key, step, float(columns[key][i]),
                                  BY_KEY[key].unit, float(figures["penetration_time_s"][i]) if full else None,
                                  float(figures["peak_resistance_n"][i]) if full else None,
                                  float(figures["residual_ke_j"][i]) if full else None, str(figures_end[i])))
    return out


@dataclass(frozen=True)
class SolveOutcome:
    """An inverse question answered on the batch simulator."""

    key: str
    want: str
    condition: str
    value: float | None
    resolution: float
    unit: str


def solve(penetrator: str, material: str, energizing: str, *, target: str, until: str,
          search: tuple[float, float] | None = None, overrides: Sequence[str] = (),
          allow_out_of_range: bool = False) -> SolveOutcome:
    """``--solve max:KEY --until COND``: the largest (or least) value of a §1 key for which COND holds.

    E.g. the largest microstructure strength a launcher penetrates to full depth
    (``max:microstructure_strength_kpa --until full_penetration``), the least spring stiffness reaching
    100 mm (``min:spring_stiffness_kn_m --until depth_mm>=100``), the thickest blade under 2 kN
    (``max:blade_thickness_mm --until peak_n<=2000``). Assumes the condition flips once over the range.
    """

    from pencli.params.definitions import BY_KEY
    from pencli.predict.batch import simulate_batch
    from pencli.predict.sweep import CONDITIONS, parse_condition, si_designs, solve_boundary

    want, _, key = target.partition(":")
    if want not in ("max", "min") or key not in BY_KEY:
        raise ParameterError(f"--solve {target!r}: expected max:KEY or min:KEY with a CONTRACT §1 key")
    name, threshold = parse_condition(until)
    p, m, e = load_parameter_sets(penetrator, material, energizing, overrides=overrides,
                                  allow_out_of_range=allow_out_of_range, blade_only="pen sweep --solve")
    base = {**p.values, **m.values, **e.values}
    param = BY_KEY[key]
    if search is None:
        lo = param.range_min if param.range_min is not None else base[key] / 10
        hi = param.range_max if param.range_max is not None else base[key] * 10
        lo = max(lo, base[key] / 20) if lo <= 0 else lo
        hi = min(hi, base[key] * 20)
        search = (lo if lo > 0 or not param.hard_min_exclusive else base[key] / 20, hi)

    def holds(values):
        designs, _ = si_designs(base, {key: np.asarray(values)})
        return CONDITIONS[name](simulate_batch(designs).figures, threshold)

    value, width = solve_boundary(holds, float(search[0]), float(search[1]), want)
    return SolveOutcome(key, want, until, value, width, param.unit)


# ---------------------------------------------------------------------------- reports
def run_ids(db: str | Path, refs: Sequence[str]) -> list[str]:
    """The run ids that run ids, run folders or id patterns name (``all``: every run)."""
    ws = workspace(db)
    return [ws.resolve(ref) for ref in expand_run_refs(ws, refs)]


def report_runs(db: str | Path, refs: Sequence[str]) -> list:
    """Sections for runs: raw channels (Fig. 11), measurements (Fig. 12), model against data (Fig. 13),
    energy per term (Fig. 14), parameters and provenance.  One run is drawn alone; several are drawn together
    (each figure holds every run) and followed by each run's tables."""
    from pencli.report.sections import campaign_sections, run_section

    ws = workspace(db)
    with ws.batch(write=False):  # one catalogue connection for every section
        versions = ws.material_versions()
        ids = list(dict.fromkeys(ws.resolve(ref) for ref in expand_run_refs(ws, refs)))
        if len(ids) == 1:
            return [run_section(ws, ids[0], versions)]
        return campaign_sections(ws, ids, versions)


def report_material(db: str | Path, material: str, version: int | None = None) -> list:
    """Sections for a fitted material version: coefficients, intervals, correlation, runs, Fig. 13, Fig. 16."""
    ws = workspace(db)
    with ws.batch(write=False):
        return _material_sections(ws, db, material, version)


def _material_sections(ws, db, material: str, version: int | None) -> list:
    from pencli.report.sections import material_section

    versions = ws.material_versions(material)
    if not versions:
        raise StoreError(f"no fitted material '{material}' in {db} (pen fit --material {material} RUN...)")
    row = versions[-1] if version is None else next((v for v in versions if v["version"] == version), None)
    if row is None:
        raise StoreError(f"material '{material}' has no version {version}; versions: "
                         f"{', '.join(str(v['version']) for v in versions)}")
    return [material_section(ws, row)]


def report_sweep(db: str | Path, sweep_id: int) -> list:
    """Sections for a sweep: heat map with the full-penetration boundary (Fig. 14), 4-D scatter (Fig. 15)."""
    from pencli.report.sections import sweep_section

    ws = workspace(db)
    record = ws.sweep_row(sweep_id)
    if record is None:
        raise StoreError(f"no sweep {sweep_id} in {db}")
    return [sweep_section(ws, record)]


def report_diagnosis(db: str | Path, refs: Sequence[str], progress: Callable[[str, float], None] | None = None
                     ) -> tuple[list, Any]:
    """Sections for a diagnosis (and the diagnosis itself, for checks)."""
    from pencli.report.sections import diagnosis_section

    result = diagnose(db, refs, progress=progress)
    return [diagnosis_section(result)], result


@dataclass(frozen=True)
class ReportJob:
    """One report of ``pen report --all``: its group on the index, title, path under the folder, what makes its
    sections, and one line about it."""

    group: str
    title: str
    path: Path
    make: Callable[[], list]
    note: str = ""


def report_jobs(db: str | Path, *, all_versions: bool = False, diagnose: bool = False) -> list[ReportJob]:
    """The reports ``pen report --all`` writes, in the index's order: every run, each material's newest fitted
    version (every version with ``all_versions``), every sweep, and with ``diagnose`` a diagnosis of each
    material's conditioned runs (three or more)."""
    ws = workspace(db)
    rows = {r["run_id"]: r for r in ws.list_runs()}
    versions = ws.material_versions()
    if not all_versions:
        newest = {v["material"]: v for v in versions}
        versions = [v for v in versions if newest[v["material"]] is v]
    jobs = [ReportJob("runs", f"run {r}", Path("runs") / f"{r}.html", lambda r=r: report_runs(db, [r]),
                      f"{rows[r]['material']}, {rows[r]['penetrator']}, {rows[r]['spring_count']} springs")
            for r in ws.run_ids()]
    jobs += [ReportJob("fitted materials", f"material {v['material']} v{v['version']}",
                       Path("materials") / f"{v['material']}-v{v['version']}.html",
                       lambda v=v: report_material(db, v["material"], v["version"]),
                       f"fitted over {len(v['source_runs'])} runs") for v in versions]
    jobs += [ReportJob("sweeps", f"sweep {i}", Path("sweeps") / f"sweep-{i}.html", lambda i=i: report_sweep(db, i))
             for i in ws.sweep_ids()]
    if diagnose:
        conditioned = [r for r in ws.run_ids() if any(s.stage == "inertia" for s in ws.stages(r))]
        for name in sorted({rows[r]["material"] for r in conditioned}):
            mine = [r for r in conditioned if rows[r]["material"] == name]
            if len(mine) >= 3:
                jobs.append(ReportJob("diagnoses", f"diagnosis of the {name} runs",
                                      Path("diagnoses") / f"{name}.html",
                                      lambda mine=mine: report_diagnosis(db, mine)[0], f"{len(mine)} runs"))
    return jobs


def report_all(db: str | Path, out: str | Path, *, pdf: bool = True, progress: Progress | None = None,
               extra: Sequence[tuple[str, list]] = (), all_versions: bool = False, diagnose: bool = False
               ) -> list[Path]:
    """``pen report --all``: one report per run, fitted material (its newest version; every version with
    ``all_versions``) and sweep under ``out``, with ``diagnose`` one diagnosis per material's conditioned runs
    (three or more), each (name, sections) of ``extra`` (the gate's record) as ``out/<name>.html``, and an
    ``index.html`` that links them all."""
    import tempfile

    from pencli.io.atomic import make_parents, remove_made
    from pencli.report.build import write_index, write_report

    ws = workspace(db)
    out = Path(out)
    jobs = report_jobs(db, all_versions=all_versions, diagnose=diagnose)
    jobs += [ReportJob("checks", name, Path(f"{name}.html"), lambda sections=sections: sections)
             for name, sections in extra]
    # every report is written into a hidden folder beside ``out`` and moved into place when all are done: a
    # failure part-way (a full disk) leaves ``out`` as it was
    made = make_parents(out.parent)
    staging = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    written: list[Path] = []
    entries = []
    try:
        for k, job in enumerate(jobs):
            if progress is not None:
                progress(job.title, k, len(jobs))
            sections = job.make()
            written += write_report(f"pen report: {job.title}", sections, staging / job.path, pdf=pdf)
            entries.append((job.group, job.title, job.path, job.note or " · ".join(s.title for s in sections[:1])))
        written.append(write_index(f"pen reports of {ws.db_path.parent.name or ws.db_path}", entries,
                                   staging / "index.html"))
        made += make_parents(out)
        for path in written:
            (out / path.relative_to(staging)).parent.mkdir(parents=True, exist_ok=True)
            os.replace(path, out / path.relative_to(staging))
    except BaseException:
        remove_made(made)
        raise
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    if progress is not None:
        progress("done", len(jobs), len(jobs))
    return [out / path.relative_to(staging) for path in written]


@dataclass(frozen=True)
class CheckResult:
    """One threshold of the gate on one subject: its value and whether it holds, or why it could not be read."""

    subject: str
    metric: str
    value: float | None
    rule: str
    passed: bool
    reason: str = ""
    """Why the check could not be evaluated (empty when it was)."""

    @property
    def evaluated(self) -> bool:
        return self.value is not None


@dataclass(frozen=True)
class GateScope:
    """What a report is of, so that its checks look at that and nothing else: run ids (checked in the newest
    fit that holds them), material versions, or a diagnosis."""

    runs: tuple[str, ...] = ()
    materials: tuple[tuple[str, int | None], ...] = ()
    """(material, version or None for the latest)."""
    everything: bool = False
    """``--all``: every material's latest fit and every run of the workspace."""


def parse_checks(items: Sequence[str]) -> list[tuple[str, str, float]]:
    """``nrmse<=0.15``, ``r2>=0.9``, ``shrink>=50`` → (metric, operator, threshold)."""
    import re

    out = []
    for item in items:
        match = re.fullmatch(r"\s*(nrmse|r2|rms_n|shrink)\s*(<=|>=)\s*([0-9.eE+-]+)\s*", item)
        try:
            threshold = float(match.group(3)) if match else math.nan
        except ValueError:
            threshold = math.nan
        if not match or not math.isfinite(threshold):
            raise ParameterError(f"--check {item!r}: expected METRIC<=VALUE or METRIC>=VALUE with METRIC one of "
                                 f"nrmse, r2, rms_n (each run of each material's latest fit) or shrink (diagnosis)")
        out.append((match.group(1), match.group(2), threshold))
    return out


def run_checks(db: str | Path, checks: Sequence[tuple[str, str, float]], scope: GateScope,
               diagnosis=None) -> list[CheckResult]:
    """Evaluate each threshold on what the report is of: ``nrmse``, ``r2``, ``rms_n`` on each run in scope as the
    newest fit that holds it measured it, ``shrink`` on the diagnosis.  A check with nothing to read (a run never
    fitted, ``shrink`` without a diagnosis, a report of a sweep) is a result that did not pass, with its reason."""
    ws = workspace(db)
    versions = ws.material_versions()
    latest = {v["material"]: v for v in versions}
    chosen = list(latest.values()) if scope.everything else [
        latest[m] if ver is None else next(v for v in versions if v["material"] == m and v["version"] == ver)
        for m, ver in scope.materials if m in latest]
    by_run: dict[str, tuple[dict, dict]] = {}
    for version in sorted(latest.values(), key=lambda v: v["created_at"]):
        for run in json.loads(version["fit"])["runs"]:
            by_run[run["run_id"]] = (version, run)  # the newest fit that holds the run
    wanted = list(ws.run_ids()) if scope.everything else list(scope.runs)
    return [result for check in checks for result in _check(check, chosen, wanted, by_run, diagnosis)]


def _check(check: tuple[str, str, float], chosen: Sequence[dict], wanted: Sequence[str],
           by_run: Mapping[str, tuple[dict, dict]], diagnosis) -> list[CheckResult]:
    metric, op, threshold = check
    rule = f"{metric}{op}{threshold:g}"

    def holds(value: float) -> bool:
        return value >= threshold if op == ">=" else value <= threshold

    if metric == "shrink":
        if diagnosis is None:
            return [CheckResult("diagnosis", metric, None, rule, False, "the report has no diagnosis (add --diagnose)")]
        named = diagnosis.verdict not in ("none", "unexplained") and diagnosis.effects
        top = diagnosis.effects[0].shrink_pct if named else 0.0
        return [CheckResult(f"diagnosis ({diagnosis.verdict})", metric, top, rule, holds(top))]
    subjects = [(f"{v['material']} v{v['version']} run {r['run_id']}", r) for v in chosen
                for r in json.loads(v["fit"])["runs"]]
    covered = {r["run_id"] for _, r in subjects}
    results = []
    for run_id in (r for r in wanted if r not in covered):
        if run_id in by_run:
            version, run = by_run[run_id]
            subjects.append((f"{version['material']} v{version['version']} run {run_id}", run))
        else:
            results.append(CheckResult(f"run {run_id}", metric, None, rule, False,
                                       "no fit holds this run (pen fit it first)"))
    if not subjects and not results:
        results.append(CheckResult("report", metric, None, rule, False, "the report holds no fitted run"))
    return results + [CheckResult(subject, metric, float(run[metric]), rule, holds(float(run[metric])))
                      for subject, run in subjects]


def gate_section(results: Sequence[CheckResult]) -> Any:
    """The gate's record in a report: every check on every subject, its value and outcome."""
    from pencli.report.build import Section

    failed = [r for r in results if not r.passed]
    text = (f"{len(results)} check(s): all hold." if not failed else
            f"{len(results)} check(s): {len(failed)} did not hold or could not be evaluated.")
    return Section("gate", text=text, tables=[(
        "checks of this report", ["check", "subject", "value", "outcome"],
        [[r.rule, r.subject, r.value, "holds" if r.passed else (f"not evaluated: {r.reason}" if not r.evaluated
                                                               else "breaks")] for r in results])])


# ---------------------------------------------------------------------------- field soundings
SOUNDING_QUANTITIES = {"qt": ("qc_mpa", "u2_kpa"), "qc": ("qc_mpa",), "fs": ("fs_kpa",), "u2": ("u2_kpa",),
                       "push_force": ("push_force_kn",)}
"""Quantities of a sounding a rate effect is fitted to, and the columns each is made from: qt = qc + (1 − a)·u₂
(a, the net area ratio, from the header's MA), qc the cone resistance, fs the sleeve friction, u2 the pore
pressure (a CPTu's, in kPa); push_force the force on a total sounding's rods (in kN)."""

QUANTITY_UNITS = {"qt": "kPa", "qc": "kPa", "fs": "kPa", "u2": "kPa", "push_force": "kN"}
"""The unit each of :data:`SOUNDING_QUANTITIES` is fitted in."""


def sounding_reading(sounding):
    """A sounding as its instrument's sensor chain reads it (:class:`pencli.sensors.Reading`): a cone's tip
    (``pencli.sensors.cone_tip``: qc, fs, u₂, and qt with the header's net area ratio MA where it has a valid
    one), a total sounding's force on the rods (``pencli.sensors.rod_force``); a record of a kind pen does not
    know by the channels it has."""
    from pencli.sensors import CHAINS, chain, missing_channels

    c = sounding.columns
    instrument = getattr(sounding, "instrument", None)  # a sounding read from a file says it by its channels
    names = [n for n in (instrument and instrument.chain, "cone_tip", "rod_force")
             if n in CHAINS and not missing_channels(CHAINS[n], c)]
    if not names:
        raise DataError(f"{sounding.source}: sounding {sounding.name} has no cone resistance (qc) and no push force "
                        f"(A)")
    ratio = sounding.header_number("MA")
    constants = {"net_area_ratio": ratio if ratio is not None and 0.0 < ratio <= 1.0 else None} \
        if names[0] == "cone_tip" else {}
    return chain(names[0], **constants).read(sounding.name, sounding.time_s, c)


def sounding_resistance(sounding) -> tuple[np.ndarray, str, str]:
    """A sounding's resistance to penetration, its name and unit, as its chain reads it (:func:`sounding_reading`):
    a cone's qt = qc + (1 − a)·u₂ where the sounding has u₂ and its net area ratio, else qc [MPa]; a total
    sounding's push force on the rods [kN]."""
    reading = sounding_reading(sounding)
    for name in ("qt", "qc"):
        if name in reading.pressures_kpa:
            return reading.pressures_kpa[name] / 1e3, name, "MPa"
    return reading.force_n / 1e3, "push_force", "kN"


def sounding_layers(sounding, *, min_thickness_m: float | None = None, resistance: tuple | None = None):
    """The layers of a sounding's resistance (``resistance``, :func:`sounding_resistance`'s, computed when not
    given; :func:`pencli.fit.layers.detect_layers`)."""
    from pencli.fit.layers import MIN_THICKNESS_M, detect_layers

    q, _, _ = resistance or sounding_resistance(sounding)
    try:
        return detect_layers(sounding.columns["depth_m"], q,
                             min_thickness_m=MIN_THICKNESS_M if min_thickness_m is None else min_thickness_m)
    except DataError as error:
        raise DataError(f"{sounding.source}: sounding {sounding.name}: {error}") from None


def plot_sounding(sounding, path: str | Path, layers=None, resistance: tuple | None = None) -> str:
    """Draw a sounding (``pen soundings plot``) against depth to a PNG, SVG or PDF file, with ``layers`` (a
    :class:`~pencli.fit.layers.Cut`) drawn where given; returns the caption.  ``resistance``:
    :func:`sounding_resistance`'s, computed when not given."""
    from pencli.report.figures import sounding_profile

    c = sounding.columns
    q, name, _ = resistance or sounding_resistance(sounding)
    fig, caption = sounding_profile(sounding.name, c["depth_m"], c.get("qc_mpa", q), c.get("fs_kpa"), c.get("u2_kpa"),
                                    q if name == "qt" else None, layers=layers, resistance=RESISTANCE_LABELS[name])
    return _save_captioned(fig, caption, path, fontsize=8, dpi=150, top=0.9)


RESISTANCE_LABELS = {"qt": ("cone resistance", "MPa", "qc"), "qc": ("cone resistance", "MPa", "qc"),
                     "push_force": ("push force on the rods", "kN", "A")}
"""How a sounding figure names each resistance :func:`sounding_resistance` gives: (what, unit, symbol of the
drawn curve)."""


def report_soundings(paths: Sequence[str | Path], out: str | Path, *, pdf: bool = True,
                     min_thickness_m: float | None = None, db: str | Path | None = None) -> list[Path]:
    """``pen soundings report``: one section per sounding of the files (its header, layers and profile), written
    as self-contained HTML (and a PDF beside it); returns the files written."""
    from pencli.filter.rate import push_rate_mm_s
    from pencli.report.build import write_report
    from pencli.report.sections import sounding_section

    sections = []
    for sounding in read_soundings(paths, db):
        resistance = q, quantity, unit = sounding_resistance(sounding)
        cut = sounding_layers(sounding, min_thickness_m=min_thickness_m, resistance=resistance)
        rate = (push_rate_mm_s(sounding.columns["depth_m"], sounding.time_s) if sounding.time_s is not None
                else None)
        sections.append(sounding_section(sounding, cut, q, quantity, unit,
                                         rate if rate is not None and math.isfinite(rate) else None,
                                         RESISTANCE_LABELS[quantity]))
    title = f"pen soundings report: {len(sections)} sounding{'s' if len(sections) != 1 else ''}"
    return write_report(title, sections, out, pdf=pdf)


def field_records(refs: Sequence[str | Path], family: str, db: str | Path | None = None,
                  options: Mapping | None = None) -> list:
    """The records ``refs`` name, as their format's reader returns them (one or more per file), in order.

    A ref is a file (read by its format, :data:`pencli.io.field.FORMATS`; a sounding file of another suffix is
    read as SGF), or, where no such file exists, a record id of workspace ``db`` (a pattern with ``*`` or ``?``
    matches ids).  ``family`` (``sounding``, ``snow``, ``drop``) is what the command takes: a record of another
    family is refused in one line.  ``options`` go to a file's reader (a BlueDrop record's ``calibration``).
    """
    import fnmatch

    from pencli.io.field import FAMILY_TITLES, FORMATS, format_of

    out = []
    ws = workspace(db) if db is not None else None
    rows = None
    for ref in refs:
        path = Path(ref)
        if path.is_file():
            fmt = format_of(path) or (FORMATS["sgf"] if family == "sounding" else None)
            if fmt is None or fmt.family != family:
                raise DataError(f"{path}: expected {FAMILY_TITLES[family]}")
            out += fmt.read(path, options or {})
            continue
        if ws is None or not ws.exists():
            raise DataError(f"{ref}: no such file" + (f", and no workspace at {db} to find it in" if db else ""))
        from pencli.store.records import load_record, record_rows

        text = str(ref)
        rows = record_rows(ws) if rows is None else rows  # the catalog read once for every ref
        ids = ([r["record_id"] for r in rows if fnmatch.fnmatchcase(r["record_id"], text)]
               if any(c in text for c in "*?[") else [text])
        if not ids:
            raise DataError(f"{ref}: no such file, and no record id in {db} matches it")
        for record_id in ids:
            try:
                record = load_record(ws, record_id, rows)
            except StoreError as error:
                raise StoreError(f"{ref}: no such file, and {error}") from None
            if FORMATS[record.format].family != family:
                raise DataError(f"record '{record_id}' is a {FORMATS[record.format].title}; expected "
                                f"{FAMILY_TITLES[family]}")
            out.append(record.to_object())
    return out


def list_records(db: str | Path, *, kind: str | None = None) -> list[dict]:
    """``pen records``: the catalog rows of the workspace's field records (a kind's only, when given)."""
    from pencli.io.field import KINDS
    from pencli.store.records import record_rows

    ws = workspace(db)
    rows = record_rows(ws)
    if kind is not None and kind not in {r["kind"] for r in rows} | set(KINDS):
        raise ParameterError(f"--kind {kind!r}: expected one of {', '.join(KINDS)}")
    return [r for r in rows if kind is None or r["kind"] == kind]


def read_soundings(paths: Sequence[str | Path], db: str | Path | None = None):
    """The soundings (``pencli.io.sgf.Sounding``) of SGF, GEF or AGS4 files, or of records of workspace ``db``,
    in order (:func:`field_records`)."""
    return field_records(paths, "sounding", db)


def site_unit_means(units_file: str | Path, site: str, quantity: str = "qt"):
    """(the site, each sounding's unit means of ``quantity``) for a site of a units file."""
    from pencli.fit.rate_effect import unit_means
    from pencli.io.units_file import read_units_file

    if quantity not in SOUNDING_QUANTITIES:
        raise ParameterError(f"quantity '{quantity}': expected one of {', '.join(SOUNDING_QUANTITIES)}")
    sites = read_units_file(units_file)
    if site not in sites:
        raise ParameterError(f"{units_file}: no site '{site}'; it has {', '.join(sites)}")
    chosen = sites[site]
    needed = SOUNDING_QUANTITIES[quantity]
    if chosen.units_m is None:
        chosen = replace(chosen, units_m=layer_units(chosen))
    means = []
    for entry in chosen.soundings:
        records = read_soundings([entry.path])
        if len(records) != 1:
            raise DataError(f"{entry.path}: {len(records)} soundings in one file; a units file names one per file")
        record = records[0]
        columns = record.columns
        missing = [c for c in needed if c not in columns]
        if not missing and record.time_s is None and "rate_mm_s" not in columns:
            missing = ["clock (% or AK) or logger's rate (B)"]
        if missing:
            raise DataError(f"{entry.path}: no {', '.join(missing)} column; a rate effect of {quantity} needs it")
        if quantity == "qt":
            area_ratio = record.header_number("MA")
            if area_ratio is None or not 0.0 < area_ratio <= 1.0:
                raise DataError(f"{entry.path}: header MA (the net area ratio, 0 < a ≤ 1) is "
                                f"{record.header.get('MA', 'missing')!r}; qt needs it")
        reading = sounding_reading(record)
        if quantity == "push_force":
            values = None if reading.force_n is None else reading.force_n / 1e3
        else:
            values = reading.pressures_kpa.get(quantity)
        if values is None:
            raise DataError(f"{entry.path}: sounding {record.name}'s sensor chain reads no {quantity}")
        means.append(unit_means(reading.travel_m, record.time_s, values, chosen.units_m, entry.warp_m,
                                entry.drop_m, logger_rate_mm_s=columns.get("rate_mm_s")))
    return chosen, means


UNIT_MARGIN_M = 0.15
"""A unit made from a layer stays this far inside its boundaries, off the cone's ramp across them (about four
diameters of a 10 cm² cone). [m]"""


def layer_units(site) -> tuple[tuple[float, float], ...]:
    """The units of a site whose units file says ``"units_m": "layers"``: the layers of the reference sounding's
    resistance (:func:`sounding_layers`), each less :data:`UNIT_MARGIN_M` at either boundary, those left at least
    as thick as the cut's thinnest layer. [m]"""
    from pencli.fit.layers import MIN_THICKNESS_M

    entry = next(s for s in site.soundings if s.name == site.reference_sounding)
    (reference,) = read_soundings([entry.path])
    cut = sounding_layers(reference)
    last = len(cut.layers) - 1
    units = [(layer.top_m + (UNIT_MARGIN_M if k > 0 else 0.0), layer.bottom_m - (UNIT_MARGIN_M if k < last else 0.0))
             for k, layer in enumerate(cut.layers)]
    kept = tuple((top, bottom) for top, bottom in units if bottom - top >= MIN_THICKNESS_M - 1e-9)
    if not kept:
        raise DataError(f"{entry.path}: no layer of the reference sounding is thick enough to be a unit")
    return kept


def fit_soundings(units_file: str | Path, site: str, quantity: str = "qt"):
    """``pen soundings fit``: the rate effect of ``quantity`` across a site's soundings
    (``pencli.fit.rate_effect.RateEffect``)."""
    from pencli.fit.rate_effect import fit_rate_effect

    chosen, means = site_unit_means(units_file, site, quantity)
    return fit_rate_effect([m for g in means for m in g], chosen.reference_rate_mm_s)


def diagnose_soundings(units_file: str | Path, site: str, quantity: str = "qt", *, permutations: int | None = None,
                       false_alarm: float | None = None, seed: int = 0):
    """``pen soundings diagnose``: whether the push rate changes ``quantity`` at a site, and which way
    (``pencli.diagnose.soundings.SoundingDiagnosis``); ``permutations`` and ``false_alarm`` default to
    ``pencli.diagnose.SOUNDING_SHUFFLES`` and ``SOUNDING_FALSE_ALARM``."""
    from pencli.diagnose import soundings

    chosen, means = site_unit_means(units_file, site, quantity)
    return soundings.diagnose_soundings(
        means, reference_rate_mm_s=chosen.reference_rate_mm_s,
        permutations=soundings.SHUFFLES if permutations is None else permutations,
        false_alarm=soundings.FALSE_ALARM if false_alarm is None else false_alarm, seed=seed)


# ---------------------------------------------------------------------------- SnowMicroPen profiles
@dataclass(frozen=True)
class SnowProfile:
    """A SnowMicroPen profile read and estimated (``pen snow estimate``): the profile
    (``pencli.io.pnt.SmpProfile``), the snow's surface and bottom [mm from the motor's start], the shot-noise
    estimates per window with depths below the surface (``pencli.fit.shot_noise.ShotNoise``) and each layer's
    medians (``LayerSummary``)."""

    profile: object
    surface_mm: float
    bottom_mm: float
    estimates: object
    layers: tuple


def read_snow_profiles(paths: Sequence[str | Path], db: str | Path | None = None):
    """The profiles (``pencli.io.pnt.SmpProfile``) of SnowMicroPen ``.pnt`` files, or of records of workspace
    ``db``, in order (:func:`field_records`)."""
    return field_records(paths, "snow", db)


def estimate_snow_profile(profile, *, window_mm: float | None = None, overlap: float | None = None,
                          surface_mm: float | None = None, bottom_mm: float | None = None,
                          layers: Sequence[tuple[float, float]] = (), db: str | Path | None = None) -> SnowProfile:
    """``pen snow estimate``: a profile's shot-noise estimates (Löwe and van Herwijnen 2012) per window below the
    snow surface (found in the force unless given) down to ``bottom_mm`` (the profile's end unless given), and the
    medians of each layer (top, bottom) [mm below the surface].  ``profile``: an ``SmpProfile``, a ``.pnt`` file,
    or a record id of workspace ``db``."""
    from pencli.fit import shot_noise as sn
    from pencli.io.pnt import SmpProfile
    from pencli.sensors import chain

    if not isinstance(profile, SmpProfile):
        found_profiles = read_snow_profiles([profile], db)
        if len(found_profiles) != 1:
            raise DataError(f"{profile}: names {len(found_profiles)} profiles; give one")
        profile = found_profiles[0]
    path = profile.source
    reading = chain("tip_force").read(profile.name, None, {"depth_mm": profile.depth_mm, "force_n": profile.force_n})
    force, depth_mm = reading.force_n, profile.depth_mm  # the travel as recorded, in the estimator's mm
    found = sn.surface_mm(force, profile.step_mm) if surface_mm is None else surface_mm
    if found is None:
        raise DataError(f"{path}: no snow surface in the force (no 1-mm mean {sn.SURFACE_RISE_N} N above the "
                        f"air's); give it with --surface-mm")
    end = float(profile.depth_mm[-1]) if bottom_mm is None else bottom_mm
    first, last = np.searchsorted(depth_mm, [found, end])
    if last - first < 3:
        raise DataError(f"{path}: no samples between the surface at {found:.1f} mm and the bottom at {end:.1f} mm")
    try:
        estimates = sn.shot_noise(force[first:last], profile.step_mm,
                                  diameter_mm=profile.tip_diameter_mm,
                                  window_mm=sn.WINDOW_MM if window_mm is None else window_mm,
                                  overlap=sn.OVERLAP if overlap is None else overlap, overload_n=profile.overload_n,
                                  start_mm=float(depth_mm[first]) - found)
    except ValueError as error:
        raise DataError(f"{path}: {error}") from None
    summaries = tuple(sn.layer_summary(estimates, top, bottom) for top, bottom in layers)
    return SnowProfile(profile, found, end, estimates, summaries)


def write_columns_csv(path: str | Path, columns: Mapping[str, np.ndarray]) -> Path:
    """Columns of one length to a CSV file (a header line of their names; booleans as 0/1), written atomically."""
    from pencli.io.atomic import write_atomic

    table = np.column_stack([np.asarray(v, dtype=float) for v in columns.values()])
    return write_atomic(path, lambda tmp: np.savetxt(tmp, table, delimiter=",", header=",".join(columns),
                                                     comments="", fmt="%.9g"))


def report_snow(paths: Sequence[str | Path], out: str | Path, *, layers: Sequence[tuple[float, float]] = (),
                pdf: bool = True, window_mm: float | None = None, overlap: float | None = None,
                db: str | Path | None = None) -> list[Path]:
    """``pen snow report``: one section per SnowMicroPen profile (its snow, each layer's medians, its figure), as
    self-contained HTML (and a PDF beside it); returns the files written.  ``paths``: files or record ids of
    workspace ``db``."""
    from pencli.report.build import write_report
    from pencli.report.sections import snow_section

    sections = [snow_section(estimate_snow_profile(profile, window_mm=window_mm, overlap=overlap, layers=layers))
                for profile in read_snow_profiles(paths, db)]
    title = f"pen snow report: {len(sections)} SnowMicroPen profile{'s' if len(sections) != 1 else ''}"
    return write_report(title, sections, out, pdf=pdf)


def plot_snow_profile(result: SnowProfile, path: str | Path) -> str:
    """Draw a profile's estimates (``pen snow estimate --plot``) to a PNG, SVG or PDF file; returns the caption."""
    from pencli.report.figures import snow_profile

    fig, caption = snow_profile(result.profile.name, result.estimates, result.layers)
    return _save_captioned(fig, caption, path, fontsize=8, dpi=150, top=0.86)


# ---------------------------------------------------------------------------- free-fall drops
@dataclass(frozen=True)
class Drop:
    """One free-fall record and its chain's reading (:class:`pencli.sensors.Reading`; its account the motion,
    :class:`pencli.filter.freefall.DropMotion`: release, impact, speed at impact, penetration, each
    accelerometer's bias)."""

    record: object
    reading: object

    @property
    def name(self) -> str:
        return self.reading.name

    @property
    def motion(self):
        """The accelerometers' account of the drop (:class:`pencli.filter.freefall.DropMotion`)."""
        return self.reading.account


def read_drops(refs: Sequence[str | Path], db: str | Path | None = None,
               calibration: str | Path | None = None) -> list[Drop]:
    """The drops of BlueDrop files (read with the probe's ``calibration`` sheet) or of records of workspace ``db``,
    each read by its instrument's sensor chain (:mod:`pencli.sensors`); a record the chain cannot read is one line
    naming it."""
    return [Drop(record, drop_reading(record)) for record in field_records(refs, "drop", db,
                                                                             {"calibration": calibration})]


def drop_reading(record, **constants):
    """A drop record as its instrument's sensor chain reads it (:class:`pencli.sensors.Reading`): the stitched
    accelerometers (``pencli.sensors.accelerometers``, the bias between the rests as ``bias_at`` in
    ``constants`` says, a ramp by default; a lean at rest read through the tilt channels where the record has
    them); a record the chain cannot read is one line naming it."""
    from pencli.io.bluedrop import ACCELEROMETER_RANGES_G
    from pencli.io.field import drop_name
    from pencli.sensors import chain, missing_channels

    try:
        reader = chain(record.instrument.chain, ranges_g=ACCELEROMETER_RANGES_G, **constants)
    except ValueError as error:
        raise DataError(f"{record.source}: {error}") from None
    missing = missing_channels(reader, record.channels)
    if missing:
        raise DataError(f"{record.source}: no {', '.join(missing)} channel in the calibration")
    try:
        return reader.read(drop_name(record.source), record.time_s, record.channels)
    except ValueError as error:
        raise DataError(f"{record.source}: {error}") from None


def free_fall_probe(penetrator: str | Path, energizing: str | Path):
    """The probe a bed fit needs (:class:`pencli.fit.freefall.FreeFallProbe`) from a cone penetrator file and a
    free-fall launcher file (presets or files)."""
    from pencli.fit.freefall import FreeFallProbe
    from pencli.model.geometry import geometry_of

    p, e = resolve(penetrator, "penetrator"), resolve(energizing, "energizing")
    if p.geometry != "cone":
        raise ParameterError(f"{p.source}: geometry {p.geometry}: a free-fall probe's bed fit needs a cone "
                             f"(geometry: cone)")
    if e.drive != "free_fall":
        raise ParameterError(f"{e.source}: drive {e.drive}: a bed fit needs the fall's fluid, drag and volume "
                             f"(drive: free_fall)")
    cone = geometry_of(p)
    return FreeFallProbe(mass_kg=float(p.values["sprung_mass_kg"]),
                         volume_m3=float(e.values["displaced_volume_l"]) * 1e-3,
                         half_angle_rad=cone.half_angle_rad, shaft_radius_m=cone.shaft_radius_m,
                         drag_coefficient=float(e.values["drag_coefficient"]),
                         added_mass_coefficient=float(e.values.get("added_mass_coefficient", 0.0)),
                         water_density=float(e.values["fluid_density_kg_m3"]),
                         tether_force_n=float(e.values.get("tether_force_n", 0.0)),
                         bed_density=float(e.values.get("bed_density_kg_m3", 0.0)))


def fit_drops(drops: Sequence[Drop], probe, *, nuisances: bool = True):
    """``pen drops fit``: the bed's q = σ + b·z + c·v over the drops (:func:`pencli.fit.freefall.fit_bed`), the
    drag and added-mass coefficients fitted too unless ``nuisances`` is False."""
    from pencli.fit.freefall import fit_bed

    try:
        return fit_bed([d.reading for d in drops], probe, nuisances=nuisances)
    except (ValueError, np.linalg.LinAlgError) as error:
        raise FitError(f"the bed cannot be fitted from these {len(drops)} drops: {error}") from None


def report_drops(drops: Sequence[Drop], out: str | Path, *, pdf: bool = True, probe=None) -> list[Path]:
    """``pen drops report``: one section per drop (its motion and figure) and, with ``probe``, the bed fitted
    across them, as self-contained HTML (and a PDF beside it); returns the files written."""
    from pencli.report.build import write_report
    from pencli.report.sections import drop_section, drop_fit_section

    sections = [drop_section(d) for d in drops]
    if probe is not None:
        sections.insert(0, drop_fit_section(fit_drops(drops, probe), probe))
    title = f"pen drops report: {len(drops)} free-fall drop{'s' if len(drops) != 1 else ''}"
    return write_report(title, sections, out, pdf=pdf)


def simulate_drop_file(out: str | Path, *, height_m: float, bed: tuple[float, ...], bias_g: float = 0.0,
                       seed: int = 0, calibration_out: str | Path | None = None, impact_shift_g: float = 0.0,
                       rest_tilt_deg: float = 0.0, bed_density_kg_m3: float = 0.0):
    """``pen drops simulate``: a drop of the simulated BlueDrop (:mod:`pencli.acquire.freefall`, the
    ``freefall_cone`` probe in ``drop_water``) released ``height_m`` above a bed of q = σ + b·z + c·v (``bed``:
    kPa, kPa/m, kPa·s/m; two more: a layer's depth [m] and step [kPa]) and bulk density ``bed_density_kg_m3``
    (0: it buoys nothing), each accelerometer with a random bias
    within ±``bias_g`` that shifts by ``impact_shift_g`` at the impact, the probe leaning ``rest_tilt_deg`` once
    stopped, written as a BlueDrop record and its calibration sheet (CSV; default ``calibration.csv``
    beside it), both or neither.  Returns (the simulation's truth, the sheet's path, each sensor's bias)."""
    from pencli.acquire.freefall import Bed, Probe, Sensors, simulate_drop
    from pencli.io.atomic import atomic_group
    from pencli.io.bluedrop import ACCELEROMETER_RANGES_G, bluedrop_bytes

    if not 0.0 < height_m <= 100.0:
        raise ParameterError(f"--height-m {height_m:g}: expected a height above the bed in (0, 100] m")
    if any(not math.isfinite(v) or v < 0.0 for v in bed[:3]) or bed[0] <= 0.0:
        raise ParameterError(f"--bed {','.join(f'{v:g}' for v in bed[:3])}: expected σ > 0, b ≥ 0, c ≥ 0 "
                             f"(kPa, kPa/m, kPa·s/m)")
    if len(bed) > 3 and (not bed[3] > 0.0 or not math.isfinite(bed[4]) or bed[0] + bed[1] * bed[3] + bed[4] <= 0.0):
        raise ParameterError(f"--layer {bed[3]:g}:{bed[4]:g}: expected a depth > 0 m and a step that leaves q "
                             f"above 0 below it")
    if not 0.0 <= bias_g <= 0.5:
        raise ParameterError(f"--bias-g {bias_g:g}: expected 0 … 0.5 g")
    if not -0.5 <= impact_shift_g <= 0.5:
        raise ParameterError(f"--impact-shift-g {impact_shift_g:g}: expected −0.5 … 0.5 g")
    if not 0.0 <= rest_tilt_deg <= 60.0:
        raise ParameterError(f"--rest-tilt-deg {rest_tilt_deg:g}: expected 0 … 60°")
    if not 0.0 <= bed_density_kg_m3 <= 3000.0:
        raise ParameterError(f"--bed-density {bed_density_kg_m3:g}: expected 0 (none) … 3000 kg/m³")
    rng = np.random.default_rng(seed)
    sensors = Sensors(bias_g={name: float(rng.uniform(-bias_g, bias_g)) for name in ACCELEROMETER_RANGES_G},
                      impact_shift_g={name: float(impact_shift_g) for name in ACCELEROMETER_RANGES_G})
    try:
        truth = simulate_drop(Probe(), Bed(*bed[:3], *(bed[3:] or (math.inf, 0.0)),
                                          density_kg_m3=bed_density_kg_m3), height_m, sensors=sensors, seed=seed,
                              rest_tilt_deg=rest_tilt_deg,
                              tilt_azimuth_deg=float(rng.uniform(0.0, 360.0)) if rest_tilt_deg else 0.0)
    except ValueError as error:
        raise ParameterError(f"--bed: {error}") from None
    out = Path(out)
    sheet = Path(calibration_out) if calibration_out is not None else out.with_name("calibration.csv")
    text = "channel,offset,scale,unit\n" + "".join(f"{name},{c.offset!r},{c.scale!r},{c.unit}\n"
                                                   for name, c in sensors.calibration.items())
    with atomic_group([out, sheet]) as (tmp_out, tmp_sheet):  # both or neither
        Path(tmp_out).write_bytes(bluedrop_bytes(truth.raw))
        Path(tmp_sheet).write_text(text, encoding="utf-8")
    return truth, sheet, sensors.bias_g


def diagnose_drops(drops: Sequence[Drop], probe, *, false_alarm: float | None = None, shuffles: int | None = None,
                   seed: int = 0):
    """``pen drops diagnose``: each sensor chain's own check on the drops it read
    (:data:`pencli.diagnose.drops.SENSOR_CHECKS`: the accelerometers'), then a layer across the drops
    (:func:`pencli.diagnose.drops.diagnose_drops`), on the bed's pressure with the probe's drag and added mass
    fitted across them first where a chain read the acceleration (a drop whose bias a step at the impact accounts
    for is read with that step)."""
    from pencli.diagnose import FALSE_ALARM, SHUFFLES
    from pencli.diagnose.drops import BedRows, diagnose_drops as diagnose
    from pencli.fit.freefall import bed_pressure

    from pencli.diagnose.drops import SENSOR_CHECKS, with_sensors

    false_alarm = FALSE_ALARM if false_alarm is None else false_alarm
    check = None
    for name, (second, run_check) in SENSOR_CHECKS.items():  # each chain's own check, on the drops it read
        read = [d for d in drops if d.reading.chain == name]
        if read:
            again = {d.name: drop_reading(d.record, **second) for d in read}
            check = run_check({d.name: (d.reading.account, again[d.name].account) for d in read}, false_alarm)
            drops = [replace(d, reading=again[d.name]) if d.name in check.stepped else d for d in drops]
    fit = fit_drops(drops, probe)
    fitted = probe if fit.drag_coefficient is None else \
        replace(probe, drag_coefficient=fit.drag_coefficient, added_mass_coefficient=fit.added_mass_coefficient)
    rows = [BedRows(d.name, *bed_pressure(d.reading, fitted)) for d in drops]
    try:
        bed = diagnose(rows, false_alarm=false_alarm, shuffles=SHUFFLES if shuffles is None else shuffles, seed=seed)
    except ValueError as error:
        raise FitError(f"the drops cannot be diagnosed: {error}") from None
    return bed if check is None else with_sensors(bed, check)
