"""Coefficient tables of the atmosphere models, as Python constants (no package-data files)."""
