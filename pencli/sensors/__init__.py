r"""Sensor chains: what an instrument recorded, read as the penetrator's motion and the force on it.

A chain's observation equations tie its channels to the penetrator's state (travel x, speed v, acceleration
a) and to the force the material puts on it, R:

- ``encoder_load_cell`` (the spring rig): x̃ = x and, tared, F̃ = R + m_lc·a; read as v and a from x̃ and
  R = F̃ − m_lc·a.
- ``accelerometers`` (a free-fall probe): f̃ᵢ = (g − a)/g + biasᵢ(t) within each one's range; read as a, v and x
  integrated from the release; R then comes from the drive's equation of motion.
- ``cone_tip`` (a cone pushed at a constant rate): q̃c = qt − (1 − a_n)·u₂, f̃s, ũ₂, z̃ = x; read as qt, fs, u₂
  [kPa], v from the logger's rate or z̃ and the clock.
- ``rod_force`` (a total sounding): F̃ = R on the bit and rods together, z̃ = x.
- ``tip_force`` (a SnowMicroPen): F̃ = R on the tip alone, at a fixed step of the motor's travel.

The fits and diagnoses read a :class:`Reading`, whichever chain made it: the rows of the motion, the
acceleration where the chain measures it, the force where it measures one (so that a drop read by a tip load
cell needs no equation of motion), the pressures where it measures them.  A new chain is one module with one
class and one :func:`register_chain` call; :data:`CHAINS` holds pen's own.

Pure: numpy only; no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping, Protocol

import numpy as np


@dataclass(frozen=True)
class Reading:
    """One record as its chain reads it: the penetrator's motion (SI, travel and acceleration positive down), the
    force on it and the pressures, where the chain measures them, and where the motion starts, meets the
    material and stops."""

    name: str
    chain: str
    """The name of the chain that read it (:data:`CHAINS`)."""
    travel_m: np.ndarray
    """The tip's travel, positive down, from the chain's origin: the surface (the rig, a sounding) or the release
    (a drop). [m]"""
    speed_m_s: np.ndarray
    """Speed, positive down. [m/s]"""
    time_s: np.ndarray | None = None
    """Time of each row (None: a record without a clock). [s]"""
    accel_m_s2: np.ndarray | None = None
    """Acceleration, positive down (None: the chain does not measure it). [m/s²]"""
    force_n: np.ndarray | None = None
    """The material's force on the penetrator, along its axis (None: the chain does not measure it; the drive's
    equation of motion gives it from the acceleration). [N]"""
    pressures_kpa: Mapping[str, np.ndarray] = field(default_factory=dict)
    """Pressures on the penetrator by name (``qt``, ``qc``, ``fs``, ``u2``). [kPa]"""
    channels: Mapping[str, np.ndarray] = field(default_factory=dict)
    """Channels as measured that the fit and diagnosis read besides (the rig's tared load-cell force ``force_n``,
    which its chain effects act on). [units in the name]"""
    start: int = 0
    """The first row of the motion (the release)."""
    contact: int = 0
    """The first row in the material."""
    stop: int = -1
    """The last row of the penetration (−1: the record's last)."""
    surface_m: float = 0.0
    """Travel at which the tip meets the material (the rig's and a sounding's travel count from it: 0). [m]"""
    account: Any = None
    """The chain's own account of the record (for its checks: an accelerometer drop's biases and rests)."""

    @property
    def penetration(self) -> slice:
        """The rows from the contact to the stop."""
        return slice(self.contact, self.stop + 1 if self.stop >= 0 else None)

    def depth_m(self) -> np.ndarray:
        """Depth in the material over :attr:`penetration`: travel less :attr:`surface_m`. [m]"""
        return self.travel_m[self.penetration] - self.surface_m


class SensorChain(Protocol):
    """The seam: a chain reads a record's channels (pen's names, units in the suffix) into a :class:`Reading`."""

    name: str
    channels: tuple[str, ...]
    """Channels a record must have for the chain to read it."""

    def read(self, name: str, time_s: np.ndarray | None, channels: Mapping[str, np.ndarray]) -> Reading:
        """The record ``name``'s reading; a record the chain cannot read raises ValueError saying why."""


CHAINS: dict[str, type] = {}
"""Every sensor chain by the name an instrument gives it; filled by :func:`register_chain` (pen's own at the
end of this module)."""


@dataclass(frozen=True)
class ChainRegistration:
    """What :func:`register_chain` added; :meth:`undo` takes it out (also as a context manager)."""

    name: str

    def undo(self) -> None:
        CHAINS.pop(self.name, None)

    def __enter__(self) -> "ChainRegistration":
        return self

    def __exit__(self, *exc) -> None:
        self.undo()


def register_chain(cls: type) -> ChainRegistration:
    """Make a chain available by its ``name``: ``cls`` builds a :class:`SensorChain` from the instrument's known
    constants (an accelerometer's ranges, a cone's net area ratio, a load cell's mass below it)."""
    if cls.name in CHAINS:
        raise ValueError(f"a sensor chain named {cls.name!r} is already registered")
    CHAINS[cls.name] = cls
    return ChainRegistration(cls.name)


def chain(name: str, **constants) -> SensorChain:
    """The chain registered as ``name``, built with the instrument's ``constants``; an unknown name is a
    ValueError listing the known ones."""
    if name not in CHAINS:
        raise ValueError(f"sensor chain {name!r}: expected one of {', '.join(sorted(CHAINS))}")
    return CHAINS[name](**constants)


def missing_channels(chain_: SensorChain, channels: Mapping[str, Any]) -> list[str]:
    """The chain's channels a record lacks."""
    return [c for c in chain_.channels if c not in channels]


def _register_own() -> None:
    from pencli.sensors.accelerometers import StitchedAccelerometers
    from pencli.sensors.cone_tip import ConeTip
    from pencli.sensors.load_cell import EncoderLoadCell
    from pencli.sensors.rod_force import RodForce
    from pencli.sensors.tip_force import TipForce

    for cls in (EncoderLoadCell, StitchedAccelerometers, ConeTip, RodForce, TipForce):
        register_chain(cls)


_register_own()

__all__ = ["CHAINS", "ChainRegistration", "Reading", "SensorChain", "chain", "missing_channels", "register_chain"]
