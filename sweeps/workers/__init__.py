"""The dask side: what a worker computes (``task``: one block of points through the engine)
and the cluster of workers (``cluster``: a LocalCluster or a scheduler's client)."""
