"""``python -m fitlab``: the ``fitlab`` command."""

import sys

from fitlab import _interrupt

_interrupt.install()  # Ctrl-C is fitlab's before the command's imports start (fitlab.cli.main installs it too)
try:
    from fitlab.cli import main
except KeyboardInterrupt:
    _interrupt.close(ignore=True)
    print("fitlab: interrupted", file=sys.stderr)
    sys.exit(130)

sys.exit(main())
