r"""What the data would look like if the reference model were right: parametric null replicates of a campaign.

Each replicate re-measures every run through the campaign's *own* sensor
chain, as read from its data:

- the true motion is the run's smoothed trajectory (the spline through its
  encoder record) in flight and, from the contact on, the baseline's own
  dynamics (whose acceleration jumps at contact and stop as the data's do,
  which the encoder cannot resolve and the spline does not reproduce), each
  replicate's contact drawn within the sampling interval before the sample
  at which the run's force shows it, as the data's lies;
- the encoder quantises it to the record's own step, each run at its own
  phase as read from its record (:func:`encoder_phase`) shifted by one
  random amount per replicate, after adding the position error the record
  shows beyond its quantisation (:func:`position_noise`), and the same
  derivative method re-derives velocity and acceleration from it, so
  derivative errors are the pipeline's own (the chain's observation
  equations: :func:`pencli.sensors.load_cell.encoder_reading` and
  :func:`~pencli.sensors.load_cell.load_cell_reading`);
- the force channel adds noise of the colour and level measured on the
  pre-trigger span (its spectrum, :class:`NoiseModel`; each replicate with
  a spectrum that measurement's own error allows, :meth:`NoiseModel.spectra`), and where that
  spectrum shows an anti-alias low-pass (:func:`fit_anti_alias`), the
  replicate's force passes through that filter as the data's did, its
  corner drawn within that reading's error (:func:`corner_spreads`);
- the resistance is the baseline fit's, so a replicate holds no effect.

Replicates go through the same inertia subtraction (R = F − m_lc·a) and
contact-speed measurement as the data.  The basis (measured x, v) is kept
from the data: the replicates perturb what is measured, not the regressors
(their speed errors are second order in the Eq. 9 columns).  The
acceleration is the exception: its error enters the resistance itself
(−m_lc × error), so a column of the *data's* acceleration correlates with
the data's residual and with no replicate's.  Each replicate therefore also
returns the acceleration it measured, and every column built from the
acceleration (the load-cell mass column, a sensor lag's offset) is built
for each replicate from its own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np
from numba import njit

from pencli.errors import DataError
from pencli.filter.derivatives import derivatives, smooth_motion, spline_columns
from pencli.filter.inertia import motion_breaks, motion_joins
from pencli.filter.tare import Events, detect_events
from pencli.sensors.load_cell import encoder_reading, load_cell_reading

MIN_SPECTRUM_SAMPLES = 64
"""Fewer samples than this give a spectrum of too few bins to read a colour from: the noise is taken as white."""
NYQUIST = 0.5
"""The Nyquist frequency in cycles per sample."""
MIN_ROLL_OFF_BINS = 16
"""A low-pass is read from at least this many spectrum bins above its search's lower edge (fewer fit anything)."""
PLAIN_PARAMETERS, LINE_PARAMETERS = 4, 7
"""Parameters of the plain noise spectrum (white, coloured part) and of the same with a narrow band, for BIC."""
HALF_COUNT = 0.5
"""A quantised reading disagrees with the record when it lies more than half an encoder count from it."""
MIN_ROUGHNESS_SAMPLES = 32
"""The position noise is read from the flight's third differences only over at least this many samples."""
MIN_GEV_SAMPLES = 10
"""Fewer scores than this leave a generalised extreme-value law's three moments unread: the Gumbel stands."""
GEV_SHAPE_ROUND_OFF = 1e-9
"""Below this the GEV's shape is 0 in floating point: the moment ratio takes its limit, log 3 / log 2."""
GUMBEL_SHAPE = 1e-6
"""A GEV whose shape is within this of 0 is a Gumbel: its quantile is taken from the Gumbel's closed form."""



@dataclass(frozen=True)
class NoiseModel:
    """Stationary Gaussian force noise of a measured spectrum: the one-sided power spectral density ``psd``
    [N² per cycle/sample] at frequencies ``frequency`` [cycles/sample, 0 to 0.5], read from the pre-trigger
    span by Welch's method (:func:`fit_noise`), and synthesised by shaping white noise in the frequency domain.

    An autoregressive model of order 12 or less, fitted by least squares, had this role before: it predicts
    one sample ahead well and misses the low frequencies of noise correlated over milliseconds by 20–40 %
    (white plus AR(1) noise of 1–2 ms at 30–60 kHz), the frequencies that the slowly varying columns (a
    load-cell mass error, a drift, a depth profile) pick up, so its replicates had too narrow a null there.
    """

    frequency: np.ndarray
    psd: np.ndarray
    level_n: float
    """Standard deviation of the noise itself. [N]"""
    samples: int = 0
    """Length of the record the spectrum was read from (0: not read from a record, taken as exact). [samples]"""

    @classmethod
    def white(cls, level_n: float) -> "NoiseModel":
        """White noise of standard deviation ``level_n`` [N]."""
        return cls(np.array([0.0, 0.5]), np.full(2, 2.0 * level_n ** 2), float(level_n))

    def simulate(self, n: int, rng: np.random.Generator, count: int = 1, psd: np.ndarray | None = None
                 ) -> np.ndarray:
        """``count`` independent noise records of ``n`` samples (n, count), stationary from the start (made
        circularly on twice the length, the first half kept); ``psd``: one spectrum per record (bins, count) on
        this model's frequencies instead of its own. [N]"""
        from scipy import fft  # numpy's transforms to the bit, records split among the machine's cores

        size = 2 * max(n, 2 * (self.frequency.size - 1))
        at = np.fft.rfftfreq(size)
        spectra = self.psd[:, None] if psd is None else psd
        gain = np.sqrt(0.5 * np.column_stack([np.interp(at, self.frequency, p) for p in spectra.T]))  # σ²: psd 2σ²
        white = fft.rfft(rng.normal(0.0, 1.0, (size, count)), axis=0, workers=-1)
        return fft.irfft(white * gain, n=size, axis=0, workers=-1)[:n]

    def spectra(self, count: int, rng: np.random.Generator) -> np.ndarray | None:
        """``count`` spectra (bins, count) the noise may have, given that this one was read from a record of
        :attr:`samples`: this spectrum times 2 / ŵ, ŵ the same estimate (:func:`noise_spectrum`) read from a
        record of that length of white noise of unit variance (true spectrum 2), one per spectrum.  Read from
        0.2 s, a bin scatters by about 30 % (log standard deviation) at 0–60 Hz, where three bins are averaged
        into one, and 27 % above, and the replicates are what the estimate's own error at white noise says
        the noise may be: the slowly varying columns see in them the low frequencies the data may have, not
        one estimate of them taken as exact.  None when the spectrum is taken as exact (no record, or one too
        short to read a spectrum from)."""
        if self.samples < MIN_SPECTRUM_SAMPLES or self.frequency.size <= 2:
            return None
        white = noise_spectrum(rng.standard_normal((self.samples, count)))[1]
        return self.psd[:, None] * np.clip(2.0 / np.maximum(white, 1e-12), *SPECTRUM_RATIO_RANGE)

    def to_dict(self) -> dict:
        return {"kind": "spectrum", "level_n": self.level_n, "segment_samples": int(2 * (self.frequency.size - 1)),
                "low_frequency_n": float(math.sqrt(0.5 * self.psd[0]))}


