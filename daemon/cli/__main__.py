"""``python -m daemon.cli``: the ``weatherd`` command."""

import sys

from daemon.cli import main

sys.exit(main())
