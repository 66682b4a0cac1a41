"""The read-only web view of a store (``ditherlab web``, ``serve --web``; docs/WEB.md):
tornado and jinja2, server-side pages with small scripts served by ditherlab itself. The
top of the chain beside ``sweeps.cli``: it reads through ``sweeps.lookup``,
``sweeps.overview`` and ``sweeps.exports``, and nothing below imports it."""
