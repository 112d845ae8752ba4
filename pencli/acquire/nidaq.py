"""The ``nidaq`` driver: the real rig through NI-DAQmx (``pip install 'pen[daq]'``).

Hardware-timed, one shot:

- an analog-input task on the six gauge channels, finite acquisition at the
  sampling rate, with a digital reference trigger on the release signal so
  the device keeps ``pre_trigger`` samples before it;
- a counter-input task on the string encoder (X4 decoding, counts), clocked
  by the analog task's sample clock so both streams share one time base;
- a digital-output line that releases the latch.

``nidaqmx`` is imported only when the driver is armed, so pen runs without
it; tests replace it with a fake module.
"""

from __future__ import annotations

import importlib
from typing import Iterator

import numpy as np

from pencli.acquire.drivers import RawBlock, ShotSetup
from pencli.acquire.rig import RigConfig
from pencli.errors import RigError

CHUNK_S = 0.1
"""Read the analog stream in blocks of this length, for a live progress display. [s]"""


def _nidaqmx():
    try:
        return importlib.import_module("nidaqmx"), importlib.import_module("nidaqmx.constants")
    except ImportError:
        raise RigError("the nidaq driver needs NI-DAQmx for Python: pip install 'pen[daq]' "
                       "(and NI's driver on the rig computer)") from None


class NidaqRig:
    """Real hardware through ``nidaqmx``."""

    name = "nidaq"

    def __init__(self, rig: RigConfig):
        self.rig = rig
        self._tasks: dict[str, object] = {}
        self._setup: ShotSetup | None = None

    def arm(self, setup: ShotSetup) -> None:
        nidaqmx, const = _nidaqmx()
        self._setup = setup
        device = self.rig["device"]
        try:
            ai = nidaqmx.Task("pen_gauges")
            ai.ai_channels.add_ai_voltage_chan(self.rig["gauge_channels"], min_val=-10.0, max_val=10.0)
            ai.timing.cfg_samp_clk_timing(setup.sampling_rate_hz, sample_mode=const.AcquisitionType.FINITE,
                                          samps_per_chan=setup.total_samples)
            ai.triggers.reference_trigger.cfg_dig_edge_ref_trig(
                self.rig["trigger_source"], pretrigger_samples=setup.pre_trigger_samples,
                trigger_edge=const.Edge.RISING)
            ci = nidaqmx.Task("pen_encoder")
            ci.ci_channels.add_ci_lin_encoder_chan(self.rig["encoder_counter"],
                                                   decoding_type=const.EncoderType.X_4,
                                                   units=const.LengthUnits.TICKS)
            ci.timing.cfg_samp_clk_timing(setup.sampling_rate_hz, source=f"/{device}/ai/SampleClock",
                                          sample_mode=const.AcquisitionType.CONTINUOUS,
                                          samps_per_chan=4 * setup.total_samples)
            do = nidaqmx.Task("pen_fire")
            do.do_channels.add_do_chan(self.rig["fire_line"])
            do.write(False)
        except RigError:
            raise
        except Exception as exc:  # nidaqmx.errors.DaqError and friends
            self.disarm()
            raise RigError(f"arming the rig on {device} failed: {exc}") from None
        self._tasks = {"ai": ai, "ci": ci, "do": do}

    def read_idle(self, n_samples: int) -> RawBlock:
        nidaqmx, const = _nidaqmx()
        if self._setup is None:
            raise RigError("arm the rig before reading it")
        with nidaqmx.Task("pen_tare") as task:
            task.ai_channels.add_ai_voltage_chan(self.rig["gauge_channels"], min_val=-10.0, max_val=10.0)
            task.timing.cfg_samp_clk_timing(self._setup.sampling_rate_hz, sample_mode=const.AcquisitionType.FINITE,
                                            samps_per_chan=n_samples)
            volts = np.asarray(task.read(number_of_samples_per_channel=n_samples, timeout=10.0), dtype=float)
        return RawBlock(np.zeros(n_samples, dtype=np.int64), volts.T)

    def fire(self) -> None:
        if not self._tasks:
            raise RigError("arm the rig before firing")
        try:
            self._tasks["ci"].start()
            self._tasks["ai"].start()
            self._tasks["do"].write(True)
        except Exception as exc:
            raise RigError(f"firing failed: {exc}") from None

    def stream(self) -> Iterator[RawBlock]:
        if self._setup is None or not self._tasks:
            raise RigError("fire before streaming")
        _, const = _nidaqmx()
        total = self._setup.total_samples
        chunk = max(1, int(self._setup.sampling_rate_hz * CHUNK_S))
        ai, ci = self._tasks["ai"], self._tasks["ci"]
        got = 0
        pieces = []
        while got < total:
            n = min(chunk, total - got)
            volts = np.asarray(ai.read(number_of_samples_per_channel=n, timeout=30.0), dtype=float).T
            pieces.append(volts)
            got += n
            yield RawBlock(np.zeros(0, dtype=np.int64), np.zeros((0, 6)))  # progress tick
        counts = np.asarray(ci.read(number_of_samples_per_channel=const.READ_ALL_AVAILABLE), dtype=float)
        if counts.size < total:
            raise RigError(f"the encoder delivered {counts.size} samples for {total} analog samples")
        # the encoder shares the analog sample clock: its last `total` samples line up with the recording
        yield RawBlock(np.round(counts[-total:]).astype(np.int64), np.concatenate(pieces, axis=0))

    def disarm(self) -> None:
        for name in ("do", "ai", "ci"):
            task = self._tasks.get(name)
            if task is None:
                continue
            try:
                if name == "do":
                    task.write(False)
                task.close()
            except Exception:  # closing must not mask the error that brought us here
                pass
        self._tasks = {}
