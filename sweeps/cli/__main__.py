"""``python -m sweeps.cli`` = the ``ditherlab`` command."""
import sys

from .main import entry

sys.exit(entry())
