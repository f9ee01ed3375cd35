"""``python -m phys2d``: the phys2d command line (see ``phys2d.cli``)."""

import sys

from .cli import main

sys.exit(main())
