"""A stand-in for the ``nidaqmx`` package: records every call, serves canned samples.

It mimics only the parts of the real API the nidaq driver uses (Task,
ai/ci/do channel collections, timing, reference trigger, read/write,
constants), so the driver's calls are checked without hardware.
"""

from __future__ import annotations

import enum
import types

import numpy as np

CALLS: list[tuple] = []
SCRIPT: dict = {}


class _Collection:
    def __init__(self, task, kind):
        self.task, self.kind = task, kind

    def __getattr__(self, name):
        def call(*args, **kwargs):
            CALLS.append((self.task.name, f"{self.kind}.{name}", args, kwargs))
            self.task.channels.append((name, args, kwargs))
        return call


class _Namespace:
    def __init__(self, task, prefix):
        self.task, self.prefix = task, prefix

    def __getattr__(self, name):
        if name in ("reference_trigger", "start_trigger"):
            return _Namespace(self.task, f"{self.prefix}.{name}")

        def call(*args, **kwargs):
            CALLS.append((self.task.name, f"{self.prefix}.{name}", args, kwargs))
        return call


class Task:
    def __init__(self, name=""):
        self.name = name
        self.channels = []
        self.ai_channels = _Collection(self, "ai_channels")
        self.ci_channels = _Collection(self, "ci_channels")
        self.do_channels = _Collection(self, "do_channels")
        self.timing = _Namespace(self, "timing")
        self.triggers = _Namespace(self, "triggers")
        self._cursor = 0
        CALLS.append((name, "Task", (), {}))

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def start(self):
        CALLS.append((self.name, "start", (), {}))

    def write(self, value):
        CALLS.append((self.name, "write", (value,), {}))

    def close(self):
        CALLS.append((self.name, "close", (), {}))

    def read(self, number_of_samples_per_channel=1, timeout=10.0):
        CALLS.append((self.name, "read", (number_of_samples_per_channel,), {"timeout": timeout}))
        if self.name == "pen_tare":
            return SCRIPT["idle_volts"][:number_of_samples_per_channel].T.tolist()
        if self.name == "pen_gauges":
            volts = SCRIPT["volts"][self._cursor:self._cursor + number_of_samples_per_channel]
            self._cursor += number_of_samples_per_channel
            return volts.T.tolist()
        if self.name == "pen_encoder":
            return SCRIPT["counts"].astype(float).tolist()
        raise AssertionError(self.name)


class AcquisitionType(enum.Enum):
    FINITE = 1
    CONTINUOUS = 2


class Edge(enum.Enum):
    RISING = 1
    FALLING = 2


class EncoderType(enum.Enum):
    X_1 = 1
    X_2 = 2
    X_4 = 4


class LengthUnits(enum.Enum):
    METERS = 1
    TICKS = 2


constants = types.SimpleNamespace(AcquisitionType=AcquisitionType, Edge=Edge, EncoderType=EncoderType,
                                  LengthUnits=LengthUnits, READ_ALL_AVAILABLE=-1)


def install(monkeypatch, counts: np.ndarray, volts: np.ndarray, idle_volts: np.ndarray) -> None:
    """Put this fake in sys.modules as ``nidaqmx`` and ``nidaqmx.constants``."""
    CALLS.clear()
    SCRIPT.update(counts=counts, volts=volts, idle_volts=idle_volts)
    module = types.ModuleType("nidaqmx")
    module.Task = Task
    const = types.ModuleType("nidaqmx.constants")
    for name, value in vars(constants).items():
        setattr(const, name, value)
    module.constants = const
    monkeypatch.setitem(__import__("sys").modules, "nidaqmx", module)
    monkeypatch.setitem(__import__("sys").modules, "nidaqmx.constants", const)
