"""The margins of a run's spans, defined once: the tare, the inertia subtraction and the diagnosis read them here.

Plain numbers, no imports: the diagnosis's registry (loaded for ``pen --help``) uses them too.
"""

PRE_TRIGGER_MARGIN_S = 0.005
"""Ignore the last 5 ms before the release when taking the tare (and reading the sensor noise). [s]"""
WINDOW_TRIM_S = 0.5e-3
"""The default analysis window starts this long after contact and ends this long before the stop
(the paper's inner limits, Fig. 11): derivatives of the encoder are least reliable at those instants. [s]"""

__all__ = ["PRE_TRIGGER_MARGIN_S", "WINDOW_TRIM_S"]
