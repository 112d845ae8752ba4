"""Fitting the Eq. 9 coefficients across runs (pure core), and the field records' own estimates."""

SNOW_WINDOW_MM = 2.5
"""Default window of the SnowMicroPen shot-noise estimates (:mod:`pencli.fit.shot_noise`; Proksch et al. 2015's).
[mm]"""

SNOW_OVERLAP = 0.5
"""Default share of a window that the next one overlaps (Proksch et al. 2015's). [–]"""

LAYER_MIN_THICKNESS_M = 0.3
"""Thinnest layer a sounding's cut keeps by default (:mod:`pencli.fit.layers`): about eight diameters of a 10 cm²
cone, over which its reading settles after a boundary. [m]"""
