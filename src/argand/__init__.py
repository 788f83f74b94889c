"""Argand: a render farm for algebraic surfaces in complex space."""

__version__ = "0.1.0"
