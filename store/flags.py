"""Point status codes of a cube's ``status`` variable (a CF flag variable).

The codes of ``engine.status``, repeated here because ``store`` never imports ``engine``
(a test checks they agree). A module of its own so that the catalogue and the command
line read them without loading xarray.
"""
OK, NOT_COMPUTED, FAILED, NON_FINITE = 0, 1, 2, 3
STATUS_MEANINGS = ("ok", "not_yet_computed", "failed", "non_finite")
