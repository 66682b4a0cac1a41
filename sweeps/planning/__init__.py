"""Planning: a spec turned into what is computed (:class:`Plan`: path, scene, parameters,
numerics, coordinates, points, blocks of balanced cost; sweeps.planning.plan), and the
adaptive refinement of a map's class boundary (``refine``, ``lattice``)."""
