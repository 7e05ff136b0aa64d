"""``python -m circuitnsds`` is the ``circuitnsds`` command."""

import sys

from circuitnsds.cli.main import main

sys.exit(main())
