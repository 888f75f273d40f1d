"""``python -m fitlab``: the ``fitlab`` command."""

import sys

from fitlab.cli import main

sys.exit(main())
