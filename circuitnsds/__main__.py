"""``python -m circuitnsds`` is the ``circuitnsds`` command."""

import sys

from circuitnsds.cli import main

sys.exit(main())
