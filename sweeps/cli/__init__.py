"""The ``ditherlab`` command line (DESIGN.md §5); see :mod:`sweeps.cli.main`."""
from .main import build_parser, entry, main

__all__ = ["build_parser", "entry", "main"]
