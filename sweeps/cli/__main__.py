"""``python -m sweeps.cli`` = the ``ditherlab`` command."""
import sys

from .main import main

sys.exit(main())
