"""``python -m scanmesh``: the ``scanmesh`` command (see :mod:`scanmesh.cli`)."""

import sys

from scanmesh.cli import main

sys.exit(main())
