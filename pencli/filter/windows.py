"""The margins of a run's spans, defined once: the tare, the inertia subtraction, the resistance fit and the
diagnosis read them here.

Plain numbers, no imports: the diagnosis's registry (loaded for ``pen --help``) uses them too.
"""

PRE_TRIGGER_MARGIN_S = 0.005
"""Ignore the last 5 ms before the release when taking the tare (and reading the sensor noise). [s]"""
WINDOW_TRIM_S = 0.5e-3
"""The default analysis window starts this long after contact and ends this long before the stop
(the paper's inner limits, Fig. 11): derivatives of the encoder are least reliable at those instants. [s]"""

FIT_EDGE_MARGINS_S = (2e-3, 3e-3)
"""The resistance fit leaves out the samples this close to contact and to the stop, inside the analysis window.
[s, s]

There the encoder's acceleration, and so R = F − m_lc·a, is least reliable: the smoothing spline's force error
(``python -m bench.bench_derivatives``, 72 shots of both materials, every blade and spring count, four encoder
phases; RMS of m_lc·(a − a_true) over the peak resistance) is 0.27 % at 0.5–1 ms after contact, 0.14 % at 1–2 ms
and 0.07 % from 2 ms on; before the stop 0.54 % at 0.5–1 ms, 0.34 % at 1–2 ms, 0.15 % at 2–3 ms and 0.12 % from
3 ms on, against 0.06 % inside the run.  Each margin is where that error falls to twice the inside's.  Those
errors sit where the speed is highest or changes fastest, so in the fit they read as rate damping.  A short run
keeps at least half of its penetration (:func:`fit_edges`).  The diagnosis keeps the analysis window: its null
replicates carry the same derivative errors."""

FIT_KEEPS_AT_LEAST = 0.5
"""The share of a run's penetration time the fit's edge margins leave at the least: shorter runs get
proportionally smaller margins. [–]"""


def fit_edges(contact_s: float, stop_s: float, margins_s: tuple[float, float] = FIT_EDGE_MARGINS_S
              ) -> tuple[float, float]:
    """The first and last instants the resistance fit uses between ``contact_s`` and ``stop_s``: the margins of
    :data:`FIT_EDGE_MARGINS_S` inside them, scaled down so that :data:`FIT_KEEPS_AT_LEAST` of the span is kept. [s]"""
    span = max(stop_s - contact_s, 0.0)
    total = margins_s[0] + margins_s[1]
    scale = min(1.0, (1.0 - FIT_KEEPS_AT_LEAST) * span / total) if total > 0 else 0.0
    return contact_s + scale * margins_s[0], stop_s - scale * margins_s[1]


__all__ = ["FIT_EDGE_MARGINS_S", "FIT_KEEPS_AT_LEAST", "PRE_TRIGGER_MARGIN_S", "WINDOW_TRIM_S", "fit_edges"]
