"""Sim-to-real gap diagnosis (pure core, issue 5)."""
