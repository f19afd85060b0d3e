"""``python -m steam_ref``: the same as the ``steam-ref`` command."""

import sys

from .cli import main

sys.exit(main())
