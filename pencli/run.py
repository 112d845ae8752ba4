"""One run, and a campaign of runs: the object every step of pen passes along.

A :class:`Run` is one recording with its three parameter sets and, once
conditioned, its events and the stages that made it.  The readers and the rig
produce the raw stage; conditioning returns a new :class:`Run` one stage on
(:meth:`Run.tared`, :meth:`Run.inertia_subtracted`), which the store keeps;
fit, diagnose and report read runs back from the store as a :class:`Campaign`.

Columns are SI from the tare on (s, m, N, N·m, m/s, m/s²); the raw stage keeps
the file units of CONTRACT §3 (s, mm, N, N·m).  A run is immutable: every
step makes a new one and leaves the one it was given as it was.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field, replace
from typing import Any, Iterator, Mapping, Sequence, overload

import numpy as np

from pencli.errors import DataError
from pencli.filter.tare import Events
from pencli.model.design import Design, design_from_sets
from pencli.params.validate import ParameterSet

RAW_COLUMNS: tuple[str, ...] = ("time_s", "position_mm", "fx_n", "fy_n", "fz_n", "tx_nm", "ty_nm", "tz_nm")
"""The data columns of CONTRACT §3, in order."""
RAW_STAGE = "raw"
"""The name of the stage a reader or the rig produces."""
MIN_WINDOW_SAMPLES = 10
"""An analysis window of fewer samples than this holds no fit: a run is refused with its id. [–]"""


@dataclass(frozen=True)
class Stage:
    """One step in a run's lineage: what made it, from which stage, with which settings."""

    name: str
    """``raw``, ``tare`` or ``inertia``."""
    command: str
    """The command that made it (``pen tare``)."""
    parameters: Mapping[str, Any] = field(default_factory=dict)
    """The settings it was made with, as the catalog records them."""
    number: int | None = None
    """Its number in the store (None until stored)."""
    parent: int | None = None
    """The number of the stage it was made from (None for the raw stage)."""


