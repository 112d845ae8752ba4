"""Prediction beyond one design (pure core): batch simulation and sweeps (issue 6).

One design is simulated by :func:`pencli.model.dynamics.simulate`.
"""
