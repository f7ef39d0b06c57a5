"""``python -m layered_brdf_addon``: the command line (see :mod:`layered_brdf_addon.cli`)."""
import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
