"""Friction laws: small pure njit functions, one module per law."""
from . import elastoplastic, lugre, stribeck

LAWS = ("coulomb", "stribeck", "lugre", "elastoplastic")

__all__ = ["LAWS", "elastoplastic", "lugre", "stribeck"]
