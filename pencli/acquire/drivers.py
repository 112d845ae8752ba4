"""The rig-driver interface and its registry.

A driver arms the rig for one shot, reads idle samples (for the tare),
fires, streams the finite recording (starting ``pre_trigger`` samples before
the release) and disarms.  It returns raw readings — encoder counts and the
six gauge voltages — which :mod:`pencli.acquire.session` calibrates.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterator, Protocol

import numpy as np

from pencli.errors import RigError
from pencli.params.validate import ParameterSet


@dataclass(frozen=True)
class ShotSetup:
    """What the operator asked for."""

    sampling_rate_hz: float
    """Rate of every channel. [Hz]"""
    duration_s: float
    """Length of the finite recording, pre-trigger included. [s]"""
    pre_trigger_s: float
    """Kept before the release. [s]"""
    penetrator: ParameterSet
    material: ParameterSet
    energizing: ParameterSet

    @property
    def total_samples(self) -> int:
        return int(round(self.duration_s * self.sampling_rate_hz))

    @property
    def pre_trigger_samples(self) -> int:
        return int(round(self.pre_trigger_s * self.sampling_rate_hz))


@dataclass(frozen=True)
class RawBlock:
    """A block of raw samples: encoder counts (n,) and gauge volts (n, 6)."""

    counts: np.ndarray
    volts: np.ndarray

    def __len__(self) -> int:
        return int(self.counts.size)


class RigDriver(Protocol):
    """What every rig driver provides."""

    name: str

    def arm(self, setup: ShotSetup) -> None: ...

    def read_idle(self, n_samples: int) -> RawBlock: ...

    def fire(self) -> None: ...

    def stream(self) -> Iterator[RawBlock]: ...

    def disarm(self) -> None: ...


def _sim(rig, position_cal, force_cal):
    from pencli.acquire.sim import SimRig

    return SimRig(rig, position_cal, force_cal)


def _nidaq(rig, position_cal, force_cal):
    from pencli.acquire.nidaq import NidaqRig

    return NidaqRig(rig)


DRIVERS: dict[str, Callable] = {"sim": _sim, "nidaq": _nidaq}
"""Rig drivers by name: each takes (rig config, position calibration, force calibration)."""


def make_driver(name: str, rig, position_cal, force_cal) -> RigDriver:
    """Instantiate the driver called ``name``."""
    factory = DRIVERS.get(name)
    if factory is None:
        raise RigError(f"unknown rig driver {name!r}; drivers: {', '.join(DRIVERS)}")
    return factory(rig, position_cal, force_cal)
