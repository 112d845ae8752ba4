"""The rig file: which driver, and for the simulated rig its sensors and its hidden world.

A rig file is YAML with ``kind: rig``.  Every key is defined once in
:data:`RIG_KEYS` (meaning, unit, default); unknown keys are an error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, Mapping

from pencli.acquire.truth import validate_effects
from pencli.errors import ParameterError
from pencli.params.load import read_yaml

RIG_KEYS: dict[str, tuple[str, Any]] = {
    "driver": ("rig driver: sim or nidaq", "sim"),
    "sampling_rate_hz": ("sampling rate of every channel [Hz]", 30000.0),
    "force_noise_n": ("white noise of each force channel, standard deviation [N]", 2.0),
    "torque_noise_nm": ("white noise of each torque channel, standard deviation [N·m]", 0.01),
    "correlated_noise_n": ("low-frequency (AR(1)) force noise, standard deviation [N]", 0.0),
    "correlated_noise_ms": ("correlation time of that noise [ms]", 2.0),
    "anti_alias_hz": ("corner of the force and torque channels' anti-alias low-pass, acting on signal and noise "
                      "alike (0: none): its -3 dB point (Butterworth, Bessel) or the end of its ripple band "
                      "(Chebyshev) [Hz]", 0.0),
    "anti_alias_kind": ("that low-pass's kind: butterworth, bessel or chebyshev (type I, its gain at 0 Hz "
                        "scaled to 1) [–]", "butterworth"),
    "anti_alias_order": ("that low-pass's order [–]", 4),
    "anti_alias_ripple_db": ("a chebyshev low-pass's pass-band ripple, peak to trough [dB]", 0.5),
    "converter_noise_n": ("white noise each force channel's converter adds after the anti-alias filter "
                          "(its own noise and quantisation), standard deviation [N]", 0.0),
    "resonant_noise_n": ("narrow-band force noise, as a floor vibration or a pump that the load cell picks up: "
                         "white noise through a damped mode, standard deviation [N]", 0.0),
    "resonant_noise_hz": ("that mode's frequency [Hz]", 500.0),
    "resonant_noise_damping": ("that mode's damping ratio (its band is about 2 × damping × frequency wide) [–]",
                               0.05),
    "pink_noise_n": ("flicker (1/f) force noise, as the gauges' bridge and amplifier make: power falling as the "
                     "inverse of frequency down to the recording's length, standard deviation over the whole "
                     "recording [N]", 0.0),
    "force_offsets_n": ("untared offsets of fx, fy, fz [N]", [-13.2, -9.3, -0.8]),
    "torque_offsets_nm": ("untared offsets of tx, ty, tz [N·m]", [0.07, 0.04, 0.044]),
    "lateral_fraction": ("side force as a fraction of the axial resistance [–]", 0.02),
    "true_material": ("preset or file of the true material (default: the run's material)", None),
    "strength_scale": ("the block's true strength over the recorded strength (block scatter) [–]", 1.0),
    "surface_offset_error_mm": ("true stand-off minus the energizing file's (the block's surface sits lower "
                                "when positive) [mm]", 0.0),
    "encoder_edge_errors": ("where a quadrature encoder's four edges of each cycle of four counts truly lie, off "
                            "their nominal places, as fractions of a count (its channels' duty-cycle and phase "
                            "errors; each within ±0.5) [–]", [0.0, 0.0, 0.0, 0.0]),
    "encoder_phase": ("where the blade rests within one encoder count, as a fraction of a count: the counter "
                      "is zeroed there and steps when the motion crosses count edges (0: the rest position "
                      "is at the middle of a count) [–]", 0.0),
    "position_noise_um": ("the encoder's position error before it is quantised (string vibration, scale "
                          "interpolation error), standard deviation [µm]", 0.0),
    "position_noise_ms": ("correlation time of that error (0: white) [ms]", 0.0),
    "effects": ("hidden effects of the true world (CONTRACT §4 names) with parameters", []),
    "seed": ("seed of the sensor noise (default: fresh each shot)", None),
    "device": ("nidaq: device name", "Dev1"),
    "gauge_channels": ("nidaq: the six gauge analog inputs", "Dev1/ai0:5"),
    "encoder_counter": ("nidaq: counter of the string encoder", "Dev1/ctr0"),
    "fire_line": ("nidaq: digital line that releases the latch", "Dev1/port0/line0"),
    "trigger_source": ("nidaq: terminal carrying the release signal (reference trigger)", "/Dev1/PFI0"),
}
"""Every rig-file key: (meaning with unit, default)."""

DRIVER_NAMES = ("sim", "nidaq")
ANTI_ALIAS_KINDS = ("butterworth", "bessel", "chebyshev")


@dataclass(frozen=True)
class RigConfig:
    """A validated rig file."""

    name: str
    values: Mapping[str, Any] = field(default_factory=dict)
    source: str = "<default>"

    def __getitem__(self, key: str) -> Any:
        return self.values[key]

    @property
    def effects(self):
        return validate_effects(self.values["effects"], self.source)


def _number(where: str, key: str, value: Any, *, positive: bool = False, minimum: float | None = None) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ParameterError(f"{where}: key '{key}': got {value!r}; expected a number")
    if positive and value <= 0:
        raise ParameterError(f"{where}: key '{key}': got {value!r}; must be > 0")
    if minimum is not None and value < minimum:
        raise ParameterError(f"{where}: key '{key}': got {value!r}; must be >= {minimum:g}")
    return float(value)


def validate_rig(data: Any, where: str) -> RigConfig:
    """Validate a rig mapping; fill defaults."""
    if not isinstance(data, Mapping) or data.get("kind") != "rig":
        raise ParameterError(f"{where}: expected a mapping with kind: rig")
    name = data.get("name")
    if not isinstance(name, str) or not name:
        raise ParameterError(f"{where}: key 'name': expected a non-empty string")
    values = {key: default for key, (_, default) in RIG_KEYS.items()}
    for key, value in data.items():
        if key in ("kind", "name", "notes"):
            continue
        if key not in RIG_KEYS:
            raise ParameterError(f"{where}: unknown key '{key}'; valid rig keys: {', '.join(RIG_KEYS)}")
        values[key] = value
    if values["driver"] not in DRIVER_NAMES:
        raise ParameterError(f"{where}: key 'driver': got {values['driver']!r}; expected one of "
                             f"{', '.join(DRIVER_NAMES)}")
    _number(where, "sampling_rate_hz", values["sampling_rate_hz"], minimum=1000)
    for key in ("force_noise_n", "torque_noise_nm", "correlated_noise_n", "lateral_fraction", "converter_noise_n"):
        _number(where, key, values[key], minimum=0)
    _number(where, "correlated_noise_ms", values["correlated_noise_ms"], positive=True)
    _number(where, "resonant_noise_n", values["resonant_noise_n"], minimum=0)
    _number(where, "pink_noise_n", values["pink_noise_n"], minimum=0)
    if _number(where, "resonant_noise_hz", values["resonant_noise_hz"], positive=True) \
            >= 0.5 * float(values["sampling_rate_hz"]):
        raise ParameterError(f"{where}: key 'resonant_noise_hz': got {values['resonant_noise_hz']!r}; expected a "
                             f"frequency below half the sampling rate ({0.5 * float(values['sampling_rate_hz']):g} Hz)")
    if _number(where, "resonant_noise_damping", values["resonant_noise_damping"], positive=True) >= 1:
        raise ParameterError(f"{where}: key 'resonant_noise_damping': got {values['resonant_noise_damping']!r}; "
                             f"expected a damping ratio between 0 and 1")
    _number(where, "position_noise_um", values["position_noise_um"], minimum=0)
    _number(where, "position_noise_ms", values["position_noise_ms"], minimum=0)
    corner = _number(where, "anti_alias_hz", values["anti_alias_hz"], minimum=0)
    if corner >= 0.5 * float(values["sampling_rate_hz"]):
        raise ParameterError(f"{where}: key 'anti_alias_hz': got {values['anti_alias_hz']!r}; expected 0 (none) or "
                             f"a corner below half the sampling rate ({0.5 * float(values['sampling_rate_hz']):g} Hz)")
    if values["anti_alias_kind"] not in ANTI_ALIAS_KINDS:
        raise ParameterError(f"{where}: key 'anti_alias_kind': got {values['anti_alias_kind']!r}; expected one of "
                             f"{', '.join(ANTI_ALIAS_KINDS)}")
    order = values["anti_alias_order"]
    if isinstance(order, bool) or not isinstance(order, int) or not 1 <= order <= 10:
        raise ParameterError(f"{where}: key 'anti_alias_order': got {order!r}; expected a whole number from 1 to 10")
    _number(where, "anti_alias_ripple_db", values["anti_alias_ripple_db"], positive=True)
    _number(where, "strength_scale", values["strength_scale"], positive=True)
    _number(where, "surface_offset_error_mm", values["surface_offset_error_mm"])
    if not 0.0 <= _number(where, "encoder_phase", values["encoder_phase"]) < 1.0:
        raise ParameterError(f"{where}: key 'encoder_phase': got {values['encoder_phase']!r}; expected a "
                             f"fraction of a count in [0, 1)")
    edges = values["encoder_edge_errors"]
    if not isinstance(edges, (list, tuple)) or len(edges) != 4 or not all(
            -0.5 < _number(where, "encoder_edge_errors", e) < 0.5 for e in edges):
        raise ParameterError(f"{where}: key 'encoder_edge_errors': got {edges!r}; expected a list of 4 fractions "
                             f"of a count, each between -0.5 and 0.5")
    for key in ("force_offsets_n", "torque_offsets_nm"):
        offsets = values[key]
        if not isinstance(offsets, (list, tuple)) or len(offsets) != 3:
            raise ParameterError(f"{where}: key '{key}': expected a list of 3 numbers")
        for value in offsets:
            _number(where, key, value)
    if values["seed"] is not None and (isinstance(values["seed"], bool) or not isinstance(values["seed"], int)):
        raise ParameterError(f"{where}: key 'seed': got {values['seed']!r}; expected a whole number")
    validate_effects(values["effects"], where)
    return RigConfig(name, values, where)


def load_rig(ref: str | Path | Mapping[str, Any] | None) -> RigConfig:
    """A rig file path, a rig mapping (recorded as ``inline``), or ``None`` for the bundled default simulated rig
    (recorded as ``bundled:sim_default.yaml``)."""
    if isinstance(ref, Mapping):
        return rig_from_mapping(ref, "inline")
    if ref is None:
        path = Path(str(resources.files("pencli.acquire.data").joinpath("sim_default.yaml")))
        return validate_rig(read_yaml(path), f"bundled:{path.name}")
    path = Path(ref)
    if not path.is_file():
        raise ParameterError(f"{path}: no such rig file")
    return validate_rig(read_yaml(path), str(path))


def rig_from_mapping(data: Mapping[str, Any], where: str = "<rig>") -> RigConfig:
    """A rig from an in-memory mapping (``kind``/``name`` filled in if absent)."""
    full = {"kind": "rig", "name": "inline", **dict(data)}
    return validate_rig(full, where)
