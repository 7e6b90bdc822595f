"""``python -m scanmesh.cli``: the ``scanmesh`` command, as ``python -m scanmesh`` runs it."""

import sys

from scanmesh.cli import main

sys.exit(main())