@dataclass(frozen=True)
class Run:
    """One recorded run at one stage of its conditioning.

    Attributes
    ----------
    columns
        Column name → float64 array.  Raw: :data:`RAW_COLUMNS` in file units; tared: ``time_s``, ``depth_m`` and
        the tared channels; inertia: also ``velocity_m_s``, ``acceleration_m_s2``, ``force_n`` and
        ``resistance_n`` (SI).
    penetrator, material, energizing
        The run's validated parameter sets.
    info
        ``run.yaml`` content (id, date, operator, notes, tags, and anything else).
    source, source_format
        Where it came from (folder path, or ``acquire:<driver>``) and how (``csv``, ``xlsx``, ``acquire``).
    reader_options
        Options the reader used (column map, units), kept for provenance.
    run_id
        The id the store keeps it under (empty until stored).
    lineage
        The stages from the raw one to this one, oldest first (empty: an unstored raw run).
    events
        Contact, stop and the analysis window (None before the tare).
    """

    columns: Mapping[str, np.ndarray]
    penetrator: ParameterSet
    material: ParameterSet
    energizing: ParameterSet
    info: Mapping[str, Any] = field(default_factory=dict)
    source: str = ""
    source_format: str = ""
    reader_options: Mapping[str, Any] = field(default_factory=dict)
    run_id: str = ""
    lineage: tuple[Stage, ...] = ()
    events: Events | None = None

    # ------------------------------------------------------------------ what it is
    @property
    def name(self) -> str:
        """The run id, else the id its ``run.yaml`` asks for, else its source."""
        return self.run_id or str(self.info.get("id") or self.source or "run")

    @property
    def stage(self) -> str:
        """The stage these columns are (``raw`` for an unstored run)."""
        return self.lineage[-1].name if self.lineage else RAW_STAGE

    @property
    def stage_parameters(self) -> Mapping[str, Any]:
        """The settings of the latest stage."""
        return self.lineage[-1].parameters if self.lineage else {}

    @property
    def n_samples(self) -> int:
        """Number of rows."""
        return int(len(self.columns["time_s"]))

    @property
    def sampling_rate_hz(self) -> float:
        """(n − 1)/(t_last − t_first), robust to rounded time stamps (CONTRACT §3). [Hz]"""
        t = self.columns["time_s"]
        return float((t.size - 1) / (t[-1] - t[0]))

    @property
    def duration_s(self) -> float:
        """t_last − t_first. [s]"""
        t = self.columns["time_s"]
        return float(t[-1] - t[0])

    def parameter_sets(self) -> tuple[ParameterSet, ParameterSet, ParameterSet]:
        """(penetrator, material, energizing)."""
        return self.penetrator, self.material, self.energizing

    @functools.cached_property
    def geometry(self):
        """The penetrator's geometry (:func:`pencli.model.geometry.geometry_of`): the blade unless its file names
        another."""
        from pencli.model.geometry import geometry_of

        return geometry_of(self.penetrator)

    @functools.cached_property
    def design(self) -> Design:
        """The blade, material properties and launcher of the run (SI; coefficients as the material file gives)."""
        return design_from_sets(self.penetrator, self.material, self.energizing)

    def column(self, name: str) -> np.ndarray:
        """One column, or one line saying which stage lacks it and what makes it."""
        try:
            return self.columns[name]
        except KeyError:
            need = {"resistance_n": "pen subtract-inertia", "velocity_m_s": "pen subtract-inertia",
                    "depth_m": "pen tare"}.get(name, "")
            hint = f"; run `{need} {self.name}` first" if need else ""
            raise DataError(f"run '{self.name}': its {self.stage} stage has no column '{name}'{hint}") from None

    # ------------------------------------------------------------------ the window
    def require_events(self) -> Events:
        """The run's events, or one line saying the run is not tared."""
        if self.events is None:
            raise DataError(f"run '{self.name}': its {self.stage} stage has no events; run `pen tare {self.name}` "
                            f"first")
        return self.events

    @property
    def window(self) -> np.ndarray:
        """The analysis window of the tare (``window_start_s ≤ t ≤ window_end_s``), as a mask."""
        events = self.require_events()
        t = self.columns["time_s"]
        return (t >= events.window_start_s) & (t <= events.window_end_s)

    def in_window(self, name: str) -> np.ndarray:
        """One column over the analysis window."""
        return self.column(name)[self.window]

    def reading(self):
        """The run as its sensor chain read it (:class:`pencli.sensors.Reading`, from the inertia stage's columns
        that :meth:`inertia_subtracted` wrote): depth below the surface, speed, acceleration, resistance, contact
        and stop at the tare's events; a stage without them is one line saying what to run."""
        from pencli.sensors.load_cell import stored

        events = self.require_events()
        return stored(self.name, self.column("time_s"), self.column("depth_m"), self.column("velocity_m_s"),
                      self.columns.get("acceleration_m_s2"), self.column("resistance_n"), events,
                      force_n=self.columns.get("force_n"))

    # ------------------------------------------------------------------ new stages
    def with_stage(self, name: str, columns: Mapping[str, np.ndarray], *, command: str,
                   parameters: Mapping[str, Any], events: Events | None = None) -> Run:
        """This run one stage on: new columns (and events), the step recorded in the lineage."""
        parent = self.lineage[-1].number if self.lineage else None
        step = Stage(name, command, dict(parameters), None, parent)
        return replace(self, columns=dict(columns), lineage=(*self.lineage, step),
                       events=events if events is not None else self.events)

    def tared(self, window_ms: tuple[float, float] | None = None) -> Run:
        """``pen tare``: offsets from the pre-trigger span, depth from the stand-off, events (needs the raw stage)."""
        from pencli.filter.tare import tare

        if self.stage != RAW_STAGE:
            raise DataError(f"run '{self.name}': the tare starts from the raw stage, not the {self.stage} stage")
        tared = tare(self.columns, self.energizing.get("surface_offset_mm"),
                     self.penetrator.get("penetration_depth_mm"), window_ms=window_ms, where=self.name)
        columns = {"time_s": tared.time_s, "depth_m": tared.depth_m,
                   **{name: np.asarray(values) for name, values in tared.forces.items()}}
        return self.with_stage("tare", columns, command="pen tare", events=tared.events,
                               parameters={"offsets": tared.offsets, "events": tared.events.to_dict(),
                                           "window_ms": list(window_ms) if window_ms else None})

    def inertia_subtracted(self, method: str | None = None, *, use_flight_mass: bool = False):
        """``pen subtract-inertia``: v and a from the encoder, R = F − m_lc·a (needs the tare stage).

        ``method``: the derivative method (default: :func:`~pencli.filter.inertia.method_for` the run, which
        joins the derivatives where the tip passes a corner of its geometry's resistance).
        Returns ``(run, estimate)``: the run one stage on, and the load-cell mass the free flight reads
        (:class:`~pencli.filter.inertia.MassEstimate`, None when the flight is too short to tell).
        """
        from pencli.filter.inertia import corner_times
        from pencli.model.geometry import corner_depths_m
        from pencli.sensors import chain

        if self.stage != "tare":
            raise DataError(f"run '{self.name}': subtract-inertia starts from the tare stage, not the {self.stage} "
                            f"stage; run `pen tare {self.name}` first")
        col = self.columns
        events = self.require_events()
        events = replace(events, corners_s=corner_times(col["time_s"], col["depth_m"], events,
                                                        corner_depths_m(self.geometry, self.design)))
        m_lc = float(self.penetrator.get("load_cell_mass_kg"))
        reading = chain("encoder_load_cell", load_cell_mass_kg=m_lc, events=events, method=method,
                        use_flight_mass=use_flight_mass).read(self.name, col["time_s"], col)
        kin = reading.account
        columns = {"time_s": col["time_s"], "depth_m": col["depth_m"],
                   "velocity_m_s": kin.velocity_m_s, "acceleration_m_s2": kin.acceleration_m_s2,
                   "force_n": col["fz_n"], "resistance_n": kin.resistance_n,
                   **{n: col[n] for n in ("fx_n", "fy_n", "tx_nm", "ty_nm", "tz_nm")}}
        estimate = kin.mass_estimate.to_dict() if kin.mass_estimate else None
        parameters = {"method": kin.method, "load_cell_mass_kg": kin.mass_used_kg, "encoder_step_m": kin.encoder_step_m,
                      "mass_from": "flight" if use_flight_mass else "file", "mass_estimate": estimate,
                      "events": events.to_dict()}
        return self.with_stage("inertia", columns, command="pen subtract-inertia", parameters=parameters,
                               events=events), \
            kin.mass_estimate


@dataclass(frozen=True)
class Campaign(Sequence[Run]):
    """Runs analysed together (a fit's or a diagnosis's input), in the order given."""

    runs: tuple[Run, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "runs", tuple(self.runs))

    @overload
    def __getitem__(self, index: int) -> Run: ...

    @overload
    def __getitem__(self, index: slice) -> Campaign: ...

    def __getitem__(self, index):
        if isinstance(index, slice):
            return Campaign(self.runs[index])
        return self.runs[index]

    def __len__(self) -> int:
        return len(self.runs)

    def __iter__(self) -> Iterator[Run]:
        return iter(self.runs)

    @property
    def ids(self) -> tuple[str, ...]:
        """The runs' ids, in order."""
        return tuple(r.run_id for r in self.runs)

    @property
    def materials(self) -> tuple[str, ...]:
        """The material names the runs were recorded in, sorted, each once."""
        return tuple(sorted({r.material.name for r in self.runs}))

    def by_id(self, run_id: str) -> Run:
        """The run stored under ``run_id``."""
        for r in self.runs:
            if r.run_id == run_id:
                return r
        raise KeyError(run_id)

