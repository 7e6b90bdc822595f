"""``python -m scanmesh``: the ``scanmesh`` command (see :mod:`scanmesh.cli`)."""

import sys

from scanmesh._entry_point import main

sys.exit(main())
