"""Compiled (numba) parts of the transient engine."""
