"""Estimates: the error estimate of a simulated cube (``error_estimate``: the sample, the
finer numerics, the comparison with what the level promises), running it on the workers
(``error_reruns``), and the wall-time estimate of ``ditherlab plan`` (``time_estimate``)
with its record of estimated against measured times (``time_history``)."""
