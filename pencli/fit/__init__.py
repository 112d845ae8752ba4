"""Fitting the Eq. 9 coefficients across runs (pure core)."""
