"""The codes of a cube's flag variables (CF flag variables: ``flag_values`` and
``flag_meanings``), one table each; a module of its own so that the catalogue and the
command line read them without loading numpy or xarray.

``status``, per point: the codes of ``engine.status``, repeated here because ``store``
never imports ``engine`` (a test checks they agree).

``provenance``, per point of a refined sweep (sweeps.planning.refine): computed, inferred
from computed neighbours (their outputs a computed neighbour's), or not yet decided.
"""
OK, NOT_COMPUTED, FAILED, NON_FINITE = 0, 1, 2, 3
STATUS_MEANINGS = ("ok", "not_yet_computed", "failed", "non_finite")

COMPUTED, INFERRED, UNDECIDED = 0, 1, 2
PROVENANCE_MEANINGS = ("computed", "inferred", "not_yet_decided")