NOISE_SEGMENTS = 4
"""Welch segments the pre-trigger span is cut into (halves overlapping): about 20 Hz of resolution from
0.2 s of record, each frequency averaged over about 7 segments. [–]"""
SPECTRUM_RATIO_RANGE = (0.2, 5.0)
"""A replicate's spectrum is kept within these factors of the one read (:meth:`NoiseModel.spectra`: one bin's
ratio scatters by about 30 %, so this only guards against a near-empty bin). [–]"""


def welch(records: np.ndarray, segment: int) -> tuple[np.ndarray, np.ndarray]:
    """(frequency [cycles/sample], one-sided power spectral density [unit² per cycle/sample]) of the records
    (along the first axis, one or many columns) by Welch's method: periodic Hann windows of ``segment`` samples
    (the records' length at most) overlapping by half, no detrending, the segments' periodograms averaged.
    :func:`scipy.signal.welch`'s estimate with those settings, without its copies of many records (the null's
    replicates read 200 at a time)."""
    from scipy import fft

    x = np.asarray(records, dtype=float)
    single = x.ndim == 1
    x = x[:, None] if single else x
    n = x.shape[0]
    segment = min(int(segment), n)
    step = segment - segment // 2
    window = 0.5 - 0.5 * np.cos(2.0 * np.pi * np.arange(segment) / segment)
    starts = range(0, n - segment + 1, step)
    power = np.zeros((segment // 2 + 1, x.shape[1]))
    for start in starts:
        power += np.abs(fft.rfft(x[start:start + segment] * window[:, None], axis=0, workers=-1)) ** 2
    power *= 1.0 / (len(starts) * np.sum(window ** 2))
    power[1:segment // 2 + (segment % 2)] *= 2.0  # one-sided: every bin but zero (and Nyquist, when there is one)
    frequency = np.fft.rfftfreq(segment)
    return frequency, power[:, 0] if single else power


def noise_spectrum(samples: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(frequency, psd) of noise records (along the first axis; one or many columns): Welch's spectrum on
    :data:`NOISE_SEGMENTS` segments, averaged over three neighbouring frequencies, and flat below the first
    frequency above 0 at the mean of the three lowest (the records' mean is taken off, which empties the zero
    bin; the noise this rig sees is flat there).  The segments are not detrended one by one: that took each
    segment's own mean off too, and 8–10 % of the power at 20–40 Hz with it (white and AR(1) noise of 1–1.5 ms,
    0.2 s at 30 and 60 kHz; the zero bin 5–8 % low too, from the bins it is filled from)."""
    e = np.asarray(samples, dtype=float)
    e = e - e.mean(axis=0)
    frequency, psd = welch(e, max(MIN_SPECTRUM_SAMPLES, e.shape[0] // NOISE_SEGMENTS))
    if frequency[-1] == NYQUIST:
        psd[-1] = psd[-2]  # Welch halves the Nyquist bin too
    # each bin averages ~7 segments (±38 %); three bins together, ±22 %, and the zero bin from the three above
    psd[0] = np.mean(psd[1:4], axis=0)
    padded = np.concatenate([psd[:1], psd, psd[-1:]], axis=0)
    smooth = (padded[:-2] + padded[1:-1] + padded[2:]) / 3.0
    smooth[0] = psd[0]
    return frequency, smooth


def fit_noise(samples: np.ndarray) -> NoiseModel:
    """The noise model of a noise record (its pre-trigger span): :func:`noise_spectrum`; white for a record
    under 64 samples."""
    e = np.asarray(samples, dtype=float)
    e = e - e.mean() if e.size else e
    level = float(e.std()) if e.size else 0.0
    if e.size < MIN_SPECTRUM_SAMPLES or level == 0.0:
        return NoiseModel.white(level)
    frequency, psd = noise_spectrum(e)
    return NoiseModel(frequency, psd, level, int(e.size))


ANTI_ALIAS_ORDERS = (2, 3, 4, 5, 6, 8)
"""Butterworth orders tried by :func:`fit_anti_alias`. [–]"""
ANTI_ALIAS_CORNERS = np.geomspace(0.02, 0.49, 60)
"""Corners tried by :func:`fit_anti_alias` (5.6 % apart). [cycles/sample]"""
ANTI_ALIAS_SLOPES = np.linspace(-3.0, 1.0, 21)
"""Power-law slopes of the gauge noise's coloured part tried by :func:`fit_anti_alias`. [–]"""
ANTI_ALIAS_COLOURS = np.array([0.0, 0.3, 0.5, 0.7, 0.8, 0.9, 0.95, 0.98])
"""Lag-one correlations of the gauge noise's coloured part tried by :func:`fit_anti_alias`. [–]"""
RESONANCE_FREQUENCIES = np.geomspace(0.02, 0.45, 80)
"""Centres of the resonant lines tried by :func:`fit_anti_alias` (4 % apart; from the low end of
:data:`ANTI_ALIAS_RANGE`: a band whose peak lies below it shows only a flank there). [cycles/sample]"""
RESONANCE_DAMPINGS = np.array([0.02, 0.04, 0.07, 0.12, 0.18, 0.25])
"""Damping ratios of the resonant lines tried by :func:`fit_anti_alias`: narrow bands only, whose peak stands at
least 4× above their skirts (a mode damped 0.707 is a second-order Butterworth, which the filter stands for). [–]"""
ANTI_ALIAS_RANGE = (0.02, 1e-4)
""":func:`fit_anti_alias` reads the spectrum above this frequency [cycles/sample] and down to this fraction of its
largest value there (the knee and the first 40 dB of the roll-off, which set the filter's delay in the pass band;
deeper, the spectrum is the estimate's own leakage). [–]"""


CORNER_READ_SPREAD = 0.04
"""One run's anti-alias corner, read from its noise alone, is known to about this standard deviation of its
natural log (4th-order Butterworths at 0.117 of the rate, 2.2 N of white noise, 5,850 samples: 40 synthetic
records, 10th–90th percentiles of read/true 0.971–1.082 on the grid): what :func:`corner_spreads` falls back on.
[–]"""
CORNER_GRID_SPREAD = math.log(ANTI_ALIAS_CORNERS[1] / ANTI_ALIAS_CORNERS[0]) / math.sqrt(12.0)
"""The rounding of a corner to :data:`ANTI_ALIAS_CORNERS` as a standard deviation of its log (a grid step's
log over √12; the same rounding for every run that reads the same corner, so their scatter does not show it). [–]"""
CORNER_SPREAD_RUNS = 3
"""At least this many runs of one sampling rate reading a filter give the campaign's own spread. [–]"""


@dataclass(frozen=True)
class AntiAlias:
    """A Butterworth low-pass on the force channel (the acquisition's anti-alias filter), as a digital filter of
    ``order`` with its corner at ``corner`` [cycles/sample], read with an error of ``spread`` (standard deviation of
    the corner's natural log [–]; :func:`corner_spreads`)."""

    order: int
    corner: float
    spread: float = 0.0

    def apply(self, signal: np.ndarray) -> np.ndarray:
        """The signal (along its first axis) as the filtered channel reads it, starting at rest. [N]"""
        from scipy.signal import butter, sosfilt

        return sosfilt(butter(self.order, 2.0 * self.corner, output="sos"), signal, axis=0)

    def apply_drawn(self, signal: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
        """``count`` columns of the signal (samples, 1 or ``count``) as filtered channels read it, each through this
        filter with its corner drawn from the read's error (× exp(spread·ε), ε standard normal; below the Nyquist
        frequency), so that the replicates carry the corner's error as the data do. [N]"""
        from scipy.signal import butter, sosfilt

        if self.spread == 0.0:
            return np.broadcast_to(self.apply(signal), (signal.shape[0], count))
        corners = np.minimum(self.corner * np.exp(self.spread * rng.standard_normal(count)), 0.499)
        columns = np.broadcast_to(signal, (signal.shape[0], count))
        return np.column_stack([sosfilt(butter(self.order, 2.0 * c, output="sos"), columns[:, b])
                                for b, c in enumerate(corners)])

    def to_dict(self, rate_hz: float) -> dict:
        return {"order": self.order, "corner_hz": round(self.corner * rate_hz, 1),
                "corner_spread": round(self.spread, 4)}


def corner_spreads(rates_hz: list[float], filters: list[AntiAlias | None]) -> list[float]:
    """How far each run's anti-alias corner may be off, as the standard deviation of its natural log [–]: the runs
    of one sampling rate share an acquisition chain, so the scatter of their corners (the sample standard
    deviation of the logs of those that read a filter, at least :data:`CORNER_SPREAD_RUNS` of them; else
    :data:`CORNER_READ_SPREAD`) is one read's error, to which the grid's rounding (:data:`CORNER_GRID_SPREAD`) is
    added in quadrature.  0 for a run that reads no filter.

    Why: the filter rings at the force step of contact, and the data's ringing is the true corner's.  With the
    replicates all behind the corner as read, a development null (8 runs at 30 kHz behind a 4th-order Butterworth
    at 3,505 Hz, read at 3,401–3,790 Hz) was called a rig ringing at z 7.78 against 4.11; with the spread its runs'
    reads show (0.027, the grid's rounding in) the ringing stands at 2.85 against 4.24.
    """
    out = []
    for rate, f in zip(rates_hz, filters):
        if f is None:
            out.append(0.0)
            continue
        logs = [math.log(g.corner) for r, g in zip(rates_hz, filters)  # a rate read from the clock: to 0.1 %
                if g is not None and math.isclose(r, rate, rel_tol=1e-3)]
        read = float(np.std(logs, ddof=1)) if len(logs) >= CORNER_SPREAD_RUNS else CORNER_READ_SPREAD
        out.append(math.hypot(read, CORNER_GRID_SPREAD))
    return out


@dataclass(frozen=True)
class NoiseLine:
    """A narrow band of the gauge noise (a floor or fixture mode) as :func:`read_noise_chain` reads it: a damped mode
    driven by white noise, centred at ``frequency`` [cycles/sample] with damping ratio ``damping`` [–], both on the
    grids :data:`RESONANCE_FREQUENCIES` and :data:`RESONANCE_DAMPINGS`."""

    frequency: float
    damping: float

    def to_dict(self, rate_hz: float) -> dict:
        return {"frequency_hz": round(self.frequency * rate_hz, 1), "damping": self.damping}


def _line_of(index: int | None) -> NoiseLine | None:
    """The line of :func:`_resonances`' row ``index`` (None: none)."""
    if index is None:
        return None
    f, z = divmod(int(index), RESONANCE_DAMPINGS.size)
    return NoiseLine(float(RESONANCE_FREQUENCIES[f]), float(RESONANCE_DAMPINGS[z]))


@njit(cache=True, nogil=True, error_model="numpy")
def _nonnegative_sse_rows(gram: np.ndarray, rhs: np.ndarray, total: float) -> np.ndarray:  # pragma: no cover
    """:func:`_nonnegative_sse` on (problems, K, K) and (problems, K), compiled: each subset by elimination."""
    problems, k = rhs.shape
    out = np.empty(problems)
    a = np.empty((k, k))
    b = np.empty(k)
    c = np.empty(k)
    idx = np.empty(k, dtype=np.int64)
    for p in range(problems):
        best = total
        for mask in range(1, 1 << k):
            m = 0
            for i in range(k):
                if mask >> i & 1:
                    idx[m] = i
                    m += 1
            trace = 0.0
            for i in range(m):
                trace += gram[p, idx[i], idx[i]]
            for i in range(m):
                b[i] = rhs[p, idx[i]]
                for j in range(m):
                    a[i, j] = gram[p, idx[i], idx[j]]
                a[i, i] += 1e-12 * trace  # a ridge on each problem's own scale
            ok = True
            for col in range(m):  # the Gram matrix is symmetric and (with the ridge) positive: no pivoting
                if not a[col, col] > 0.0:
                    ok = False
                    break
                for row in range(col + 1, m):
                    f = a[row, col] / a[col, col]
                    for j in range(col, m):
                        a[row, j] -= f * a[col, j]
                    b[row] -= f * b[col]
            if not ok:
                continue
            sse = total
            for i in range(m - 1, -1, -1):
                v = b[i]
                for j in range(i + 1, m):
                    v -= a[i, j] * c[j]
                c[i] = v / a[i, i]
                if not c[i] >= 0.0:
                    ok = False
                    break
                sse -= c[i] * rhs[p, idx[i]]  # at the optimum, |t - Xc|² = |t|² - cᵀb
            if ok and sse < best:
                best = sse
        out[p] = best
    return out


def _nonnegative_sse(gram: np.ndarray, rhs: np.ndarray, total: float) -> np.ndarray:
    """Residual sum of squares of least squares with non-negative amplitudes, for a batch of small problems given
    by their normal equations (Gram matrices (..., K, K), right-hand sides (..., K), and the target's own sum of
    squares): every subset of amplitudes is solved and the best one with none negative kept (the best feasible
    subset is the constrained optimum)."""
    k = gram.shape[-1]
    rows = _nonnegative_sse_rows(np.ascontiguousarray(gram, dtype=float).reshape(-1, k, k),
                                 np.ascontiguousarray(rhs, dtype=float).reshape(-1, k), float(total))
    return rows.reshape(gram.shape[:-2])


def _resonances(frequency: np.ndarray) -> np.ndarray:
    """The resonant lines :func:`fit_anti_alias` tries on ``frequency`` [cycles/sample]: the spectrum of a damped
    mode driven by white noise, :math:`1/((1 - x^2)^2 + (2\\zeta x)^2)` with :math:`x = f/f_0`, for every
    :data:`RESONANCE_FREQUENCIES` × :data:`RESONANCE_DAMPINGS`, each scaled to a largest value of 1 there.
    (lines, bins)"""
    x = frequency[None, None, :] / RESONANCE_FREQUENCIES[:, None, None]
    z = RESONANCE_DAMPINGS[None, :, None]
    shape = (1.0 / ((1.0 - x * x) ** 2 + (2.0 * z * x) ** 2)).reshape(-1, frequency.size)
    return shape / np.max(shape, axis=1, keepdims=True)


def _butterworth_gain(frequency: np.ndarray, order: int, corners: np.ndarray = ANTI_ALIAS_CORNERS) -> np.ndarray:
    """|H|² of the digital Butterworth of ``order`` at every corner of ``corners`` [cycles/sample] on ``frequency``
    [cycles/sample]. (corners, bins)"""
    ratio = np.tan(np.pi * np.minimum(frequency, 0.4999))[None, :] / np.tan(np.pi * corners)[:, None]
    return 1.0 / (1.0 + ratio ** (2 * order))


def _filtered_fits(base: np.ndarray, w: np.ndarray, t: np.ndarray, total: float, frequency: np.ndarray,
                   line: np.ndarray | None) -> tuple[float, int, int, int]:
    """The best fit of :math:`|H|^2 (A g + B [+ D L]) + F` over every order, corner and coloured part ``base``
    (weighted, (bases, bins)), with the weighted line ``line`` (bins) under the filter when given: (residual sum of
    squares, order, corner index, base index)."""
    k = 3 if line is None else 4
    best = (math.inf, 0, 0, 0)
    cols_w = [w] if line is None else [w, line]        # the flat parts under the filter
    bb, bt = base * base, base * t                     # the same for every order
    bc = [base * c for c in cols_w]
    for order in ANTI_ALIAS_ORDERS:
        h2 = _butterworth_gain(frequency, order)
        hh = h2 * h2
        gram = np.empty((base.shape[0], h2.shape[0], k, k))
        rhs = np.empty((base.shape[0], h2.shape[0], k))
        gram[..., 0, 0] = bb @ hh.T
        for i, c in enumerate(cols_w, start=1):
            gram[..., 0, i] = gram[..., i, 0] = bc[i - 1] @ hh.T
            for j, d in enumerate(cols_w[i - 1:], start=i):
                gram[..., i, j] = gram[..., j, i] = ((c * d) @ hh.T)[None, :]
            gram[..., i, k - 1] = gram[..., k - 1, i] = ((c * w) @ h2.T)[None, :]
            rhs[..., i] = ((c * t) @ h2.T)[None, :]
        gram[..., 0, k - 1] = gram[..., k - 1, 0] = bc[0] @ h2.T
        gram[..., k - 1, k - 1] = float(w @ w)
        rhs[..., 0] = bt @ h2.T
        rhs[..., k - 1] = float(w @ t)
        sse = _nonnegative_sse(gram, rhs, total)  # (bases, corners)
        i = int(np.argmin(sse))
        if float(sse.flat[i]) < best[0]:
            best = (float(sse.flat[i]), order, i % h2.shape[0], i // h2.shape[0])
    return best


def fit_anti_alias(noise: NoiseModel) -> AntiAlias | None:
    """The force channel's anti-alias low-pass as read from its noise spectrum, or None when it shows none
    (:func:`read_noise_chain`)."""
    return read_noise_chain(noise)[0]


def _unfiltered_fits(base: np.ndarray, w: np.ndarray, t: np.ndarray, total: float, lines: np.ndarray
                     ) -> tuple[float, np.ndarray]:
    """The noise without a filter: the least weighted error of A g + C over every slope and colour, and of
    A g + C + D L per (slope and colour, line)."""
    gg, gw, gt = np.sum(base * base, axis=1), base @ w, base @ t
    gram = np.empty((base.shape[0], 2, 2))
    gram[:, 0, 0], gram[:, 0, 1] = gg, gw
    gram[:, 1, 0], gram[:, 1, 1] = gw, float(w @ w)
    rhs = np.column_stack([gt, np.full(base.shape[0], float(w @ t))])
    plain = float(np.min(_nonnegative_sse(gram, rhs, total)))
    gram = np.empty((base.shape[0], lines.shape[0], 3, 3))
    gram[..., 0, 0], gram[..., 0, 1] = gg[:, None], gw[:, None]
    gram[..., 0, 2] = base @ lines.T
    gram[..., 1, 1], gram[..., 1, 2] = float(w @ w), (lines @ w)[None, :]
    gram[..., 2, 2] = np.sum(lines * lines, axis=1)[None, :]
    for i, j in ((1, 0), (2, 0), (2, 1)):
        gram[..., i, j] = gram[..., j, i]
    rhs = np.stack(np.broadcast_arrays(gt[:, None], float(w @ t), (lines @ t)[None, :]), axis=-1)
    return plain, _nonnegative_sse(gram, rhs, total)  # (bases, lines)


def read_noise_chain(noise: NoiseModel) -> tuple[AntiAlias | None, NoiseLine | None]:
    r"""The force channel's anti-alias low-pass as read from its noise spectrum (or None when it shows none), and
    the narrow band read beside or under it (or None).

    The gauge noise the rig sees is white plus a coloured part, flat or falling gently (a power law times the
    spectrum of a first-order autoregression, :math:`A f^\beta/(1 + \phi^2 - 2\phi\cos 2\pi f)` plus
    :math:`B`), and sometimes a narrow band (a floor or fixture mode, a line :math:`D L` of :func:`_resonances`);
    an anti-alias filter bends it down steeply towards the Nyquist frequency; and the converter after the filter
    adds its own white noise, a floor :math:`F` the roll-off ends on.  The spectrum is fitted as
    :math:`|H(f)|^2 (A g + B [+ D L]) + F`, with :math:`|H|^2 = 1/(1 + (\tan\pi f/\tan\pi f_c)^{2n})` the
    digital Butterworth of order n and corner :math:`f_c`, for every order, corner, slope and colour on their grids
    (A, B, D, F ≥ 0, by least squares on the relative error over :data:`ANTI_ALIAS_RANGE`), and the filter is kept
    when its best fit, with or without a line, beats the same noise without a filter (:math:`A g + C [+ D L]`),
    with or without one, by the Bayesian information criterion on that error, counting a third of the bins
    (:func:`fit_noise` averages them in threes; counted all, 19 of 216 unfiltered records were read as filtered)
    and three parameters for a line.  The filter acts on the signal as on the noise: the inertia force m·a in
    flight reaches the data through it, lagging by its group delay, which a load-cell mass column follows (a
    0.08 mm encoder and a corner at 0.1 of the rate made a null campaign's load-cell mass z 76 against 3.9).

    The floor matters: fitted without it, a converter noise 26 dB under the gauge noise (5 % of it) hid every
    2nd-order Butterworth at 0.05–0.2 of the rate (the roll-off flattens on it, which a power law fits better
    than a Butterworth alone), and a null campaign behind such a filter was called a load-cell mass error at
    z 60–85.  And the colour matters once the floor is there: white plus autoregressive noise with no filter
    is "falling, then flat" too, and a power law plus floor alone read a filter in 63 of 216 such records.  The
    line matters too: without one, a band's upper flank passes for a roll-off (white noise with a 2.14 kHz band
    of damping 0.11 at 60 kHz was read as an 8th-order filter at 0.043 of the rate in 10 of 10 records), the
    replicates low-pass their force, and a null campaign was called a sidewall pressure growth at z 8.0 against
    3.9.  The line under the filter is searched by turns (the line for the best filter without one, the filter
    for that line, the line again), not over every filter at once.
    """
    f_lo, depth = ANTI_ALIAS_RANGE
    keep = noise.frequency >= f_lo
    if keep.sum() < MIN_ROLL_OFF_BINS:
        return None, None
    keep &= noise.psd > depth * float(np.max(noise.psd[keep]))
    f, p = noise.frequency[keep], noise.psd[keep]
    if f.size < MIN_ROLL_OFF_BINS:
        return None, None
    n = f.size
    # relative error against a running geometric mean of the spectrum (15 bins): weights that do not follow each
    # bin's own estimation error, which 1/P would (it favours models below the spectrum)
    w = 1.0 / np.exp(np.convolve(np.log(np.r_[np.full(7, p[0]), p, np.full(7, p[-1])]), np.ones(15) / 15.0,
                                 mode="valid"))
    t = p * w
    colour = 1.0 / (1.0 + ANTI_ALIAS_COLOURS[:, None] ** 2
                    - 2.0 * ANTI_ALIAS_COLOURS[:, None] * np.cos(2.0 * np.pi * f)[None, :])
    base = (np.exp(np.outer(ANTI_ALIAS_SLOPES, np.log(f)))[:, None, :] * colour[None, :, :]).reshape(-1, n) * w
    lines = _resonances(f) * w
    total = float(t @ t)
    plain, plain_lines = _unfiltered_fits(base, w, t, total, lines)
    plain_line = float(np.min(plain_lines))
    m = n / 3.0  # independent bins: fit_noise averages three neighbours
    bic = lambda sse, k: m * math.log(max(sse, 1e-300) / n) + k * math.log(m)  # noqa: E731
    bic_plain = min(bic(plain, PLAIN_PARAMETERS), bic(plain_line, LINE_PARAMETERS))
    unfiltered_line = (int(np.argmin(plain_lines)) % lines.shape[0]
                       if bic(plain_line, LINE_PARAMETERS) < bic(plain, PLAIN_PARAMETERS) else None)
    # a filter: |H|²(A g + B) + F over every order, corner and coloured part
    filtered = _filtered_fits(base, w, t, total, f, None)
    # with a line under it, by turns: the line for that filter, the filter for that line, the line again (the
    # last two only when the line fits the first better, or the filter alone loses)
    readings = [(bic(filtered[0], 7), filtered[1:3], None)]
    sse, line = _line_under(filtered, base, w, t, total, f, lines)
    readings.append((bic(sse, 10), filtered[1:3], line))
    if readings[1][0] < min(readings[0][0], bic_plain):
        with_line = _filtered_fits(base, w, t, total, f, lines[line])
        readings.append((bic(with_line[0], 10), with_line[1:3], line))
        again, again_line = _line_under(with_line, base, w, t, total, f, lines)
        readings.append((bic(again, 10), with_line[1:3], again_line))
    score, (order, corner), under = min(readings, key=lambda r: r[0])
    if score < bic_plain:
        return AntiAlias(order, float(ANTI_ALIAS_CORNERS[corner])), _line_of(under)
    return None, _line_of(unfiltered_line)


def _line_under(fit: tuple[float, int, int, int], base: np.ndarray, w: np.ndarray, t: np.ndarray, total: float,
                frequency: np.ndarray, lines: np.ndarray) -> tuple[float, int]:
    """The best line (weighted, (lines, bins)) under the filter and coloured part of ``fit`` (as
    :func:`_filtered_fits` returns it): (residual sum of squares, line index)."""
    _, order, corner, b = fit
    h2 = _butterworth_gain(frequency, order, ANTI_ALIAS_CORNERS[corner:corner + 1])[0]
    columns = [np.broadcast_to(h2 * base[b], lines.shape), np.broadcast_to(h2 * w, lines.shape), h2 * lines,
               np.broadcast_to(w, lines.shape)]
    sse = _nonnegative_sse(*_stacked_normal(columns, t), total)
    i = int(np.argmin(sse))
    return float(sse[i]), i


def _stacked_normal(columns: list[np.ndarray], t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Normal equations (Gram matrices (problems, K, K), right-hand sides (problems, K)) of a batch of least-squares
    problems, one per row of the K column arrays (problems, bins), against the target ``t`` (bins)."""
    a = np.stack(columns, axis=1)                      # (problems, K, bins)
    return np.einsum("pkn,pjn->pkj", a, a), a @ t


@dataclass(frozen=True)
class ModelMotion:
    """The baseline's own motion in the material from its contact on (the reference model's dynamics, started
    where and as fast as the run met the material), to be placed at any contact time."""

    time_s: np.ndarray
    """Since contact. [s]"""
    depth_m: np.ndarray
    """Since contact. [m]"""
    acceleration_m_s2: np.ndarray

    def on(self, ts: np.ndarray, contact_s: float, depth_at_contact_m: float) -> tuple[np.ndarray, np.ndarray, float]:
        """(depth [m], acceleration [m/s²]) on ``ts`` with the contact at ``contact_s``, the depth there
        ``depth_at_contact_m`` (NaN before it, the acceleration 0 after the stop), and the stop [s]."""
        tau = ts - contact_s
        inside = tau >= 0.0
        end = float(self.time_s[-1])
        depth = np.full(ts.size, np.nan)
        accel = np.full(ts.size, np.nan)
        depth[inside] = depth_at_contact_m + np.interp(tau[inside], self.time_s, self.depth_m)
        accel[inside] = np.where(tau[inside] <= end,
                                 np.interp(tau[inside], self.time_s, self.acceleration_m_s2), 0.0)
        return depth, accel, contact_s + end


@dataclass(frozen=True)
class RunNull:
    """What one run needs to make its replicates (all on the span from the context start to just past the stop)."""

    time_s: np.ndarray
    depth_m: np.ndarray
    acceleration_m_s2: np.ndarray
    """The data's own acceleration (the spline of the real record). [m/s²]"""
    at_rest: np.ndarray
    use: np.ndarray
    """Analysis samples, as a mask on the span."""
    fitted_n: np.ndarray
    """Baseline resistance on the analysis samples. [N]"""
    events: Events
    full_depth_m: float
    encoder_step_m: float
    load_cell_mass_kg: float
    noise: NoiseModel
    method: str
    kinematic_contact_s: float
    """Where the derivatives break the motion at contact (:func:`pencli.filter.inertia.kinematic_events`). [s]"""
    model: "ModelMotion | None" = None
    """The baseline's motion in the material, or None to make the replicates from the spline through the record
    alone."""
    anti_alias: AntiAlias | None = None
    """The force channel's low-pass as read from its noise (:func:`fit_anti_alias`), or None."""
    noise_line: NoiseLine | None = None
    """The narrow band read beside or under it (:func:`read_noise_chain`), or None: reported, not replicated apart
    (the replicates' noise has the run's whole spectrum)."""
    baseline_n: np.ndarray | None = None
    """Baseline resistance on the whole span (0 outside the material), what the filter acts on with m·a. [N]"""
    contact_break: bool = True
    """The derivatives break the motion at contact (False for a sharp tip, as the inertia stage did)."""


@dataclass(frozen=True)
class Replicates:
    """Null replicates of one run."""

    resistance_n: np.ndarray
    """(analysis samples, replicates). [N]"""
    contact_speed_m_s: np.ndarray
    """Measured contact speed of each replicate (NaN where the detector failed). [m/s]"""
    true_contact_speed_m_s: float
    """Contact speed of the smoothed trajectory the replicates were made from. [m/s]"""
    acceleration_m_s2: np.ndarray
    """(span samples, replicates): the acceleration each replicate *measures* (its true acceleration plus its
    own derivative error, the error its resistance carries through R = F − m·a), on the whole span, so that a
    causal filter of it (a sensor lag's offset) starts where the data's does. [m/s²]"""
    position_noise_m: float = 0.0
    """The record's position error beyond its quantisation, as read from its flight (:func:`position_noise`),
    which every replicate's encoder adds before it quantises. [m]"""


PHASE_GRID = 64
"""Phases (fractions of a count) tried by :func:`encoder_phase`. [–]"""


def encoder_phase(record_m: np.ndarray, smooth_m: np.ndarray, span: np.ndarray, step_m: float) -> float:
    """Where the record's encoder steps, as the phase f of :func:`replicate_run`'s quantiser
    step·round((x + f·step)/step) − f·step (zeroed at the first sample, as the record is): of
    :data:`PHASE_GRID` phases, the ones whose quantisation of the smoothed motion disagrees with the record
    by more than half a count on the fewest samples of ``span`` (the flight, where the smoothed motion follows
    the record within a fraction of a count), averaged on the circle. [fraction of a count]"""
    f = np.arange(PHASE_GRID) / PHASE_GRID
    shift = f * step_m

    def quantised(x):
        return step_m * np.round((x[:, None] + shift) / step_m) - shift

    q = quantised(smooth_m[span]) - (quantised(smooth_m[:1]) - record_m[0])
    mismatch = np.sum(np.abs(q - record_m[span][:, None]) > HALF_COUNT * step_m, axis=0)
    best = 2.0 * np.pi * f[mismatch == mismatch.min()]
    return float(np.arctan2(np.sin(best).mean(), np.cos(best).mean()) / (2.0 * np.pi)) % 1.0


POSITION_NOISE_GRID = np.array([0.0, 0.025, 0.05, 0.075, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.7, 1.0])
"""Position errors (standard deviation, in counts) :func:`position_noise` tries. [counts]"""
POSITION_NOISE_DRAWS = 16
"""Noise draws per position error tried by :func:`position_noise`. [–]"""


def _roughness(x: np.ndarray) -> np.ndarray:
    """Mean squared third difference along the first axis: 20 σ² for white noise of σ, next to nothing for a
    smooth motion sampled at 30–60 kHz. [m²]"""
    d = np.diff(x, 3, axis=0)
    return np.mean(d * d, axis=0)


def position_noise(record_m: np.ndarray, smooth_m: np.ndarray, span: np.ndarray, step_m: float,
                   phase: float, seed: int) -> float:
    """The record's position error beyond its quantisation (string vibration, an encoder's interpolation
    error), white, as a standard deviation. [m]

    The roughness (:func:`_roughness`) of the record over ``span`` (the flight) against that of the smoothed
    motion re-quantised at the record's own phase with white position errors of each size on
    :data:`POSITION_NOISE_GRID` (mean of :data:`POSITION_NOISE_DRAWS` draws): the size whose roughness the
    record's matches, interpolated; 0 where the record is no rougher than its quantisation alone makes it.
    A pure quantiser of a smooth motion makes the record about as rough as the error-free re-quantisation,
    so an encoder without such error reads near 0 (and a small positive reading only widens the null, which
    errs towards ``none``).
    """
    x = smooth_m[span]
    if x.size < MIN_ROUGHNESS_SAMPLES:
        return 0.0
    rng = np.random.default_rng(seed)
    shift = phase * step_m
    noise = rng.standard_normal((x.size, POSITION_NOISE_DRAWS))
    target = float(_roughness(record_m[span]))
    sizes = POSITION_NOISE_GRID * step_m
    rough = np.array([float(np.mean(_roughness(step_m * np.round((x[:, None] + shift + s * noise) / step_m))))
                      for s in sizes])
    rough = np.maximum.accumulate(rough)  # a sampling wobble must not make it fold back
    if target <= rough[0]:
        return 0.0
    if target >= rough[-1]:
        return float(sizes[-1])
    return float(np.interp(target, rough, sizes))


def _replicate_motions(null: RunNull, motion: Events, smooth: np.ndarray, rate: float, count: int,
                       rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, list[Events]]:
    """Each replicate's true motion (n × count, or n × 1 when all share it), its true acceleration, and its
    events (the breaks of its derivatives): the model's dynamics from a contact drawn within the sampling
    interval before the force shows it, continuous with the smoothed flight; without a model, the smoothed
    record for every replicate."""
    t, step = null.time_s, null.encoder_step_m
    if null.model is None:
        reference = derivatives(smooth, rate, motion_breaks(t, motion, null.contact_break), null.method,
                                count_m=step, joins=motion_joins(t, motion, null.contact_break))[1][:, None]
        return smooth[:, None], reference, [motion] * count
    contacts = null.kinematic_contact_s - rng.uniform(0.0, 1.0, count) / rate
    # continuous with the smoothed flight where it meets the material (the record's reading there is a whole
    # count, up to half a count off the motion)
    placed = [null.model.on(t, c, float(np.interp(c, t, smooth))) for c in contacts]
    inside = np.column_stack([np.isfinite(d) for d, _, _ in placed])
    truth = np.where(inside, np.column_stack([d for d, _, _ in placed]), smooth[:, None])
    motions = [replace(motion, stop_s=min(stop, float(t[-1]))) for _, _, stop in placed]
    # the true acceleration: the model's in the material; in flight D(x̃), the smoother's own reading of it
    flight_motion = motions[0]
    _, flight_accel = derivatives(np.where(inside[:, 0], truth[:, 0], smooth), rate,
                                  motion_breaks(t, flight_motion, null.contact_break), null.method, count_m=step,
                                  joins=motion_joins(t, flight_motion, null.contact_break))
    reference = np.where(inside, np.column_stack([a for _, a, _ in placed]), flight_accel[:, None])
    return truth, reference, motions


def _measured_accelerations(null: RunNull, depth: np.ndarray, motions: Sequence[Events], rate: float) -> np.ndarray:
    """The acceleration each replicate's encoder record gives through the run's derivative method (n × count):
    the replicates that share their breaks in one call where the method is linear in the record."""
    t, step = null.time_s, null.encoder_step_m
    accel = np.empty_like(depth)
    groups: dict[tuple, list[int]] = {}
    for b, m in enumerate(motions):
        groups.setdefault((tuple(motion_breaks(t, m, null.contact_break)),
                           tuple(motion_joins(t, m, null.contact_break))), []).append(b)
    for members in groups.values():
        m = motions[members[0]]
        breaks, joins = motion_breaks(t, m, null.contact_break), motion_joins(t, m, null.contact_break)
        if null.method == "spline":  # not linear, but its polynomial pieces are fitted to every replicate at once
            accel[:, members] = spline_columns(depth[:, members], rate, breaks, step)
        else:  # linear in the record: the replicates of one set of breaks in one call
            accel[:, members] = derivatives(depth[:, members], rate, breaks, null.method, count_m=step,
                                            joins=joins)[1]
    return accel


def replicate_run(null: RunNull, count: int, seed: int, phases: np.ndarray | None = None) -> Replicates:
    """``count`` null replicates of one run (see the module docstring).

    The motion a replicate is measured from is the smoothed record x̃ in flight and, from the contact on,
    the baseline's own dynamics (``null.model``), whose acceleration has the jumps at contact and stop that
    the encoder cannot resolve.  The acceleration error of a replicate is D(x* + q) − a*: the derivative
    method D applied to that motion re-quantised (random encoder phase, zeroed at rest) minus its true
    acceleration a*, which in flight is D(x̃) (the smoother's own resolution bias, common to data and
    replicates, cancels).  Without a model the whole motion is x̃, as in flight.

    Each replicate's contact is drawn uniformly within the sampling interval before the sample at which the
    run's force shows it (``kinematic_contact_s``, where the derivatives break the motion, the data's and the
    replicates' alike): the data's tip met the material somewhere in that interval, not on a sample, and
    how far before the break the acceleration jumps sets the derivative error around contact.  With every
    replicate's jump on the break, dev nulls read by a 0.32 mm encoder at 30 kHz put the data's sensor-lag
    improvement above the replicates' median in 24 of 30 campaigns, and 2 of the 30 were called a lag.

    ``phases``: one shift per replicate (fractions of a count) added to the run's own phase as read from its
    record (:func:`encoder_phase`); without them each replicate reads the run at a random phase.
    """
    rng = np.random.default_rng(seed)
    t = null.time_s
    rate = (t.size - 1) / (t[-1] - t[0])
    motion = replace(null.events, contact_s=null.kinematic_contact_s)
    step = null.encoder_step_m
    smooth, velocity, _ = smooth_motion(null.depth_m, rate, motion_breaks(t, motion, null.contact_break), step)
    smooth = np.where(null.at_rest & (t < null.events.contact_s), null.depth_m, smooth)
    true_contact = float(np.interp(null.events.contact_s, t, velocity))
    flight = ~null.at_rest & (t < null.events.contact_s)
    own = encoder_phase(null.depth_m, smooth, flight, step)
    if phases is None:
        fractions = rng.uniform(0.0, 1.0, count)
    else:
        fractions = (np.asarray(phases, dtype=float) + own) % 1.0
    jitter = position_noise(null.depth_m, smooth, flight, step, own, seed + 1)
    truth, reference, motions = _replicate_motions(null, motion, smooth, rate, count, rng)
    # the noise, each replicate with a spectrum the run's may have (its own stream: the rest is drawn as before)
    noise = null.noise.simulate(t.size, rng, count, null.noise.spectra(count, np.random.default_rng([seed, 7])))
    error_m = None
    if jitter > 0.0:  # the encoder's own position error, where the blade moves (at rest the record is its own)
        error_m = np.where(null.at_rest, 0.0, jitter)[:, None] * rng.standard_normal((t.size, count))
    depth = encoder_reading(truth, step, fractions, float(null.depth_m[0]), error_m)  # zeroed at rest, as the data's
    speeds = np.full(count, np.nan)
    for b in range(count):
        try:
            speeds[b] = detect_events(t, depth[:, b], null.full_depth_m).contact_speed_m_s
        except DataError:
            pass
    accel = _measured_accelerations(null, depth, motions, rate)
    error = np.where(null.at_rest[:, None], 0.0, accel - reference)  # at rest the record is its own: no error
    out = load_cell_reading(null.fitted_n, null.load_cell_mass_kg, error[null.use], noise[null.use])
    if null.anti_alias is not None:  # the channel's filter acts on the force, R + m·a, not on the noise added after
        force = null.load_cell_mass_kg * np.where(null.at_rest[:, None], 0.0, reference)
        if null.baseline_n is not None:
            force = force + null.baseline_n[:, None]
        out += (null.anti_alias.apply_drawn(force, count, np.random.default_rng([seed, 8])) - force)[null.use]
    return Replicates(out, speeds, true_contact, reference + error, jitter)


def _replicate_job(args) -> Replicates:
    return replicate_run(*args)


class PendingReplicates:
    """A campaign's replicates being made by a pool of processes (:func:`start_replicates`): the caller works on
    meanwhile, and :meth:`result` waits for them (then shuts the pool down)."""

    def __init__(self, pool, futures, done: list | None = None):
        self._pool, self._futures, self._done = pool, futures, done

    def result(self) -> list[Replicates]:
        if self._done is None:
            try:
                self._done = [f.result() for f in self._futures]
            finally:
                self.cancel()
        return self._done

    def cancel(self) -> None:
        """Shut the pool down without waiting for replicates not yet started (their work is discarded)."""
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None


def start_replicates(nulls: list[RunNull], count: int, seed: int, *, workers: int = 2) -> PendingReplicates:
    """Replicates of every run (:func:`replicate_run`), begun: with more than one worker the runs are spread over
    a pool of ``workers`` processes while the caller goes on; in one process they are made here, before it returns.

    Replicate b reads every run at that run's own encoder phase, as read from its record, shifted by one
    amount common to the campaign (a fraction of a count): the runs' phases keep the relation they have in
    the data.  A rig whose blade rests at the same place before every shot reads every run through one phase,
    so its runs' derivative errors agree in sign where their motions agree, and phases drawn independently
    per run would average that out of every replicate but not out of the data; a rig whose blade rests
    anywhere reads each run through its own phase, and one phase shared by the replicates' runs would add
    up errors that the data's runs do not share.
    """
    phases = np.random.default_rng(seed).uniform(0.0, 1.0, count)
    jobs = [(null, count, seed * 1000 + i, phases) for i, null in enumerate(nulls)]
    if workers <= 1 or len(jobs) < 2:
        return PendingReplicates(None, [], [replicate_run(*job) for job in jobs])
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    context = multiprocessing.get_context("fork") if "fork" in multiprocessing.get_all_start_methods() else None
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=context)
    # the longest runs first, so that the workers finish together; the results in the runs' order
    order = sorted(range(len(jobs)), key=lambda i: -nulls[i].time_s.size)
    futures = dict(zip(order, (pool.submit(_replicate_job, jobs[i]) for i in order)))
    return PendingReplicates(pool, [futures[i] for i in range(len(jobs))])


# ----------------------------------------------------------------------------- tails
def gumbel_quantile(samples: np.ndarray, p: float) -> float:
    """Upper ``p``-quantile of a Gumbel law fitted by moments to maxima ``samples``.

    The distribution of a maximum over many statistics is of Gumbel type; the
    fit extrapolates the tail beyond what a few dozen replicates resolve.
    """
    x = np.asarray(samples, dtype=float)
    x = x[np.isfinite(x)]
    beta = max(float(np.std(x, ddof=1)) * math.sqrt(6.0) / math.pi, 1e-12)
    mu = float(np.mean(x)) - 0.5772156649 * beta
    return mu - beta * math.log(-math.log(1.0 - p))


def gev_quantile(samples: np.ndarray, p: float) -> float:
    """Upper ``p``-quantile of a generalised extreme-value law fitted to maxima ``samples`` by probability-weighted
    moments (Hosking, Wallis & Wood 1985, the shape k solved exactly; k < 0 is a heavy, Fréchet-type tail, k > 0
    a bounded one), or the Gumbel one where the shape is 0.

    A maximum over statistics with a heavy upper tail (a family at its sign bound that fits on a few
    replicates, a noise correlated over milliseconds) has a Fréchet-type law, whose tail a Gumbel fitted by
    moments places too low; the shape is read from the maxima themselves.
    """
    from scipy.optimize import brentq
    from scipy.special import gamma

    x = np.sort(np.asarray(samples, dtype=float))
    x = x[np.isfinite(x)]
    n = x.size
    if n < MIN_GEV_SAMPLES:
        return gumbel_quantile(x, p)
    i = np.arange(n, dtype=float)
    b0 = float(x.mean())
    b1 = float(np.sum(i / (n - 1) * x)) / n
    b2 = float(np.sum(i * (i - 1) / ((n - 1) * (n - 2)) * x)) / n
    if not 2 * b1 - b0 > 0:
        return gumbel_quantile(x, p)
    ratio = (3 * b2 - b0) / (2 * b1 - b0)  # (1 − 3^−k)/(1 − 2^−k); log 3/log 2 at k = 0

    def gap(k):
        limit = math.log(3.0) / math.log(2.0)
        return (limit if abs(k) < GEV_SHAPE_ROUND_OFF else (1 - 3.0 ** -k) / (1 - 2.0 ** -k)) - ratio

    lo, hi = -0.95, 5.0
    if gap(lo) * gap(hi) > 0:  # outside the bracket (the heaviest shape with a finite mean): its nearer end
        k = lo if abs(gap(lo)) < abs(gap(hi)) else hi
    else:
        k = float(brentq(gap, lo, hi, xtol=1e-8))
    if abs(k) < GUMBEL_SHAPE:
        return gumbel_quantile(x, p)
    scale = (2 * b1 - b0) * k / (gamma(1 + k) * (1 - 2.0 ** -k))
    loc = b0 + scale * (gamma(1 + k) - 1) / k
    return loc + scale / k * (1 - (-math.log(1 - p)) ** k)


def normal_quantile(p: float) -> float:
    """Upper ``p``-quantile of the standard normal."""
    from scipy.special import ndtri

    return float(ndtri(1.0 - p))


def student_quantile(p: float, dof: int) -> float:
    """Upper ``p``-quantile of Student's t with ``dof`` degrees of freedom."""
    from scipy.stats import t as student

    return float(student.ppf(1.0 - p, dof))
