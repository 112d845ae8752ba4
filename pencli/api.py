"""The Python API of pen; the ``pen`` command maps onto it one to one.

Each function takes plain values (names, paths, numbers), calls into the
pure core and returns result objects.  Nothing here prints.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Sequence

from pencli.errors import ParameterError, PenError
from pencli.model.design import Design, design_from_sets
from pencli.model.dynamics import SimulationResult, simulate
from pencli.params.definitions import Kind
from pencli.params.load import all_presets, load_file, load_preset, preset_names, resolve
from pencli.params.overrides import parse_overrides
from pencli.params.validate import ParameterSet


@dataclass(frozen=True)
class Prediction:
    """A simulated design with the parameter sets it came from."""

    penetrator: ParameterSet
    material: ParameterSet
    energizing: ParameterSet
    design: Design
    result: SimulationResult

    def to_dict(self) -> dict:
        """CONTRACT §5 record plus where the parameters came from."""
        record = self.result.to_dict()
        record["penetrator"] = self.penetrator.name
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
                        overrides: Sequence[str] = (), allow_out_of_range: bool = False
                        ) -> tuple[ParameterSet, ParameterSet, ParameterSet]:
    """Resolve three preset names or files and apply ``--set`` overrides."""
    sets = {
        "penetrator": resolve(penetrator, "penetrator", allow_out_of_range=allow_out_of_range),
        "material": resolve(material, "material", allow_out_of_range=allow_out_of_range),
        "energizing": resolve(energizing, "energizing", allow_out_of_range=allow_out_of_range),
    }
    for kind, updates in parse_overrides(overrides).items():
        sets[kind] = sets[kind].with_values(updates, allow_out_of_range=allow_out_of_range)
    return sets["penetrator"], sets["material"], sets["energizing"]


def predict(penetrator: str | Path, material: str | Path, energizing: str | Path, *,
            overrides: Sequence[str] = (), terms: Iterable[str] | str | None = None,
            speed_at_contact_m_s: float | None = None, allow_out_of_range: bool = False,
            output_rate_hz: float = 50_000.0) -> Prediction:
    """Simulate one design from presets or files (``pen predict``)."""
    p, m, e = load_parameter_sets(penetrator, material, energizing, overrides=overrides,
                                  allow_out_of_range=allow_out_of_range)
    design = design_from_sets(p, m, e)
    result = simulate(design, terms, speed_at_contact_m_s=speed_at_contact_m_s, output_rate_hz=output_rate_hz)
    return Prediction(p, m, e, design, result)


def write_prediction_trajectory(prediction: Prediction, path: str | Path) -> Path:
    """Write the trajectory of a prediction to Parquet with its provenance."""
    from pencli.io.trajectory import write_trajectory  # pyarrow only when asked

    return write_trajectory(prediction.result, path, {"parameters": prediction.provenance()})


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
