"""End-to-end tests: everything that starts the ``ditherlab`` command, a dask cluster,
Slurm or a browser (the unit tests sit under the package they test). They share the
fixtures of the sweep tests (a spec file, the processes' environment, the block gate) and
of the web view's (its store, a server)."""
from ..sweeps.conftest import env, gate, spec_file  # noqa: F401  (fixtures)
from ..sweeps.web.conftest import running, serve_ctx, server, web_store  # noqa: F401  (fixtures)
