"""``python -m scenarios.cli``: the same as the ``mocap-bench`` command."""

import sys

from scenarios.cli import main

sys.exit(main())
