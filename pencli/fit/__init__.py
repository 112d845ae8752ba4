"""Fitting the Eq. 9 coefficients across runs (pure core), and the field records' own estimates."""

SNOW_WINDOW_MM = 2.5
"""Default window of the SnowMicroPen shot-noise estimates (:mod:`pencli.fit.shot_noise`; Proksch et al. 2015's).
[mm]"""

SNOW_OVERLAP = 0.5
"""Default share of a window that the next one overlaps (Proksch et al. 2015's). [–]"""
