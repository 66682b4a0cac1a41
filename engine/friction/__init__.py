"""Friction laws, written once: every path (simulate, averaged, harmonic balance) calls these.

- :mod:`.stribeck` -- g(u) (Eq. 2.4) and sigma1(u) (Eq. 2.5) on the parameter vector;
- :mod:`.lugre` -- the bristle rate (Eq. 2.3) and the force F = sigma0 z + sigma1 dz + sigma2 u;
- :mod:`.elastoplastic` -- alpha(z, u) (Eqs. 2.6, 2.7) and the stick/pre-slide/slide phase;
- :mod:`.laws` -- the per-scene composition the time integrators compile (Karnopp band for
  the static laws, Eq. 2.2) and the kinks the integrators land on.
"""
LAWS = ("coulomb", "stribeck", "lugre", "elastoplastic")

__all__ = ["LAWS"]
