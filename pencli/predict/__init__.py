"""Prediction beyond one design (pure core): batch simulation and sweeps.

One design is simulated by :func:`pencli.model.dynamics.simulate`.
"""
