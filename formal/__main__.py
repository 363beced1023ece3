"""``python -m formal``: see :mod:`formal.cli`."""

import sys

from .cli import main

sys.exit(main())
