"""Figures and HTML/PDF reports from result objects (edge)."""
