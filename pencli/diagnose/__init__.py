"""Sim-to-real gap diagnosis (pure core, issue 5)."""

FALSE_ALARM = 0.01
"""Default probability that a campaign with no effect gets any verdict but ``none``."""
BOOTSTRAP = 60
"""Default number of null replicates."""
