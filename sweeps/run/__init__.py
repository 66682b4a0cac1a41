"""Running a plan (DESIGN.md §4): ``submit.submit`` under the sweep's lease
(``lease_holder``), the plan's empty cube (``new_cube``), finished blocks into journal and
cube (``sink``), their dispatch to the workers (``dispatch``), a refined sweep's levels
(``refined``), how a run ends (``outcome``), and a running sweep seen from outside
(``progress``)."""
